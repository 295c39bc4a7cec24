#include "app/controllers/solve_controller.h"

#include <algorithm>
#include <chrono>
#include <functional>
#include <iomanip>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app/controllers/solve_routing.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/io/result_maps.h"
#include "app/io/staged_folder.h"
#include "app/session/albedo_color_choice.h"
#include "app/session/calibrated_lighting.h"  // issue #4
#include "app/session/calibration_set.h"
#include "app/session/color_staleness.h"
#include "app/session/session.h"
#include "calibration/camera_model.h"
#include "calibration/rig_light_field.h"
#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "core/summary.h"
#include "pipeline/banded_solve.h"
#include "solver/normal_network.h"
#include "solver/photometric_methods.h"

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
  if (MethodRunsPass(solver, SolverPass::kCoherentSheen)) {
    json["adaptive_coherent_sheen"] = 2;
  }
  // Only where the network runs, so that earlier results keep their
  // fingerprints; the result then depends on the model too.
  if (MethodRunsPass(solver, SolverPass::kLearnedNormals)) {
    json["adaptive_learned"] = static_cast<int>(solver.adaptive_learned);
    json["adaptive_learned_max_lights"] = solver.adaptive_learned_max_lights;
    json["learned_refine"] = solver.learned_refine;
    json["learned_model_sha256"] = NormalNetwork::Embedded().sha256();
  }
  return json;
}


nlohmann::json DepthOptionsJson(const DepthRefinementOptions& depth) {
  return nlohmann::json::parse(depth.ReportJson());  // pipeline/depth_refinement.h: solve-dataset reports the same
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
  banded.bayer_blend =
      options.bayer_blend && !options.bayer_domain && MethodRunsPass(options.solver, SolverPass::kBayerBlend);
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
  report["depth_refinement"] = nlohmann::json::parse(summary.depth.ReportJson(options.depth));  // issue #15
  report["timings_s"] = timings;
  report["outputs"] = outputs;
  report["bytes_written"] = {{"files", summary.bytes_written},
                             {"total", summary.TotalBytesWritten()},
                             {"exr_encoding", summary.exr_encoding},
                             {"not_counted", {"report.json", "summary.txt"}}};
  return report;
}

}  // namespace

namespace {

ImageU8 SampleMaskFromGroundTruth(const fs::path& session_dir, const GroundTruthFiles& truth) {
  const ImageU8 stored = ReadImageU8(session_dir / truth.mask_file);
  ImageU8 mask(stored.width(), stored.height(), 1);
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] = stored.data()[i * stored.channels()] > 127;
  return mask;
}

// The session's true normals and albedo a band of rows at a time, each band
// checked against the solution's width, naming the file.
class SessionGroundTruthRows final : public GroundTruthRows {
 public:
  SessionGroundTruthRows(const fs::path& session_dir, const GroundTruthFiles& truth, int width)
      : normals_(session_dir / truth.normal_file), albedo_(session_dir / truth.albedo_file), width_(width) {}
  void ReadNormalRows(int y_begin, int y_end, ImageF* rows) override { Read(normals_, y_begin, y_end, rows); }
  void ReadAlbedoRows(int y_begin, int y_end, ImageF* rows) override { Read(albedo_, y_begin, y_end, rows); }

 private:
  void Read(ImageRowReader& reader, int y_begin, int y_end, ImageF* rows) const {
    reader.ReadRows(y_begin, y_end, rows);
    if (rows->width() != width_ || rows->channels() != 3) {
      throw std::runtime_error(reader.path().string() + ": " + ShapeText(*rows) + " rows, the solution's are " +
                               SizeText(width_, y_end - y_begin) + "x3");
    }
  }
  ImageRowReader normals_, albedo_;  // opened once
  int width_;
};

}  // namespace

