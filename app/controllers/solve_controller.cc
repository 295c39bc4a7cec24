#include "app/controllers/solve_controller.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <exception>
#include <functional>
#include <future>
#include <iomanip>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/io/result_maps.h"
#include "app/session/albedo_color_choice.h"
#include "app/session/calibrated_lighting.h"  // issue #4
#include "app/session/calibration_set.h"
#include "app/session/session.h"
#include "calibration/camera_model.h"
#include "calibration/rig_light_field.h"
#include "core/bounded_worker.h"
#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "core/spill_file.h"
#include "core/summary.h"
#include "pipeline/banded_solve.h"
#include "pipeline/error_statistics.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

const char* DemosaicName(RawDevelopOptions::Demosaic demosaic) {
  return demosaic == RawDevelopOptions::Demosaic::kBilinear ? "bilinear" : "edge_aware";
}

nlohmann::json StatisticsJson(const ErrorStatistics& stats) {
  return {{"pixels", stats.num_pixels}, {"mean", stats.mean}, {"median", stats.median},
          {"p95", stats.percentile_95}, {"max", stats.max}};
}

// Everything is written into a hidden staging folder that replaces the
// reserved, empty result folder at the very end: a result folder is either
// complete or absent.
class StagedResultFolder {
 public:
  explicit StagedResultFolder(fs::path final_dir)
      : final_dir_(std::move(final_dir)),
        staging_dir_(final_dir_.parent_path() / ("." + final_dir_.filename().string() + ".partial")) {
    fs::create_directory(staging_dir_);
  }
  ~StagedResultFolder() {
    if (committed_) return;
    std::error_code ignored;
    fs::remove_all(staging_dir_, ignored);
    fs::remove(final_dir_, ignored);  // still the empty reservation
  }
  const fs::path& staging() const { return staging_dir_; }
  void Commit() {
    RenameDurably(staging_dir_, final_dir_);  // replaces the empty reserved folder
    committed_ = true;
  }

 private:
  fs::path final_dir_;
  fs::path staging_dir_;
  bool committed_ = false;
};

ImageU8 SampleMaskFromGroundTruth(const fs::path& session_dir, const GroundTruthFiles& truth) {
  const ImageU8 stored = ReadImageU8(session_dir / truth.mask_file);
  ImageU8 mask(stored.width(), stored.height(), 1);
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] = stored.data()[i * stored.channels()] > 127;
  return mask;
}

const char* RobustLossName(PhotometricSolverOptions::RobustLoss loss) {
  return loss == PhotometricSolverOptions::RobustLoss::kCauchy ? "cauchy" : "tukey";
}

// Every field of PhotometricSolverOptions but num_threads (same result on any
// count): what the inputs fingerprint hashes and what report.json records.
// adaptive_coherent_sheen (issue #13's shared sheen, the adaptive method's
// default) only where it runs, so that results made before it, and with
// --no-coherent-sheen or another method, keep their fingerprints; its value
// is the pass's revision where that changes results (true: the first; 2:
// the per-block gate, session 2026-12-03 #4).
nlohmann::json SolverOptionsJson(const PhotometricSolverOptions& solver) {
  nlohmann::json json = {{"method", PhotometricMethodName(solver.method)},
          {"luminance_weights", solver.luminance_weights},
          {"min_lights", solver.min_lights},
          {"max_condition_number", solver.max_condition_number},
          {"min_sample_value", solver.min_sample_value},
          {"min_light_intensity", solver.min_light_intensity},
          {"min_albedo", solver.min_albedo},
          {"compute_albedo", solver.compute_albedo},
          {"compute_confidence", solver.compute_confidence},
          {"tile_size", solver.tile_size},
          {"light_tolerance", solver.light_tolerance},
          {"robust_loss", RobustLossName(solver.robust_loss)},
          {"robust_loss_width", solver.robust_loss_width},
          {"robust_min_scale", solver.robust_min_scale},
          {"robust_max_iterations", solver.robust_max_iterations},
          {"robust_dark_fraction", solver.robust_dark_fraction},
          {"adaptive_robust_residual", solver.adaptive_robust_residual},
          {"adaptive_lobe", solver.adaptive_lobe},
          {"adaptive_coherent_lobe", solver.adaptive_coherent_lobe},
          {"adaptive_sheen", solver.adaptive_sheen}};
  if (solver.method == PhotometricSolverOptions::Method::kAdaptive && solver.adaptive_coherent_sheen) {
    json["adaptive_coherent_sheen"] = 2;
  }
  return json;
}


nlohmann::json DepthOptionsJson(const DepthRefinementOptions& depth) {
  return {{"enabled", depth.enabled},
          {"max_iterations", depth.max_iterations},
          {"tolerance_mm", depth.tolerance_mm},
          {"min_height_range_mm", depth.min_height_range_mm},
          {"anchor_percentile", depth.anchor_percentile},
          {"shadow_edge_radius_px", depth.shadow_edge_radius_px},
          {"shadow_edge_level", depth.shadow_edge_level}};
}

// The steps of SolveController::Run, in order.

// Load: the manifest is checked, every frame re-hashed when asked.
Session LoadCompleteSession(const fs::path& session_dir, bool verify_checksums, int num_threads) {
  SessionLoadOptions load_options;
  load_options.verify_checksums = verify_checksums;
  load_options.num_threads = num_threads;
  Session session = LoadSession(session_dir, load_options);
  if (!session.capture_complete) {
    throw SessionError((session_dir / "session.json").string() +
                       ": capture_complete: false; resume the capture before solving");
  }
  return session;
}

// The session's frames as decoded: raw uint16 mosaics, developed band by band
// in the solve (banded_solve.h) so that no full-frame float RGB is held.
struct RawFrames {
  RawImage dark;
  std::vector<RawImage> leds;          // one per LED, the rig's order
  std::vector<double> exposure_scales;  // per LED frame (FrameExposureScale)
  std::string dark_file;               // as session.json names it
  // The RAW files' own colour matrix (XYZ -> camera native, D65), from the first LED frame.
  std::optional<Eigen::Matrix3d> camera_from_xyz;
  std::string first_led_file;
  // One line per frame whose exposure differs from the session's (imports).
  std::vector<std::string> exposure_notes;
  // Per LED frame, the frame developed ahead (SolvePreparation::DevelopFrame)
  // or null; not owned. Empty without a preparation.
  std::vector<const DevelopedFrame*> developed_ahead;

  RawFrameStack Stack() const {
    RawFrameStack stack;
    stack.dark = &dark;
    for (const RawImage& led : leds) stack.frames.push_back(&led);
    stack.exposure_scales = exposure_scales;
    stack.developed = developed_ahead;
    return stack;
  }
};

// Frames decoded ahead of the solve (SolvePreparation), by file name.
struct PreparedFrame {
  std::string sha256;  // as the record that was decoded names it
  DecodedRaw decoded;
};
using PreparedFrames = std::map<std::string, PreparedFrame>;

