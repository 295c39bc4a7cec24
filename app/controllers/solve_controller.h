// Solves a session on disk: decode its RAW frames, develop them, predict the
// light at every pixel, solve normals and albedo, write maps and a report into
// a new results/<run-id>/ folder beside any earlier results.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/io/raw_decoder.h"
#include "app/io/result_maps.h"
#include "calibration/raw_develop.h"
#include "pipeline/albedo_color.h"
#include "pipeline/depth_refinement.h"
#include "pipeline/ground_truth_evaluation.h"
#include "solver/angular_error.h"
#include "solver/photometric_solver.h"

namespace scanbench {

struct SolveOptions {
  PhotometricSolverOptions solver;
  RawDevelopOptions develop;
  std::string run_label;                 // part of the result folder name: [A-Za-z0-9._-]*; "" = the method name
  bool verify_checksums = true;          // re-hash every frame against session.json
  // 32-bit float EXR maps (zip) instead of half float (ResultMapExrEncoding);
  // the PNGs are the same either way.
  bool float32_maps = false;
  // Solve the normals per raw pixel from its own CFA sample
  // (SolvePhotometricStereoBayer, issue #13) instead of on the demosaiced
  // frames; only the albedo is demosaiced. The depth refinement's re-solves
  // (when the height range triggers them) use the demosaiced frames.
  bool bayer_domain = false;
  // With the adaptive method: blend each pixel's normal between the
  // demosaiced solve and a Bayer-domain one (BandedSolveOptions::bayer_blend,
  // issue #13), also in the depth re-solves (with the first re-solve's
  // weights). Ignored with bayer_domain or another method. The default since
  // session 2026-12-03 (docs/solver.md, "Blend of the demosaiced and
  // Bayer-domain normals").
  bool bayer_blend = true;
  // --- calibration (issue #4) ---
  // A calibration set (app/session/calibration_set.h): lights, white balance
  // and camera rays from it instead of the session's rig description. Empty =
  // the rig description. A set of another camera, lens or resolution is refused.
  std::filesystem::path calibration_dir;
  double calibration_max_age_days = 90;  // an older set warns, > 0
  // --- end calibration ---
  // The albedo's colour space (issue #12): the set's colour calibration, else
  // the RAW files' camera matrix, else white-balanced camera RGB.
  AlbedoColorOptions albedo_color;
  // Draped samples (issue #15): re-solve with the surface points moved to the
  // integrated height (pipeline/depth_refinement.h).
  DepthRefinementOptions depth;
  // Latency, not the result (the live solve sets it): when the depth
  // refinement may re-solve, write the first pass's maps while it is solved
  // instead of spilling it whole until the decision, keeping only its normals
  // and status aside (13 instead of 44 bytes a pixel); a draped sample's
  // streamed files are dropped and the re-solve's written. The same files;
  // about 0.1 GB more peak and, on a draped sample, an encoding for nothing.
  bool stream_first_pass = false;

  void Check() const;
};

struct Session;

struct SolveSummary {
  std::filesystem::path result_dir;
  std::string inputs_fingerprint;               // SolveInputsFingerprint, as in report.json
  std::string sample_name;
  int width = 0, height = 0, num_lights = 0;
  std::string light_model;                      // what the light field came from
  std::vector<std::string> warnings;            // e.g. a stale calibration (issue #4)
  size_t clipped_samples = 0;                   // raw samples at the clip level, all frames
  PhotometricSolverSummary solver;
  std::vector<StageTiming> timings;             // per step of Run(), in order
  // Against the session's ground truth, on the sample, when it has one.
  std::optional<ErrorStatistics> normal_error_deg;
  std::optional<ErrorStatistics> albedo_error;
  AlbedoColor albedo_color;                     // the albedo's colour space and scale, and where they came from
  std::optional<AlbedoColorErrors> albedo_color_error;  // CIEDE2000 against the ground truth (linear Rec.709)
  size_t unsolved_on_sample = 0;
  std::optional<SpecularMapStatistics> specular;  // when the method made a specular map (specular.exr)
  DepthRefinementSummary depth;                 // issue #15: the depth-aware re-solves
  // Bytes of each map file written (file name -> bytes; report.json and
  // summary.txt themselves not counted), and how the EXRs were stored.
  std::map<std::string, uintmax_t> bytes_written;
  std::string exr_encoding;                     // e.g. "half, piz"
  uintmax_t TotalBytesWritten() const;