GroundTruthEvaluation SessionGroundTruthEvaluation(const fs::path& session_dir, const GroundTruthFiles& truth,
                                                   int width, int height, const fs::path& spill_folder) {
  auto rows = std::make_unique<SessionGroundTruthRows>(session_dir, truth, width);
  ImageU8 on_sample = SampleMaskFromGroundTruth(session_dir, truth);
  if (!on_sample.SameSize(width, height)) {
    throw std::runtime_error((session_dir / truth.mask_file).string() + ": " +
                             SizeText(on_sample.width(), on_sample.height()) + ", the solution is " +
                             SizeText(width, height));
  }
  return GroundTruthEvaluation(std::move(on_sample), std::move(rows), spill_folder);
}

// A tripwire (x86-64, libstdc++): a new option must be sorted into what changes the
// result (then into the text below) or not (then only this number changes).
#if defined(__x86_64__) && defined(__GLIBCXX__)
static_assert(sizeof(PhotometricSolverOptions) == 152 && sizeof(RawDevelopOptions) == 16 && sizeof(SolveOptions) == 320,
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
  for (const StageTiming& timing : timings) out << " " << timing.stage << " " << Significant(timing.seconds) << ";";
  out << " total " << Significant(TotalSeconds()) << "\n";
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

// The session's frames through the solve: decoded (or taken from a
// preparation) for the first pass, released after it (32 MB a raw frame at
// 16 MP, 290 MB a frame developed ahead), and decoded again only when the
// depth refinement re-solves (a flat sample never does).
class SolveFrames {
 public:
  SolveFrames(RawFrames frames, std::function<RawFrames()> decode_again)
      : frames_(std::move(frames)), decode_again_(std::move(decode_again)) {}

  // The frames `prepared` developed ahead of the solve for exactly these
  // frames and `develop` (DevelopedAheadFor), held until Release.
  void UsePreparation(std::unique_ptr<SolvePreparation::State> prepared, const Session& session,
                      const RawDevelopOptions& develop) {
    prepared_ = std::move(prepared);
    if (prepared_ && !prepared_->developed.empty()) {
      frames_.developed_ahead = DevelopedAheadFor(*prepared_, session, develop);
    }
  }
  const RawFrames& Get() {
    if (released_) {
      frames_ = decode_again_();
      released_ = false;
    }
    return frames_;
  }
  void Release() {
    frames_.leds.clear();
    frames_.dark = RawImage();
    frames_.developed_ahead.clear();
    prepared_.reset();
    released_ = true;
  }
  const std::string& dark_file() const { return frames_.dark_file; }

 private:
  RawFrames frames_;
  std::function<RawFrames()> decode_again_;
  std::unique_ptr<SolvePreparation::State> prepared_;  // what frames_.developed_ahead points into
  bool released_ = false;
};

// The steps of SolveController::Run that follow the decode, in order.

// The light field (made earlier when there is a preparation), and what the
// solve takes from it and from the frames before it starts.
Lighting PrepareLighting(const SolveOptions& options, const fs::path& session_dir, const Session& session,
                         const RawFrames& frames, SolvePreparation::State* prepared, SolveSummary* summary) {
  Lighting lighting = prepared ? std::move(prepared->lighting) : MakeLighting(options, session_dir, session);
  // After the calibration set was checked, so that its errors come from its loader.
  summary->inputs_fingerprint = SolveInputsFingerprint(session, options);
  // Before the solve, so that a colour source that is not there fails early.
  summary->albedo_color = ChooseAlbedoColor(options.albedo_color, lighting.set.get(), lighting.set_name,
                                            frames.camera_from_xyz, frames.first_led_file);
  summary->light_model = lighting.light_model;
  summary->warnings = lighting.warnings;
  // Issue #36 item 14: a colour correction measured through an older light field.
  if (lighting.set && summary->albedo_color.source == AlbedoColorOptions::Source::kChart) {
    if (const auto stale = StaleColorReason(*lighting.set, options.calibration_dir)) {
      summary->warnings.push_back(*stale);
      summary->albedo_color.description += " [STALE: fitted before the set's latest lights / white balance]";
    }
  }
  summary->warnings.insert(summary->warnings.end(), frames.exposure_notes.begin(), frames.exposure_notes.end());
  return lighting;
}

// Only point LEDs can be moved off the table plane (RefineOnDepth): then the
// first pass waits for the depth refinement's decision (or, with
// stream_first_pass, is written meanwhile); otherwise its bands are the result.
SolveRouting::Route RouteOf(const SolveOptions& options, const LightField& light_field) {
  const bool may_refine = options.depth.enabled && dynamic_cast<const PointLightField*>(&light_field) != nullptr;
  if (!may_refine) return SolveRouting::Route::kStream;
  return options.stream_first_pass ? SolveRouting::Route::kStreamAndSpill : SolveRouting::Route::kSpill;
}

// The result files in `folder` (the staging folder), with the session's
// ground-truth evaluation when it has one.
std::unique_ptr<ResultStream> OpenResults(const SolveOptions& options, const fs::path& session_dir,
                                          const Session& session, const SolveSummary& summary,
                                          const fs::path& folder, StageTimes* times) {
  std::optional<GroundTruthEvaluation> evaluation;
  if (session.ground_truth) {
    evaluation = SessionGroundTruthEvaluation(session_dir, *session.ground_truth, summary.width, summary.height,
                                              folder);
  }
  return std::make_unique<ResultStream>(folder, summary.width, summary.height, summary.albedo_color,
                                        ResultMapExrEncoding(options.float32_maps), std::move(evaluation),
                                        options.solver.num_threads, times);
}

// Solve: the first pass, band by band from the raw frames, each band to `routing`.
void SolveFirstPass(const SolveOptions& options, const RawFrames& frames, const LightField& light_field,
                    const ProgressCallback& progress, SolveRouting* routing, SolveSummary* summary) {
  const BandedSolveSummary banded = SolveBanded(
      BandedOptions(options), frames.Stack(), light_field,
      [&](int, PhotometricSolution& band) { routing->AddFirstPassBand(band); }, progress);
  summary->solver = banded.solver;
  summary->clipped_samples = banded.clipped_samples;
  RequireSuccess(banded, "solve");
  routing->FinishFirstPass();
}

// Depth refine (issue #15): the decision on the first pass's blocks and, on
// a draped sample, the re-solves, whose result goes to the result files.
DepthRefinementSummary RefineDepthOfFirstPass(const SolveOptions& options, const ProgressCallback& progress,
                                              SolveFrames* frames, Lighting* lighting, SolveRouting* routing) {
  const auto raw_frames = [&]() -> const RawFrames& { return frames->Get(); };
  const DepthDecisionBlocks* blocks = routing->decision_blocks();
  if (blocks == nullptr) {  // disabled, or a measured light field: the solution is not read
    PhotometricSolution unused;
    DepthRefinementSummary depth = RefineOnDepth(options, raw_frames, *lighting, &unused, progress);
    RequireSuccess(depth, "depth refine");
    return depth;
  }
  if (std::optional<DepthRefinementSummary> kept = TablePlaneKept(options.depth, *blocks, lighting->camera)) {
    return *kept;  // the first pass is the result
  }
  // Draped: the re-solves start from the first pass (held from here on), and
  // the maps are those of the last re-solve.
  PhotometricSolution solution = routing->TakeFirstPassForResolve();
  DepthRefinementSummary depth = RefineOnDepth(options, raw_frames, *lighting, &solution, progress);
  RequireSuccess(depth, "depth refine");
  frames->Release();
  lighting->light_field.reset();
  routing->StreamResolved(solution);
  return depth;
}

void RecordEvaluation(const GroundTruthComparison& comparison, SolveSummary* summary) {
  summary->normal_error_deg = comparison.normal_error_deg;
  summary->albedo_error = comparison.albedo_error;
  summary->albedo_color_error = comparison.albedo_color_error;
  summary->unsolved_on_sample = comparison.unsolved_on_sample;
}

// report.json and summary.txt beside the maps in the staging folder, which
// is to become `result_dir`.
void WriteReports(const SolveOptions& options, const fs::path& session_dir, const fs::path& staging,
                  const fs::path& result_dir, const std::string& dark_file, const nlohmann::json& calibration_report,
                  std::map<std::string, std::string> outputs, SolveSummary* summary) {
  const ExrEncoding exr = ResultMapExrEncoding(options.float32_maps);
  summary->bytes_written = FileSizesIn(staging);
  summary->exr_encoding = std::string(exr.sample_type == ExrSampleType::kHalf ? "half" : "float32") + ", " +
                          ExrCompressionName(exr.compression);
  summary->result_dir = result_dir;
  outputs["report"] = "report.json";
  outputs["summary"] = "summary.txt";
  const nlohmann::json report =
      SolveReportJson(*summary, options, session_dir, dark_file, calibration_report, outputs);
  WriteFileAtomic(staging / "report.json", report.dump(2) + "\n", OverwritePolicy::kRefuse);
  WriteFileAtomic(staging / "summary.txt", summary->FullReport(), OverwritePolicy::kRefuse);
}

}  // namespace