// Decodes the dark and LED frames, several at once on the one thread pool,
// taking those `prepared` holds for the same file and checksum from it;
// `progress` gets the frames done, false from it stops with Cancelled.
RawFrames DecodeFrames(const fs::path& session_dir, const Session& session, int num_threads,
                       const ProgressCallback& progress, PreparedFrames* prepared = nullptr) {
  const int num_lights = static_cast<int>(session.rig.leds.size());
  std::vector<const FrameRecord*> records = {FindDarkFrame(session)};
  for (int k = 0; k < num_lights; ++k) records.push_back(FindLedFrame(session, k));
  std::vector<DecodedRaw> decoded(records.size());
  std::vector<int> to_decode;
  for (int i = 0; i < static_cast<int>(records.size()); ++i) {
    const auto found = prepared ? prepared->find(records[i]->file) : PreparedFrames::iterator();
    if (prepared && found != prepared->end() && found->second.sha256 == records[i]->sha256) {
      decoded[i] = std::move(found->second.decoded);
      prepared->erase(found);
    } else {
      to_decode.push_back(i);
    }
  }
  const int count = static_cast<int>(to_decode.size());
  const bool finished = ParallelFor(
      count, ResolveThreadCount(num_threads), 1,
      [&](int first, int last, int) {
        for (int i = first; i < last; ++i) {
          decoded[to_decode[i]] = DecodeSessionFrame(session_dir, session, *records[to_decode[i]]);
        }
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(double(done) / count); })
               : std::function<bool(int)>());
  if (!finished) throw Cancelled("decode RAW");

  RawFrames frames;
  frames.dark_file = records[0]->file;
  frames.dark = std::move(decoded[0].image);
  for (int k = 0; k < num_lights; ++k) {
    const FrameRecord& record = *records[k + 1];
    DecodedRaw& raw = decoded[k + 1];
    const fs::path path = session_dir / record.file;
    if (raw.image.cfa != frames.dark.cfa) {
      throw std::runtime_error(path.string() + ": CFA pattern " + CfaPatternName(raw.image.cfa) +
                               " differs from the dark frame's " + CfaPatternName(frames.dark.cfa));
    }
    if (k == 0) {
      frames.first_led_file = path.string();
      frames.camera_from_xyz = raw.camera_from_xyz;
    }
    // The rig's intensities are for the session's exposure; a frame exposed
    // longer reads proportionally brighter (the RAW is linear).
    const double scale = FrameExposureScale(session, record);
    if (scale != 1) {
      frames.exposure_notes.push_back(record.file + ": exposed " + Fixed(record.exposure_time_s, 6) +
                                      " s, scaled by " + Fixed(scale, 6) + " to the session's " +
                                      Fixed(session.camera.exposure_time_s, 6) + " s");
    }
    frames.exposure_scales.push_back(scale);
    frames.leds.push_back(std::move(raw.image));
  }
  return frames;
}

BandedSolveOptions BandedOptions(const SolveOptions& options) {
  BandedSolveOptions banded;
  banded.solver = options.solver;
  banded.develop = options.develop;
  banded.bayer_domain = options.bayer_domain;
  banded.bayer_blend = options.bayer_blend && !options.bayer_domain &&
                       options.solver.method == PhotometricSolverOptions::Method::kAdaptive;
  return banded;
}

// The light at every pixel: from the calibration set when one is given (issue
// #4), else from the rig description.
struct Lighting {
  std::unique_ptr<LightField> light_field;
  std::string light_model;            // one line for reports
  std::vector<std::string> warnings;  // e.g. a stale calibration set
  nlohmann::json calibration_report;  // report.json's "calibration"
  std::shared_ptr<const CalibrationSet> set;  // null without a calibration set
  std::string set_name;
  CameraGeometry camera;              // whose rays meet the surface (issue #15)
};

Lighting MakeLighting(const SolveOptions& options, const fs::path& session_dir, const Session& session) {
  Lighting lighting;
  if (options.calibration_dir.empty()) {
    lighting.light_field = MakeRigLightField(session.rig);
    lighting.camera = session.rig.camera;
    lighting.light_model =
        "rig description: point LEDs (position, axis, mu, RGB intensity), surface on the table plane (no calibration "
        "set given)";
    lighting.calibration_report = {{"used", nullptr}};
  } else {
    CalibrationUseOptions use;
    use.max_age_days = options.calibration_max_age_days;
    CalibratedLighting calibrated =
        MakeCalibratedLighting(options.calibration_dir, session, (session_dir / "session.json").string(), use);
    lighting.light_field = std::move(calibrated.light_field);
    lighting.light_model = calibrated.light_model;
    lighting.warnings = calibrated.warnings;
    lighting.calibration_report = nlohmann::json::parse(calibrated.report_json);
    lighting.set = calibrated.set;
    lighting.set_name = (options.calibration_dir / kCalibrationManifestName).string();
    lighting.camera = lighting.set->camera_calibration->summary.camera;
  }
  lighting.calibration_report["light_model"] = lighting.light_model;
  return lighting;
}

// The depth-aware re-solves (issue #15), band by band as the first solve:
// only point LEDs can be moved off the table plane; a measured per-pixel
// field is sampled on it only.
// `raw_frames` gives the decoded frames, decoding them again when they were
// dropped after the first solve (a flat sample never re-solves).
DepthRefinementSummary RefineOnDepth(const SolveOptions& options, const std::function<const RawFrames&()>& raw_frames,
                                     const Lighting& lighting, PhotometricSolution* solution,
                                     const ProgressCallback& progress) {
  const auto* point_field = dynamic_cast<const PointLightField*>(lighting.light_field.get());
  if (options.depth.enabled && point_field == nullptr) {
    DepthRefinementSummary skipped;
    skipped.termination = Termination::kSuccess;
    skipped.stop_reason =
        "not applicable: the calibration set's measured per-pixel light field is sampled on the table plane only";
    return skipped;
  }
  // The Bayer blend's cell weights of the first re-solve, kept for the next
  // ones, so that the re-solves differ by the moved light field only (with
  // the opt-in blend's sheen fit, weights re-estimated every pass made the
  // loop overshoot; docs/solver.md).
  ImageF blend_weights;
  const DepthResolve resolve = [&](const LightField& moved_field, PhotometricSolution* resolved,
                                   const ProgressCallback& resolve_progress, size_t* shadow_edge_samples) {
    BandedSolveOptions banded_options = BandedOptions(options);
    banded_options.bayer_domain = false;  // the re-solves use the demosaiced frames (SolveOptions::bayer_domain)
    if (banded_options.bayer_blend && !blend_weights.empty()) banded_options.bayer_blend_weights = &blend_weights;
    if (options.depth.shadow_edge_radius_px > 0) {
      banded_options.sample_mask_margin_rows = options.depth.shadow_edge_radius_px;
      banded_options.sample_masks = [&](const PhotometricSolverInput& band) {
        return ShadowEdgeSampleMasks(options.depth, options.solver, band);
      };
    }
    const BandedSolveSummary banded =
        SolveBanded(banded_options, raw_frames().Stack(), moved_field, resolved, resolve_progress);
    *shadow_edge_samples = banded.samples_masked_out;
    if (banded_options.bayer_blend && blend_weights.empty() && banded.IsUsable()) {
      blend_weights = banded.bayer_blend_weights;
    }
    return banded.solver;
  };
  const std::vector<PointLight> no_lights;
  return RefineDepth(options.depth, resolve, point_field ? point_field->lights() : no_lights, lighting.camera,
                     solution, nullptr, progress);
}

