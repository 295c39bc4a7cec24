// Renders a capture session on the simulated rig and writes it to disk exactly
// as the capture sequencer would: DNG frames, a journalled session.json, plus
// the ground truth a real bench cannot give.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "app/controllers/base_controller.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/target_renderer.h"
#include "app/sim/textile_scene.h"

namespace scanbench {

// The simulated camera's capture settings, for scans and calibration targets alike.
inline constexpr double kSimulatedExposureTimeS = 0.1;
inline constexpr double kSimulatedIso = 100;
inline constexpr double kSimulatedFNumber = 8;

struct Session;
struct SimulatedSceneRecord;

// A new session of the simulated camera (make, model, serial "SIM-<seed>",
// lens, ISO, aperture, the rig options' size), not yet on disk. The model
// names the colour model: "Simulated D5100" (the spectral D5100) or
// "Simulated D5100 (sRGB primaries)", so a calibration set of one does not fit
// the other.
Session NewSimulatedSession(const std::string& sample_name, const std::string& notes, const RigDescription& rig,
                            const SimulatedRigOptions& rig_options, double exposure_time_s);

// What session.json records of a simulated scene (Session::simulation), from
// the options that render it.
SimulatedSceneRecord SimulatedSceneOf(const SimulatedRigOptions& rig, const TextileSceneOptions& scene);

// The session camera model of a simulated camera with `color`.
std::string SimulatedCameraModel(SensorColorModel color);

// Encodes `raw` as a DNG of the session's camera and journals it as the frame
// of LED `led` (nullopt = the dark frame), as the capture sequencer would. The
// DNG carries the camera's colour data as a real camera's file does:
// ColorMatrix1 (D65) = SimulatedCameraFromXyzD65(color), AsShotNeutral = its
// LEDs' white.
void AddSimulatedFrame(const std::filesystem::path& session_dir, Session& session, std::optional<int> led,
                       const RawImage& raw, SensorColorModel color);

struct SimulateOptions {
  SimulatedRigOptions rig;                 // sensor, size, noise, seed, colour model (--camera-color)
  TextileSceneOptions scene;               // the sample (scene.sample = kColorChecker: --sample colorchecker)
  std::string sample_name = "simulated twill";
  std::string notes = "rendered by the scanbench simulated rig";
  bool write_ground_truth = true;          // normal, albedo, height, mask beside the frames
  // The rig description session.json records (issue #4): the simulator's
  // truth (default: the solve then needs no calibration), or what an operator
  // would have measured (MakeMeasuredRigDescription: LED positions a few mm
  // off, nominal mu, intensity and camera), which a calibration set corrects.
  enum class RigDescriptionKind { kTrue, kMeasured };
  RigDescriptionKind rig_description = RigDescriptionKind::kTrue;
  MeasuredRigOptions measured;             // how far off the measured description is

  void Check() const;
};

struct SimulateSummary {
  std::filesystem::path session_dir;
  int frames_written = 0;   // this run
  int frames_resumed = 0;   // found already on disk from an interrupted run
  double seconds = 0;
};

class SimulateController : public BaseController {
 public:
  SimulateController(std::filesystem::path session_dir, SimulateOptions options);

  // Writes a new session, or completes an interrupted one in the same folder
  // (same options: frames are deterministic). A complete session is refused.
  void Run() override;
  const SimulateSummary& summary() const { return summary_; }

 private:
  // session.json of a new run: the rig description the options ask for.
  Session NewSession(const SimulatedRig& rig) const;
  // A render's progress, reported as part `part` of `parts` of
  // `reported_stage`; a stop throws Cancelled(stage) from inside the render.
  ProgressCallback RenderCallback(const std::string& stage, const std::string& reported_stage, int part,
                                  int parts) const;

  std::filesystem::path session_dir_;
  SimulateOptions options_;
  SimulateSummary summary_;
};

}  // namespace scanbench