void SolveController::Run() {
  options_.Check();
  summary_ = SolveSummary();
  const int threads = options_.solver.num_threads;
  // The stages of report.json's "timings_s" and summary.txt's "time per stage", in order.
  StageTimes times({"load", "decode", "light_field", "solve", "depth_refine", "color", "evaluate", "write_maps"});

  const Session session = TimedStage(times, "load", "load session", [&] {
    return LoadCompleteSession(session_dir_, options_.verify_checksums, threads);
  });
  summary_.sample_name = session.sample_name;
  summary_.width = session.camera.width;
  summary_.height = session.camera.height;
  summary_.num_lights = static_cast<int>(session.rig.leds.size());

  // From a preparation (the live solve) when there is one: the same frames
  // and light field, made earlier.
  std::unique_ptr<SolvePreparation::State> prepared = std::move(preparation_);
  SolveFrames frames = TimedStage(times, "decode", "decode RAW", [&] {
    return SolveFrames(DecodeFrames(session_dir_, session, threads, StageCallback("decode RAW"),
                                    prepared ? &prepared->frames : nullptr),
                       [&] { return DecodeFrames(session_dir_, session, threads, {}); });
  });
  Lighting lighting = TimedStage(times, "light_field", "", [&] {
    return PrepareLighting(options_, session_dir_, session, frames.Get(), prepared.get(), &summary_);
  });
  frames.UsePreparation(std::move(prepared), session, DevelopOptionsFor(BandedOptions(options_)));

  // The folder appears complete or not at all. Reserved before the solve:
  // the maps stream into its staging folder band by band as they are solved.
  StagedFolder staged = ReserveResultFolder(
      session_dir_, options_.run_label.empty() ? PhotometricMethodName(options_.solver.method) : options_.run_label);
  SolveRouting routing(RouteOf(options_, *lighting.light_field), summary_.width, summary_.height, staged.staging(),
                       threads, [&] {
                         return OpenResults(options_, session_dir_, session, summary_, staged.staging(), &times);
                       });
  TimedStage(times, "solve", "solve", [&] {
    SolveFirstPass(options_, frames.Get(), *lighting.light_field, StageCallback("solve"), &routing, &summary_);
  });
  frames.Release();  // decoded again only for a re-solve
  summary_.depth = TimedStage(times, "depth_refine", "depth refine", [&] {
    return RefineDepthOfFirstPass(options_, StageCallback("depth refine"), &frames, &lighting, &routing);
  });
  lighting.light_field.reset();  // its per-pixel surface points: 193 MB at 16 MP

  ResultStream& results = routing.Results();  // a spilled first pass that is the result: written and evaluated now
  summary_.specular = results.specular();
  ThrowIfStopRequested("evaluate");
  if (results.evaluates()) times.Time("evaluate", [&] { RecordEvaluation(results.FinishEvaluation(), &summary_); });
  const std::map<std::string, std::string> outputs =
      TimedStage(times, "write_maps", "write maps", [&] { return results.Commit(); });
  summary_.timings = times.List();
  WriteReports(options_, session_dir_, staged.staging(), staged.final_dir(), frames.dark_file(),
               lighting.calibration_report, outputs, &summary_);
  ThrowIfStopRequested("write maps");
  staged.Commit();
  ReportProgress("write maps", 1);
}

}  // namespace scanbench