nlohmann::json DepthRefinementJson(const DepthRefinementSummary& depth, const DepthRefinementOptions& options) {
  nlohmann::json iterations = nlohmann::json::array();
  for (const DepthIteration& it : depth.iterations) {
    iterations.push_back({{"max_move_mm", it.max_move_mm},
                          {"mean_move_mm", it.mean_move_mm},
                          {"p99_move_mm", it.p99_move_mm},
                          {"height_range_mm", it.height_range_mm},
                          {"seconds", it.seconds}});
  }
  return {{"enabled", options.enabled},
          {"refined", depth.refined},
          {"iterations", iterations},
          {"first_height_range_mm", depth.first_height_range_mm},
          {"decision_block_px", depth.decision_block_px},
          {"shadow_edge_samples", depth.shadow_edge_samples},
          {"stop_reason", depth.stop_reason},
          {"seconds", depth.seconds},
          {"message", depth.BriefReport()}};
}

nlohmann::json SolveReportJson(const SolveSummary& summary, const SolveOptions& options, const fs::path& session_dir,
                               const std::string& dark_file, const nlohmann::json& calibration_report,
                               const std::map<std::string, std::string>& outputs) {
  nlohmann::json report;
  report["schema"] = "scanbench.solve_report/1";
  report["software_version"] = "scanbench " SCANBENCH_VERSION;
  report["created"] = FormatUtcTimestamp(std::chrono::system_clock::now());
  report["run_id"] = summary.result_dir.filename().string();
  report["inputs_fingerprint"] = summary.inputs_fingerprint;  // scanbench batch: same inputs, same result
  report["session"] = {{"path", fs::absolute(session_dir).string()},
                       {"sample_name", summary.sample_name},
                       {"width", summary.width},
                       {"height", summary.height},
                       {"leds", summary.num_lights}};
  report["solver"] = SolverOptionsJson(options.solver);
  report["solver"]["num_threads"] = summary.solver.num_threads;
  report["solver"]["depth_refinement"] = DepthOptionsJson(options.depth);
  report["develop"] = {{"demosaic", DemosaicName(options.develop.demosaic)},
                       {"bayer_domain", options.bayer_domain},
                       {"bayer_blend", BandedOptions(options).bayer_blend},
                       {"clip_fraction", options.develop.clip_fraction},
                       {"dark_frame", dark_file},
                       {"clipped_raw_samples", summary.clipped_samples}};
  report["calibration"] = calibration_report;  // issue #4: which calibration solved it, and why
  report["color"] = nlohmann::json::parse(summary.albedo_color.ReportJson());  // issue #12
  nlohmann::json by_status;
  for (int s = 0; s < kNumPixelStatuses; ++s) {
    by_status[PixelStatusName(static_cast<PixelStatus>(s))] = summary.solver.pixels_by_status[s];
  }
  report["result"] = {{"termination", "success"},
                      {"message", summary.solver.BriefReport()},
                      {"pixels", summary.solver.num_pixels},
                      {"pixels_by_status", by_status}};
  if (summary.normal_error_deg) {
    report["ground_truth"] = {{"normal_angular_error_deg", StatisticsJson(*summary.normal_error_deg)},
                              {"albedo_abs_error", StatisticsJson(*summary.albedo_error)},
                              {"unsolved_on_sample", summary.unsolved_on_sample},
                              {"albedo_color", nlohmann::json::parse(summary.albedo_color_error->ReportJson())},
                              {"evaluated_on", "sample mask, solved pixels"}};
  }
  nlohmann::json timings;
  for (const StageTiming& timing : summary.timings) timings[timing.stage] = timing.seconds;
  if (summary.specular) report["specular"] = nlohmann::json::parse(summary.specular->ReportJson());  // issue #13
  report["depth_refinement"] = DepthRefinementJson(summary.depth, options.depth);  // issue #15
  report["timings_s"] = timings;
  report["outputs"] = outputs;
  report["bytes_written"] = {{"files", summary.bytes_written},
                             {"total", summary.TotalBytesWritten()},
                             {"exr_encoding", summary.exr_encoding},
                             {"not_counted", {"report.json", "summary.txt"}}};
  return report;
}

}  // namespace

struct GroundTruthEvaluation::State {
  std::optional<ImageRowReader> normal_reader, albedo_reader;  // the truth maps, opened once
  ImageF truth_normal_rows, truth_albedo_rows;                  // AddBand's, reused from band to band
  ImageU8 solved_on_sample;                                     // AddBand's, reused
  ImageU8 on_sample;  // whole size
  int rows_added = 0;
  size_t unsolved_on_sample = 0;
  AlbedoColorComparison color;  // spills the pixels whose truth may be a region's
  FloatErrorStatistics angles;  // the angles, as floats
  FloatErrorStatistics albedo_errors;  // the albedo's absolute errors (pixel, channel), as floats
  std::vector<double> band_values;  // AddBand's, reused from band to band
  explicit State(const fs::path& spill_folder) : color(0.002, spill_folder) {}
};

GroundTruthEvaluation::GroundTruthEvaluation(const fs::path& session_dir, const GroundTruthFiles& truth, int width,
                                             int height, const fs::path& spill_folder)
    : state_(std::make_unique<State>(spill_folder)) {
  state_->normal_reader.emplace(session_dir / truth.normal_file);
  state_->albedo_reader.emplace(session_dir / truth.albedo_file);
  state_->on_sample = SampleMaskFromGroundTruth(session_dir, truth);
  if (!state_->on_sample.SameSize(width, height)) {
    throw std::runtime_error((session_dir / truth.mask_file).string() + ": " +
                             SizeText(state_->on_sample.width(), state_->on_sample.height()) +
                             ", the solution is " + SizeText(width, height));
  }
  // The values held in memory: room for every sample pixel at once, never a
  // second copy while growing.
  const size_t sample_pixels =
      std::count_if(state_->on_sample.data(), state_->on_sample.data() + state_->on_sample.size(),
                    [](uint8_t on) { return on != 0; });
  state_->angles.Reserve(sample_pixels);
  state_->color.Reserve(sample_pixels);
  state_->albedo_errors.Reserve(3 * sample_pixels);
  // The truth's colours over the sample, read once before the bands: the
  // colour comparison then spills only the pixels that may be a uniform
  // region's (a chart's patches), not a textile's every pixel.
  ImageF truth_rows;
  ImageU8 mask_rows;
  for (int y = 0; y < height; y += kEvaluationBandRows) {
    const int rows = std::min(kEvaluationBandRows, height - y);
    state_->albedo_reader->ReadRows(y, y + rows, &truth_rows);
    if (truth_rows.width() != width || truth_rows.channels() != 3) {
      throw std::runtime_error(state_->albedo_reader->path().string() + ": " + ShapeText(truth_rows) +
                               " rows, the solution's are " + SizeText(width, rows) + "x3");
    }
    mask_rows.Reshape(width, rows, 1);
    std::copy(state_->on_sample.row(y), state_->on_sample.row(y) + mask_rows.size(), mask_rows.data());
    state_->color.CountPossibleRegions(truth_rows, mask_rows);
  }
}