  double TotalSeconds() const;
  std::string FullReport() const;               // the human-readable summary.txt
};

// What a result depends on, as canonical JSON text (sorted keys, no spaces):
// every frame's file and SHA-256 as session.json records them, the rig and
// camera parts of session.json, the calibration set's identity (SHA-256 of its
// calibration.json, which lists its field files' checksums), the options that
// change the result (method and every threshold, develop options; not the
// thread count, run label, checksum verification or calibration age limit;
// float32_maps adds "exr_maps": "float32", absent for the default half maps,
// so that fingerprints of earlier results stay valid),
// and the software version. Reads <calibration_dir>/calibration.json when a
// set is used; no frame is read (the recorded checksums stand for them).
std::string SolveInputsCanonicalText(const Session& session, const SolveOptions& options);
// SHA-256 (lower-case hex) of SolveInputsCanonicalText: equal fingerprints =
// the same result. Recorded as "inputs_fingerprint" in report.json; `scanbench
// batch` skips a session that already has a result with it.
std::string SolveInputsFingerprint(const Session& session, const SolveOptions& options);

struct FrameRecord;

// One frame of `session` read and decoded, its size checked against the
// session's camera: the one decode `scanbench solve` and the live solve
// (live_solve.h) share.
DecodedRaw DecodeSessionFrame(const std::filesystem::path& session_dir, const Session& session,
                              const FrameRecord& record);

// What a solve can do before its last frame exists: the light field (from the
// rig description or the calibration set; it needs only the session's rig and
// camera) and the frames decoded so far. The live solve builds one while the
// capture runs and hands it to SolveController::UsePreparation, so that after
// the last frame only the solve itself is left. A solve with a preparation is
// bit-equal to one without.
class SolvePreparation {
 public:
  // Builds the light field for `session`, which may still lack frames;
  // `options` must be the ones the solve runs with (its calibration part).
  SolvePreparation(const std::filesystem::path& session_dir, const Session& session, const SolveOptions& options);
  SolvePreparation(SolvePreparation&&) noexcept;
  SolvePreparation& operator=(SolvePreparation&&) noexcept;
  ~SolvePreparation();

  // Keeps `decoded` (DecodeSessionFrame of `record`). The solve uses it for
  // the frame session.json lists with the same file and SHA-256, and decodes
  // any other frame itself.
  void AddFrame(const FrameRecord& record, DecodedRaw decoded);
  int num_frames() const;
  // The rig light field's table-plane points made once and held
  // (ComputeTablePoints on num_threads, 0 = all: the same floats the solve
  // otherwise makes on request, band by band; 12 bytes a pixel, 193 MB at
  // 16 MP), so that the solve after the last frame does not undistort every
  // pixel's ray again (about 2 s of CPU at 16 MP). Nothing for a calibration
  // set's measured light field. The result is the same either way.
  void HoldSurfacePoints(int num_threads);
  bool holds_surface_points() const;
  // Develops the held frame of `record` (an LED frame of `session`) whole,
  // against the held dark frame, as the solve's bands would be developed
  // (DevelopOptionsFor, banded_solve.h), and keeps it: the solve then copies
  // its bands' rows from it instead of demosaicing them after the last frame
  // (RawFrameStack::developed; the same values). 18 bytes a pixel with the
  // Bayer blend's mosaic (290 MB a frame at 16 MP), held until the solve has
  // run. Returns false (and keeps nothing) when the frame or the dark frame
  // is not held, or `record` is not an LED frame.
  bool DevelopFrame(const Session& session, const FrameRecord& record);
  int num_developed_frames() const;

  struct State;  // the light field and the frames (solve_controller.cc)

 private:
  friend class SolveController;
  std::unique_ptr<State> state_;
};

struct GroundTruthFiles;

// The evaluation (pipeline/ground_truth_evaluation.h) of a width x height
// solution against a session's ground-truth files (a simulated rig's): the
// sample mask read whole (its first channel > 127 = on the sample), the true
// normals and albedo a band of rows at a time from their files; a file of
// another size is refused, naming it. Spill files in `spill_folder` (empty =
// the temporary folder).
GroundTruthEvaluation SessionGroundTruthEvaluation(const std::filesystem::path& session_dir,
                                                   const GroundTruthFiles& truth, int width, int height,
                                                   const std::filesystem::path& spill_folder = {});

class SolveController : public BaseController {
 public:
  SolveController(std::filesystem::path session_dir, SolveOptions options);
  ~SolveController() override;
  // The next Run() starts from `preparation` (made for this session and these
  // options) instead of building the light field and decoding every frame.
  void UsePreparation(SolvePreparation preparation);
  void Run() override;
  const SolveSummary& summary() const { return summary_; }

 private:
  std::filesystem::path session_dir_;
  SolveOptions options_;
  SolveSummary summary_;
  std::unique_ptr<SolvePreparation::State> preparation_;
};

}  // namespace scanbench