GroundTruthEvaluation::~GroundTruthEvaluation() = default;

ImageF GroundTruthEvaluation::AddBand(const PhotometricSolution& band, int num_threads) {
  State& s = *state_;
  const int width = s.on_sample.width(), rows = band.status.height(), y0 = s.rows_added;
  if (band.status.width() != width || rows < 1 || y0 + rows > s.on_sample.height() ||
      !band.normal_in_table.SameSize(band.status) || band.normal_in_table.channels() != 3 ||
      !band.albedo.SameSize(band.status) || band.albedo.channels() != 3) {
    throw std::invalid_argument("GroundTruthEvaluation::AddBand: a band of " + ShapeText(band.status) + " (normals " +
                                ShapeText(band.normal_in_table) + ", albedo " + ShapeText(band.albedo) + ") after " +
                                std::to_string(y0) + " rows of " + ShapeText(s.on_sample));
  }
  s.rows_added += rows;
  ImageU8& solved_on_sample = s.solved_on_sample;
  solved_on_sample.Reshape(width, rows, 1);
  for (size_t i = 0; i < solved_on_sample.size(); ++i) {
    const bool on_sample = s.on_sample.row(y0)[i] != 0;
    const bool solved = band.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    solved_on_sample.data()[i] = on_sample && solved;
    s.unsolved_on_sample += on_sample && !solved;
  }
  const auto read_truth = [&](ImageRowReader& reader, ImageF* truth_rows) -> const ImageF& {
    reader.ReadRows(y0, y0 + rows, truth_rows);
    if (truth_rows->width() != width || truth_rows->channels() != 3) {
      throw std::runtime_error(reader.path().string() + ": " + ShapeText(*truth_rows) + " rows, the solution's are " +
                               SizeText(width, rows) + "x3");
    }
    return *truth_rows;
  };
  ImageF error_rows(width, rows, 1, 0.0f);
  s.band_values.clear();
  AngularErrorsOfRows(band.normal_in_table, read_truth(*s.normal_reader, &s.truth_normal_rows), 0, solved_on_sample,
                      num_threads, &s.band_values, &error_rows);
  s.angles.Add(s.band_values);
  const ImageF& truth_albedo = read_truth(*s.albedo_reader, &s.truth_albedo_rows);
  s.color.AddRows(band.albedo, solved_on_sample, truth_albedo, num_threads);
  // The albedo's absolute error of every channel, pooled in pixel order.
  s.band_values.clear();
  AbsoluteErrorsOfRows(band.albedo, truth_albedo, 0, solved_on_sample, num_threads, &s.band_values);
  s.albedo_errors.Add(s.band_values);
  return error_rows;
}

GroundTruthComparison GroundTruthEvaluation::Finish(int num_threads) {
  State& s = *state_;
  if (s.rows_added != s.on_sample.height()) {
    throw std::logic_error("GroundTruthEvaluation::Finish: " + std::to_string(s.rows_added) + " of " +
                           std::to_string(s.on_sample.height()) + " rows added");
  }
  GroundTruthComparison comparison;
  comparison.unsolved_on_sample = s.unsolved_on_sample;
  // Side by side: the albedo's errors (the most values) and the rest.
  ParallelFor(2, std::min(2, ResolveThreadCount(num_threads)), 1, [&](int begin, int end, int) {
    for (int item = begin; item < end; ++item) {
      if (item == 0) {
        comparison.albedo_error = s.albedo_errors.Finish();
      } else {
        comparison.normal_error_deg = s.angles.Finish();
        comparison.albedo_color_error = s.color.Finish();
      }
    }
  });
  return comparison;
}

GroundTruthComparison CompareWithGroundTruth(const fs::path& session_dir, const GroundTruthFiles& truth,
                                             const PhotometricSolution& solution, int num_threads, int band_rows) {
  if (band_rows < 1) {
    throw std::invalid_argument("CompareWithGroundTruth: band_rows " + std::to_string(band_rows) + " must be >= 1");
  }
  const int width = solution.status.width(), height = solution.status.height();
  GroundTruthEvaluation evaluation(session_dir, truth, width, height);
  ImageF error_map(width, height, 1);
  for (int y = 0; y < height; y += band_rows) {
    const ImageF rows = evaluation.AddBand(SolutionRows(solution, y, std::min(band_rows, height - y)), num_threads);
    std::copy(rows.data(), rows.data() + rows.size(), error_map.row(y));
  }
  GroundTruthComparison comparison = evaluation.Finish(num_threads);
  comparison.angular_error_deg = std::move(error_map);
  return comparison;
}

// A tripwire (x86-64, libstdc++): a new option must be sorted into what changes the
// result (then into the text below) or not (then only this number changes).
#if defined(__x86_64__) && defined(__GLIBCXX__)
static_assert(sizeof(PhotometricSolverOptions) == 144 && sizeof(RawDevelopOptions) == 16 && sizeof(SolveOptions) == 312,
              "an option was added or removed: update SolveInputsCanonicalText, then these sizes");
#endif

std::string SolveInputsCanonicalText(const Session& session, const SolveOptions& options) {
  nlohmann::json frames = nlohmann::json::array();
  for (const FrameRecord& frame : session.frames) {
    frames.push_back({{"file", frame.file},
                      {"kind", frame.kind == FrameKind::kDark ? "dark" : "led"},
                      {"led_index", frame.led_index},
                      {"sha256", frame.sha256}});
    // Only where it changes the result, so one-exposure sessions keep their fingerprints.
    if (const double scale = FrameExposureScale(session, frame); scale != 1) frames.back()["exposure_scale"] = scale;
  }
  // The rig and camera exactly as session.json stores them.
  const nlohmann::json manifest = nlohmann::json::parse(SessionToJson(session));
  nlohmann::json calibration = nullptr;
  if (!options.calibration_dir.empty()) {
    const fs::path path = options.calibration_dir / kCalibrationManifestName;
    calibration = {{"manifest_sha256", Sha256HexOfFile(path)}};
  }
  const PhotometricSolverOptions& solver = options.solver;
  nlohmann::json text;
  text["schema"] = "scanbench.solve_inputs/1";
  text["software_version"] = "scanbench " SCANBENCH_VERSION;
  text["frames"] = frames;
  text["rig"] = manifest.at("rig");
  text["camera"] = manifest.at("camera");
  text["calibration"] = calibration;
  text["solver"] = SolverOptionsJson(solver);
  text["develop"] = {{"demosaic", DemosaicName(options.develop.demosaic)},
                     {"clip_fraction", options.develop.clip_fraction}};
  // Only when set, so that earlier results keep their fingerprints; the
  // blend as 2 since it became the default (frozen depth-loop weights, the
  // Bayer solve without sheen and lobe), so that a result of the opt-in
  // blend (true) is not taken for one of today's; 3 since the gate (the
  // Bayer solve only on the cells SelectBayerBlendCells picks); 4 since the
  // shared lobe's pixels take its re-solve from their raw samples (issue #13).
  if (options.bayer_domain) text["develop"]["bayer_domain"] = true;
  if (BandedOptions(options).bayer_blend) text["develop"]["bayer_blend"] = 4;
  text["albedo_color"] = AlbedoColorSourceName(options.albedo_color.source);
  text["depth_refinement"] = DepthOptionsJson(options.depth);  // issue #15
  if (options.float32_maps) text["exr_maps"] = "float32";
  return text.dump();  // nlohmann::json sorts object keys: canonical
}

std::string SolveInputsFingerprint(const Session& session, const SolveOptions& options) {
  const std::string text = SolveInputsCanonicalText(session, options);
  return Sha256Hex(std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
}

void SolveOptions::Check() const {
  solver.Check();
  develop.Check();
  depth.Check();
  static const std::regex kLabel("[A-Za-z0-9._-]+");
  if (!run_label.empty() && !std::regex_match(run_label, kLabel)) {
    throw FieldError("SolveOptions", "run_label", "'" + run_label + "'", "must be letters, digits, '.', '_' or '-' only");
  }
  SCANBENCH_REQUIRE_GT("SolveOptions", "calibration_max_age_days", calibration_max_age_days, 0);  // issue #4
}

uintmax_t SolveSummary::TotalBytesWritten() const {
  uintmax_t total = 0;
  for (const auto& [name, bytes] : bytes_written) total += bytes;
  return total;
}

double SolveSummary::TotalSeconds() const {
  double total = 0;
  for (const StageTiming& timing : timings) total += timing.seconds;
  return total;
}

std::string SolveSummary::FullReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  out << "scanbench solve report\n"
      << "  sample:       " << sample_name << "\n"
      << "  result:       " << result_dir.string() << "\n"
      << "  frames:       " << num_lights << " LEDs + dark, " << width << "x" << height << "\n"
      << "  light model:  " << light_model << "\n"
      << "  albedo:       " << albedo_color.color_space << ", " << albedo_color.scale << "; "
      << albedo_color.description << "\n"
      << "  albedo scale: " << albedo_color.scale_source << "\n"
      << "  clipped raw samples: " << clipped_samples << "\n"
      << "  " << solver.BriefReport() << "\n";
  for (const std::string& warning : warnings) out << "  warning: " << warning << "\n";  // issue #4
  if (normal_error_deg) {
    out << "  normal angular error vs ground truth on the sample (deg): mean " << normal_error_deg->mean
        << ", median " << normal_error_deg->median << ", p95 " << normal_error_deg->percentile_95 << ", max "
        << normal_error_deg->max << " over " << normal_error_deg->num_pixels << " px\n";
  }
  if (albedo_error) {
    out << "  albedo absolute error on the sample: mean " << albedo_error->mean << ", median "
        << albedo_error->median << ", p95 " << albedo_error->percentile_95 << "\n";
  }
  if (albedo_color_error) {
    const AlbedoColorErrors& e = *albedo_color_error;
    out << "  albedo CIEDE2000 vs ground truth (linear Rec.709) per pixel: mean " << e.delta_e.mean << ", median "
        << e.delta_e.median << ", p95 " << e.delta_e.percentile_95 << "\n";
    if (e.chart_patches > 0) {
      out << "  albedo CIEDE2000 over " << e.chart_patches << " ColorChecker patches (median albedo per patch): mean "
          << e.chart_mean_delta_e << ", max " << e.chart_max_delta_e << "\n";
    }
  }
  if (normal_error_deg) out << "  unsolved pixels on the sample: " << unsolved_on_sample << "\n";
  if (specular) out << "  " << specular->BriefReport() << "\n";
  out << "  " << depth.BriefReport() << "\n";  // issue #15
  if (!bytes_written.empty()) {
    out << "  bytes written (" << exr_encoding << " EXR):";
    for (const auto& [name, bytes] : bytes_written) out << " " << name << " " << bytes << ";";
    out << " total " << TotalBytesWritten() << " (" << std::setprecision(1) << TotalBytesWritten() / 1e6
        << " MB)\n" << std::setprecision(3);
  }
  out << "  time per stage (s):";
  for (const StageTiming& timing : timings) out << " " << timing.stage << " " << timing.seconds << ";";
  out << " total " << TotalSeconds() << "\n";
  return out.str();
}

DecodedRaw DecodeSessionFrame(const fs::path& session_dir, const Session& session, const FrameRecord& record) {
  const fs::path path = session_dir / record.file;
  DecodedRaw decoded = DecodeRawFileWithInfo(path);
  CheckRawSize(decoded.image, session.camera.width, session.camera.height, path.string());
  return decoded;
}

// An LED frame developed whole ahead of the solve (SolvePreparation::DevelopFrame).
struct DevelopedAhead {
  std::string sha256;       // the frame's, as its record names it
  std::string dark_sha256;  // the dark frame's it was developed against
  DevelopedFrame developed;
};

struct SolvePreparation::State {
  fs::path session_dir;
  fs::path calibration_dir;  // what the light field was made from
  RawDevelopOptions develop;  // DevelopOptionsFor the solve's options
  Lighting lighting;
  PreparedFrames frames;
  bool holds_points = false;  // HoldSurfacePoints made the light field's points
  std::map<std::string, DevelopedAhead> developed;  // by file
};

SolvePreparation::SolvePreparation(const fs::path& session_dir, const Session& session, const SolveOptions& options)
    : state_(std::make_unique<State>()) {
  state_->session_dir = session_dir;
  state_->calibration_dir = options.calibration_dir;
  state_->develop = DevelopOptionsFor(BandedOptions(options));
  state_->lighting = MakeLighting(options, session_dir, session);
}
SolvePreparation::SolvePreparation(SolvePreparation&&) noexcept = default;
SolvePreparation& SolvePreparation::operator=(SolvePreparation&&) noexcept = default;
SolvePreparation::~SolvePreparation() = default;

void SolvePreparation::AddFrame(const FrameRecord& record, DecodedRaw decoded) {
  state_->frames[record.file] = PreparedFrame{record.sha256, std::move(decoded)};
}

int SolvePreparation::num_frames() const { return static_cast<int>(state_->frames.size()); }

void SolvePreparation::HoldSurfacePoints(int num_threads) {
  // Only the rig description's field is on the table plane made on request;
  // a calibration set's is measured per pixel.
  const auto* field = dynamic_cast<const PointLightField*>(state_->lighting.light_field.get());
  if (!state_->calibration_dir.empty() || field == nullptr || state_->holds_points) return;
  const CameraGeometry& camera = state_->lighting.camera;
  state_->lighting.light_field = std::make_unique<PointLightField>(
      field->lights(), std::make_unique<HeldSurfacePoints>(ComputeTablePoints(camera, num_threads)),
      CameraCentreInTable(camera));
  state_->holds_points = true;
}

bool SolvePreparation::holds_surface_points() const { return state_->holds_points; }

bool SolvePreparation::DevelopFrame(const Session& session, const FrameRecord& record) {
  const FrameRecord* dark_record = FindDarkFrame(session);
  if (record.kind != FrameKind::kLed || dark_record == nullptr) return false;
  const auto frame = state_->frames.find(record.file);
  const auto dark = state_->frames.find(dark_record->file);
  if (frame == state_->frames.end() || frame->second.sha256 != record.sha256 || dark == state_->frames.end() ||
      dark->second.sha256 != dark_record->sha256) {
    return false;
  }
  state_->developed[record.file] =
      DevelopedAhead{record.sha256, dark_record->sha256,
                     DevelopRaw(frame->second.decoded.image, &dark->second.decoded.image, state_->develop)};
  return true;
}

int SolvePreparation::num_developed_frames() const { return static_cast<int>(state_->developed.size()); }

namespace {

// The frames `prepared` developed ahead for exactly these records and this
// development (null where it did not), in the order of frames.leds.
std::vector<const DevelopedFrame*> DevelopedAheadFor(const SolvePreparation::State& prepared, const Session& session,
                                                     const RawDevelopOptions& develop) {
  const RawDevelopOptions& made = prepared.develop;
  const int num_lights = static_cast<int>(session.rig.leds.size());
  std::vector<const DevelopedFrame*> developed(num_lights, nullptr);
  if (made.demosaic != develop.demosaic || made.clip_fraction != develop.clip_fraction ||
      made.keep_mosaic != develop.keep_mosaic) {
    return developed;
  }
  const FrameRecord* dark = FindDarkFrame(session);
  for (int k = 0; k < num_lights; ++k) {
    const FrameRecord* record = FindLedFrame(session, k);
    const auto found = prepared.developed.find(record->file);
    if (found != prepared.developed.end() && found->second.sha256 == record->sha256 &&
        found->second.dark_sha256 == dark->sha256) {
      developed[k] = &found->second.developed;
    }
  }
  return developed;
}

}  // namespace

SolveController::SolveController(fs::path session_dir, SolveOptions options)
    : session_dir_(std::move(session_dir)), options_(std::move(options)) {}
SolveController::~SolveController() = default;

void SolveController::UsePreparation(SolvePreparation preparation) {
  if (preparation.state_->session_dir != session_dir_ ||
      preparation.state_->calibration_dir != options_.calibration_dir) {
    throw std::invalid_argument("SolveController::UsePreparation: prepared for " +
                                preparation.state_->session_dir.string() + " with calibration '" +
                                preparation.state_->calibration_dir.string() + "', not " + session_dir_.string() +
                                " with '" + options_.calibration_dir.string() + "'");
  }
  preparation_ = std::move(preparation.state_);
}

namespace {

// Every map of a solution, in one order, for `f(image)`.
template <typename Solution, typename F>
void ForEachMap(Solution& s, const F& f) {
  f(s.normal_in_table);
  f(s.albedo);
  f(s.status);
  f(s.lights_used);
  f(s.condition_number);
  f(s.residual);
  f(s.solve_path);
  f(s.specular);
  f(s.specular_status);
}
constexpr int kNormalMap = 0, kStatusMap = 2, kSolvePathMap = 6;  // their places in ForEachMap's order

// The first pass of a solve whose depth refinement may re-solve (point LEDs,
// refinement on): each solved band goes into the decision blocks and, every
// map of it that is written or evaluated (not solve_path), into an unlinked
// spill file (43 bytes a pixel: 0.7 GB of the file system's cache at 16 MP,
// not the process's memory). Once the decision is
// taken the bands are handed on to be written (the table plane kept) or only
// the normals and status read back (the re-solves start from them), so a
// draped sample's first pass is never encoded nor evaluated. A solve that
// streams the first pass's maps meanwhile (SolveOptions::stream_first_pass)
// spills only the normals and status (13 bytes a pixel; no Replay).
class FirstPassSpill {
 public:
  FirstPassSpill(const fs::path& folder, int width, int height, int num_threads, bool all_maps = true)
      : width_(width), all_maps_(all_maps), blocks_(width, height), spill_(folder), num_threads_(num_threads) {}

  void Add(const PhotometricSolution& band) {
    blocks_.AddRows(band, num_threads_);
    int map = 0;
    ForEachMap(band, [&](const auto& image) {
      if (band_rows_.empty()) channels_[map] = image.empty() ? 0 : image.channels();
      if (image.empty() != (channels_[map] == 0) || (!image.empty() && image.channels() != channels_[map])) {
        throw std::logic_error("FirstPassSpill: the bands' maps differ");
      }
      if (Spilled(map)) spill_.Append(image.data(), image.size() * sizeof(*image.data()));
      ++map;
    });
    band_rows_.push_back(band.status.height());
  }

  const DepthDecisionBlocks& decision_blocks() const { return blocks_; }

  // The bands as they were added, in order. The next band is read from the
  // spill on a thread of its own while the sink takes this one (the read is
  // a serial 28 MB copy a band at 16 MP, which left the pool idle), into the
  // other of two bands whose maps are reused (the sink holds none of them
  // after it returns): no fresh pages to fault in and fill per band.
  void Replay(const std::function<void(PhotometricSolution& band)>& sink) {
    if (!all_maps_) throw std::logic_error("FirstPassSpill::Replay: only the normals and status were spilled");
    std::array<PhotometricSolution, 2> bands;
    const auto read = [this](int rows, size_t offset, PhotometricSolution* band) {
      int map = 0;
      ForEachMap(*band, [&](auto& image) {
        if (channels_[map] > 0 && Spilled(map)) {
          image.Reshape(width_, rows, channels_[map]);
          const size_t bytes = image.size() * sizeof(*image.data());
          spill_.ReadAt(offset, image.data(), bytes);  // pread only: the spill was flushed before
          offset += bytes;
        }
        ++map;
      });
      return offset;
    };
    if (band_rows_.empty()) return;
    spill_.Flush();  // so that ReadAt only reads, from either thread
    size_t next_offset = read(band_rows_[0], 0, &bands[0]);
    for (size_t b = 0; b < band_rows_.size(); ++b) {
      std::future<size_t> next;
      if (b + 1 < band_rows_.size()) {
        next = std::async(std::launch::async, read, band_rows_[b + 1], next_offset, &bands[(b + 1) % 2]);
      }
      try {
        sink(bands[b % 2]);
      } catch (...) {
        if (next.valid()) next.wait();  // its band is this function's
        throw;
      }
      if (next.valid()) next_offset = next.get();
    }
  }

  // The first pass's normals and status at full size (all RefineDepth reads of it).
  PhotometricSolution NormalsAndStatus() {
    PhotometricSolution first;
    int height = 0;
    for (const int rows : band_rows_) height += rows;
    first.normal_in_table = ImageF(width_, height, 3);
    first.status = ImageU8(width_, height, 1);
    size_t offset = 0;
    int y = 0;
    for (const int rows : band_rows_) {
      int map = 0;
      PhotometricSolution shapes;  // only for the maps' sample types
      ForEachMap(shapes, [&](auto& image) {
        const size_t bytes = size_t(width_) * rows * channels_[map] * sizeof(*image.data());
        if (map == kNormalMap) spill_.ReadAt(offset, first.normal_in_table.row(y), bytes);
        if (map == kStatusMap) spill_.ReadAt(offset, first.status.row(y), bytes);
        if (Spilled(map)) offset += bytes;
        ++map;
      });
      y += rows;
    }
    return first;
  }

  bool all_maps() const { return all_maps_; }

 private:
  // Map `map` (ForEachMap's order) goes to the spill: all but solve_path
  // (neither written nor evaluated: a replayed band has none), or the
  // normals and status.
  bool Spilled(int map) const { return all_maps_ ? map != kSolvePathMap : map == kNormalMap || map == kStatusMap; }

  int width_;
  bool all_maps_;
  std::array<int, 9> channels_{};  // per map (ForEachMap's order), 0 = empty
  std::vector<int> band_rows_;
  DepthDecisionBlocks blocks_;
  SpillFile spill_;
  int num_threads_;
};

// What the solve does with each solved band (issue #14): the albedo's colour
// (ApplyAlbedoColor on its solved pixels), the specular tally, the ground-truth
// evaluation and the maps, streamed into the staging folder, so that no
// full-size solution is held.
class ResultStream {
 public:
  ResultStream(const fs::path& folder, int width, int height, const AlbedoColor& color, const ExrEncoding& exr,
               const fs::path& session_dir, const GroundTruthFiles* truth, int num_threads)
      : folder_(folder), width_(width), height_(height), color_(color), exr_(exr), num_threads_(num_threads) {
    if (truth != nullptr) evaluation_.emplace(session_dir, *truth, width, height, folder);
  }

  void Add(PhotometricSolution& band) {
    const auto start = std::chrono::steady_clock::now();
    solved_.Reshape(band.status.width(), band.status.height(), 1);
    for (size_t i = 0; i < solved_.size(); ++i) {
      solved_.data()[i] = band.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    }
    ApplyAlbedoColor(color_, solved_, &band.albedo);
    color_seconds_ += SecondsSince(start);
    specular_.Add(band);
    // The maps open at the first band: whether there is a specular map is the solve's.
    if (!maps_) maps_.emplace(folder_, width_, height_, !band.specular.empty(), evaluation_.has_value(), color_, exr_);
    const double evaluated_before = maps_->alongside_seconds();
    maps_->AddBand(band,
                   evaluation_ ? std::function<ImageF()>([&] { return evaluation_->AddBand(band, num_threads_); })
                               : std::function<ImageF()>(),
                   num_threads_);
    evaluate_seconds_ += maps_->alongside_seconds() - evaluated_before;
    sink_seconds_ += SecondsSince(start);
  }

  std::optional<SpecularMapStatistics> specular() const { return specular_.Finish(); }
  GroundTruthComparison FinishEvaluation() { return evaluation_->Finish(num_threads_); }
  std::map<std::string, std::string> Commit() { return maps_->Commit(); }

  double sink_seconds() const { return sink_seconds_; }  // in Add, all parts
  double color_seconds() const { return color_seconds_; }
  double evaluate_seconds() const { return evaluate_seconds_; }
  double write_seconds() const { return sink_seconds_ - color_seconds_ - evaluate_seconds_; }

 private:
  fs::path folder_;
  int width_, height_;
  AlbedoColor color_;
  ExrEncoding exr_;
  int num_threads_;
  SpecularMapTally specular_;
  std::optional<GroundTruthEvaluation> evaluation_;
  std::optional<SolutionMapStream> maps_;
  ImageU8 solved_;  // the band's solved pixels, kept from band to band
  double sink_seconds_ = 0, color_seconds_ = 0, evaluate_seconds_ = 0;
};

}  // namespace

void SolveController::Run() {
  options_.Check();
  summary_ = SolveSummary();
  std::vector<StageTiming>& timings = summary_.timings;

  const Session session = TimedStage(timings, "load", "load session", [&] {
    return LoadCompleteSession(session_dir_, options_.verify_checksums, options_.solver.num_threads);
  });
  summary_.sample_name = session.sample_name;
  summary_.width = session.camera.width;
  summary_.height = session.camera.height;
  summary_.num_lights = static_cast<int>(session.rig.leds.size());

  // From a preparation (the live solve) when there is one: the same frames
  // and light field, made earlier.
  std::unique_ptr<SolvePreparation::State> prepared = std::move(preparation_);
  RawFrames frames = TimedStage(timings, "decode", "decode RAW", [&] {
    return DecodeFrames(session_dir_, session, options_.solver.num_threads, StageCallback("decode RAW"),
                        prepared ? &prepared->frames : nullptr);
  });
  Lighting lighting = TimedStage(timings, "light_field", "", [&] {
    Lighting made = prepared ? std::move(prepared->lighting) : MakeLighting(options_, session_dir_, session);
    // After the calibration set was checked, so that its errors come from its loader.
    summary_.inputs_fingerprint = SolveInputsFingerprint(session, options_);
    // Before the solve, so that a colour source that is not there fails early.
    summary_.albedo_color = ChooseAlbedoColor(options_.albedo_color, made.set.get(), made.set_name,
                                              frames.camera_from_xyz, frames.first_led_file);
    return made;
  });
  if (prepared && !prepared->developed.empty()) {
    frames.developed_ahead = DevelopedAheadFor(*prepared, session, DevelopOptionsFor(BandedOptions(options_)));
  }
  summary_.light_model = lighting.light_model;
  summary_.warnings = lighting.warnings;
  summary_.warnings.insert(summary_.warnings.end(), frames.exposure_notes.begin(), frames.exposure_notes.end());

  // The folder appears complete or not at all. Reserved before the solve:
  // the maps stream into its staging folder band by band as they are solved.
  const fs::path result_dir = CreateResultFolder(
      session_dir_, options_.run_label.empty() ? PhotometricMethodName(options_.solver.method) : options_.run_label);
  StagedResultFolder staged(result_dir);
  const ExrEncoding exr = ResultMapExrEncoding(options_.float32_maps);
  const GroundTruthFiles* truth = session.ground_truth ? &*session.ground_truth : nullptr;
  // Only point LEDs can be moved off the table plane (RefineOnDepth): then
  // the first pass is spilled until the decision whether to re-solve is
  // taken (or, with stream_first_pass, written as it is solved, and only its
  // normals and status spilled for the re-solves); otherwise its bands are
  // written as they are solved.
  const bool may_refine = options_.depth.enabled &&
                          dynamic_cast<const PointLightField*>(lighting.light_field.get()) != nullptr;
  const bool stream_first_pass = may_refine && options_.stream_first_pass;
  const auto result_stream = [&] {
    return std::make_unique<ResultStream>(staged.staging(), summary_.width, summary_.height, summary_.albedo_color,
                                          exr, session_dir_, truth, options_.solver.num_threads);
  };
  std::unique_ptr<FirstPassSpill> first_pass;
  std::unique_ptr<ResultStream> stream;
  if (may_refine) {
    first_pass = std::make_unique<FirstPassSpill>(staged.staging(), summary_.width, summary_.height,
                                                  options_.solver.num_threads, !stream_first_pass);
  }
  if (!may_refine || stream_first_pass) stream = result_stream();
  TimedStage(timings, "solve", "solve", [&] {
    // With stream_first_pass the bands are written on a thread of their own
    // beside the solve (its time then includes the writing it waited for).
    const auto take_band = [&](PhotometricSolution& band) {
      if (first_pass) first_pass->Add(band);  // before the stream: it colours the albedo in place
      if (stream) stream->Add(band);
    };
    // With stream_first_pass solved bands go to `take_band` (the first
    // pass's decision blocks and spill, then the ResultStream) on a thread of
    // their own, so that one band's files are encoded while the next band is
    // solved: the solve's threads and this one share the cores, and what one
    // leaves idle (a band's last file, the solve's serial steps) the other
    // takes. The bands come in order, as on the solve's thread, so the files
    // are the same. Two bands wait at most (about 28 MB each at 16 MP).
    std::optional<BoundedWorker<PhotometricSolution>> writer;
    if (stream_first_pass) writer.emplace(take_band, 2);
    const BandedSolveSummary banded = SolveBanded(
        BandedOptions(options_), frames.Stack(), *lighting.light_field,
        [&](int, PhotometricSolution& band) { writer ? writer->Push(std::move(band)) : take_band(band); },
        StageCallback("solve"));
    summary_.solver = banded.solver;
    summary_.clipped_samples = banded.clipped_samples;
    RequireSuccess(banded, "solve");
    if (writer) writer->Finish();
  });
  // The streaming's own stages below (beside the solve with stream_first_pass).
  if (stream && !stream_first_pass) timings.back().seconds -= stream->sink_seconds();
  // The raw frames (32 MB each at 16 MP) are not held through the later
  // stages, nor the frames developed ahead.
  frames.leds.clear();
  frames.dark = RawImage();
  frames.developed_ahead.clear();
  prepared.reset();
  const auto raw_frames = [&]() -> const RawFrames& {
    if (frames.leds.empty()) frames = DecodeFrames(session_dir_, session, options_.solver.num_threads, {});
    return frames;
  };
  bool restreamed = false;  // the maps streamed in the depth stage, from the last re-solve
  summary_.depth = TimedStage(timings, "depth_refine", "depth refine", [&] {
    if (first_pass) {
      if (std::optional<DepthRefinementSummary> kept =
              TablePlaneKept(options_.depth, first_pass->decision_blocks(), lighting.camera)) {
        return *kept;  // the spilled first pass is written below (or was streamed)
      }
      // Draped: the re-solves start from the first pass (held from here on),
      // and the maps are those of the last re-solve, streamed from it. A
      // first pass streamed meanwhile is not the result: its files go.
      stream.reset();
      PhotometricSolution solution = first_pass->NormalsAndStatus();
      first_pass.reset();
      DepthRefinementSummary depth =
          RefineOnDepth(options_, raw_frames, lighting, &solution, StageCallback("depth refine"));
      RequireSuccess(depth, "depth refine");
      frames.leds.clear();
      frames.dark = RawImage();
      lighting.light_field.reset();
      stream = result_stream();
      restreamed = true;
      const int height = solution.status.height();
      for (int y = 0; y < height; y += kEvaluationBandRows) {
        PhotometricSolution band = SolutionRows(solution, y, std::min(kEvaluationBandRows, height - y));
        stream->Add(band);
      }
      return depth;
    }
    PhotometricSolution unused;  // disabled, or a measured light field: the solution is not read
    DepthRefinementSummary depth = RefineOnDepth(options_, raw_frames, lighting, &unused, StageCallback("depth refine"));
    RequireSuccess(depth, "depth refine");
    return depth;
  });
  if (restreamed) timings.back().seconds -= stream->sink_seconds();
  frames.leds.clear();
  frames.dark = RawImage();
  lighting.light_field.reset();  // its per-pixel surface points: 193 MB at 16 MP
  if (first_pass && first_pass->all_maps()) {
    // The table plane kept: the first pass's bands, written and evaluated now
    // (its time the stages' below).
    stream = result_stream();
    first_pass->Replay([&](PhotometricSolution& band) { stream->Add(band); });
  }
  first_pass.reset();  // a streamed first pass's spilled normals and status
  summary_.specular = stream->specular();
  timings.push_back({"color", stream->color_seconds()});

  ThrowIfStopRequested("evaluate");
  if (truth != nullptr) {
    const auto start = std::chrono::steady_clock::now();
    const GroundTruthComparison comparison = stream->FinishEvaluation();
    timings.push_back({"evaluate", stream->evaluate_seconds() + SecondsSince(start)});
    summary_.normal_error_deg = comparison.normal_error_deg;
    summary_.albedo_error = comparison.albedo_error;
    summary_.albedo_color_error = comparison.albedo_color_error;
    summary_.unsolved_on_sample = comparison.unsolved_on_sample;
  }
  std::map<std::string, std::string> outputs;
  {
    BeginStage("write maps");
    const auto start = std::chrono::steady_clock::now();
    outputs = stream->Commit();
    timings.push_back({"write_maps", stream->write_seconds() + SecondsSince(start)});
  }
  summary_.bytes_written = FileSizesIn(staged.staging());
  summary_.exr_encoding = std::string(exr.sample_type == ExrSampleType::kHalf ? "half" : "float32") + ", " +
                          ExrCompressionName(exr.compression);
  summary_.result_dir = result_dir;
  outputs["report"] = "report.json";
  outputs["summary"] = "summary.txt";
  const nlohmann::json report =
      SolveReportJson(summary_, options_, session_dir_, frames.dark_file, lighting.calibration_report, outputs);
  WriteFileAtomic(staged.staging() / "report.json", report.dump(2) + "\n", OverwritePolicy::kRefuse);
  WriteFileAtomic(staged.staging() / "summary.txt", summary_.FullReport(), OverwritePolicy::kRefuse);
  ThrowIfStopRequested("write maps");
  staged.Commit();
  ReportProgress("write maps", 1);
}

}  // namespace scanbench
