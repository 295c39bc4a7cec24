#include "app/controllers/dataset_controller.h"

#include <chrono>
#include <iomanip>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/result_maps.h"
#include "app/io/staged_folder.h"
#include "app/session/session.h"
#include "core/field_error.h"
#include "core/format.h"
#include "solver/light_subset.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

nlohmann::json StatisticsJson(const ErrorStatistics& stats) {
  return {{"pixels", stats.num_pixels}, {"mean", stats.mean}, {"median", stats.median},
          {"p95", stats.percentile_95}, {"max", stats.max}};
}

const char* KindName(PhotometricDataset::Kind kind) {
  return kind == PhotometricDataset::Kind::kDistantLights ? "distant_lights (DiLiGenT)" : "near_field (LUCES-style)";
}

// report.json: the dataset, the solver options and result, the error against
// the ground truth, timings and the files written.
nlohmann::json DatasetReportJson(const fs::path& dataset_dir, const PhotometricDataset& dataset,
                                 const PhotometricSolverOptions& solver, const DepthRefinementOptions& depth,
                                 const DatasetSolveResult& result,
                                 const DatasetSolveSummary& summary, const std::map<std::string, std::string>& outputs) {
  nlohmann::json report;
  report["schema"] = "scanbench.dataset_report/1";
  report["software_version"] = "scanbench " SCANBENCH_VERSION;
  report["created"] = FormatUtcTimestamp(std::chrono::system_clock::now());
  report["dataset"] = {{"path", fs::absolute(dataset_dir).string()},
                       {"name", dataset.name},
                       {"kind", summary.kind},
                       {"width", dataset.width},
                       {"height", dataset.height},
                       {"lights", dataset.num_lights()},
                       {"lights_in_folder", summary.dataset_lights},
                       {"mask_pixels", summary.mask_pixels}};
  if (!summary.light_files.empty()) {
    report["dataset"]["light_subset"] = {{"rule", "ring (solver/light_subset.h SelectRingLights)"},
                                         {"files", summary.light_files}};
  }
  report["solver"] = {{"method", PhotometricMethodName(solver.method)},
                      {"min_sample_value", solver.min_sample_value},
                      {"max_condition_number", solver.max_condition_number},
                      {"robust_loss", solver.robust_loss == PhotometricSolverOptions::RobustLoss::kTukey ? "tukey"
                                                                                                          : "cauchy"},
                      {"adaptive_lobe", solver.adaptive_lobe},
                      {"adaptive_coherent_lobe", solver.adaptive_coherent_lobe},
                      {"adaptive_sheen", solver.adaptive_sheen},
                      {"adaptive_coherent_sheen", solver.adaptive_coherent_sheen},
                      {"num_threads", result.solver.num_threads}};
  report["solver"]["depth_refinement"] = nlohmann::json::parse(depth.ReportJson());
  nlohmann::json by_status, by_path, by_specular;
  for (int s = 0; s < kNumPixelStatuses; ++s) {
    by_status[PixelStatusName(static_cast<PixelStatus>(s))] = result.solver.pixels_by_status[s];
  }
  for (int p = 0; p < kNumSolvePaths; ++p) {
    by_path[SolvePathName(static_cast<SolvePath>(p))] = result.solver.pixels_by_path[p];
  }
  for (int s = 0; s < kNumSpecularStatuses; ++s) {
    by_specular[SpecularStatusName(static_cast<SpecularStatus>(s))] = result.solver.pixels_by_specular[s];
  }
  // The solve whose maps are written: the last depth re-solve's when it ran.
  report["result"] = {{"message", result.solver.BriefReport()},
                      {"pixels_by_status", by_status},
                      {"pixels_by_path", by_path},
                      {"pixels_by_specular", by_specular},
                      {"pixels_coherent_lobe", result.solver.pixels_coherent_lobe},
                      {"pixels_coherent_sheen", result.solver.pixels_coherent_sheen},
                      {"unsolved_in_mask", result.unsolved_in_mask}};
  if (result.depth.refined) report["result"]["first_pass_message"] = result.first_pass.BriefReport();
  if (result.normal_error_deg) {
    report["ground_truth"] = {{"normal_angular_error_deg", StatisticsJson(*result.normal_error_deg)},
                              {"evaluated_on", "mask.png, every pixel (unsolved ones as (0, 0, 1))"}};
  }
  report["timings_s"] = {{"load", summary.load_seconds}, {"solve", summary.solve_seconds},
                         {"depth_refine", summary.depth_seconds}, {"write_maps", summary.write_seconds}};
  if (summary.specular) report["specular"] = nlohmann::json::parse(summary.specular->ReportJson());  // issue #13
  report["depth_refinement"] = nlohmann::json::parse(result.depth.ReportJson(depth));  // as `solve` reports it
  report["outputs"] = outputs;
  return report;
}

}  // namespace

DepthRefinementOptions DatasetDepthRefinementOptions() {
  DepthRefinementOptions depth;
  depth.anchor_percentile = 50;    // mean_distance.txt is the object's (LUCES), not a table's: see the header
  depth.anchor_by_residual = true;  // and whatever a folder means by it, the images decide (ResidualScaleChooser)
  return depth;
}

void DatasetSolveOptions::Check() const {
  solver.Check();
  depth.Check();
  if (ring_lights != 0 && ring_lights < 3) {
    throw FieldError("DatasetSolveOptions", "ring_lights", ring_lights, "must be 0 (every light) or at least 3");
  }
  if (!output_dir.empty() && fs::exists(output_dir) && !overwrite) {
    throw std::invalid_argument("DatasetSolveOptions.output_dir = " + output_dir.string() +
                                " already exists; choose a new folder or allow overwrite");
  }
}

fs::path DefaultDatasetOutputFolder(const fs::path& parent, const fs::path& dataset_dir,
                                    PhotometricSolverOptions::Method method) {
  fs::path dataset = fs::absolute(dataset_dir).lexically_normal();
  if (dataset.filename().empty()) dataset = dataset.parent_path();  // "ballPNG/" names ballPNG too
  const std::string dataset_name = dataset.filename().empty() ? "dataset" : dataset.filename().string();
  const std::string name = dataset_name + "-" + PhotometricMethodName(method);
  constexpr int kMaxAttempts = 10000;
  for (int attempt = 1; attempt <= kMaxAttempts; ++attempt) {
    const fs::path folder = parent / (attempt == 1 ? name : name + "-" + std::to_string(attempt));
    std::error_code error;
    if (!fs::exists(folder, error) && !error) return folder;
  }
  throw std::invalid_argument(parent.string() + ": " + std::to_string(kMaxAttempts) + " folders named " + name +
                              "* exist already; pass --output");
}

namespace {

DepthRefinementSummary NotRefined(std::string reason) {
  DepthRefinementSummary summary;
  summary.termination = Termination::kSuccess;
  summary.stop_reason = std::move(reason);
  return summary;
}

// The depth-aware re-solves of a near-field dataset's first pass (`input`,
// *solution), in its table frame (PhotometricDataset::TableFrame).
DepthRefinementSummary RefineDatasetDepth(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                          const DepthRefinementOptions& depth, const PhotometricSolverInput& input,
                                          PhotometricSolution* solution, const ProgressCallback& progress) {
  if (dataset.kind != PhotometricDataset::Kind::kNearField) {
    return NotRefined("not applicable: distant lights (no surface points to move)");
  }
  if (!depth.enabled) return NotRefined("disabled (the plane at mean_distance only)");
  NearFieldTableFrame frame;
  try {
    frame = dataset.TableFrame();
  } catch (const std::invalid_argument& error) {
    return NotRefined(std::string("not applicable: ") + error.what());
  }
  return RefineDepth(depth, options, input, frame.lights, frame.camera, solution, nullptr, progress);
}

}  // namespace

DatasetSolveResult SolveDataset(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                const ProgressCallback& progress) {
  return SolveDataset(dataset, options, DatasetDepthRefinementOptions(), progress);
}

DatasetSolveResult SolveDataset(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                const DepthRefinementOptions& depth, const ProgressCallback& progress) {
  return SolveDataset(dataset, options, depth, progress, progress);
}

DatasetSolveResult SolveDataset(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                const DepthRefinementOptions& depth, const ProgressCallback& progress,
                                const ProgressCallback& depth_progress) {
  if (dataset.images.empty()) {
    throw std::invalid_argument("SolveDataset: dataset " + dataset.folder.string() + " was loaded without images");
  }
  depth.Check();
  DatasetSolveResult result;
  const std::unique_ptr<LightField> field = dataset.MakeLightField();
  PhotometricSolverInput input;
  input.images = dataset.ImagePointers();
  input.light_field = field.get();
  input.region = &dataset.mask;
  result.first_pass = result.solver = SolvePhotometricStereo(options, input, &result.solution, progress);
  if (result.first_pass.IsCancelled() || !result.first_pass.IsUsable()) return result;
  const auto depth_start = std::chrono::steady_clock::now();
  result.depth = RefineDatasetDepth(dataset, options, depth, input, &result.solution, depth_progress);
  result.depth_seconds = SecondsSince(depth_start);
  if (result.depth.IsCancelled()) {
    result.solver.SetCancelled("cancelled during the depth refinement");
    return result;
  }
  if (result.depth.refined) result.solver = result.depth.last_resolve;
  for (size_t i = 0; i < dataset.mask.num_pixels(); ++i) {
    result.unsolved_in_mask += dataset.mask.data()[i] != 0 &&
                               result.solution.status.data()[i] != static_cast<uint8_t>(PixelStatus::kSolved);
  }
  if (dataset.normal_ground_truth) {
    result.normal_error_deg = AngularErrorDegrees(result.solution.normal_in_table, *dataset.normal_ground_truth,
                                                  dataset.mask);
    result.error_map_deg = AngularErrorMapDegrees(result.solution.normal_in_table, *dataset.normal_ground_truth,
                                                  dataset.mask);
  }
  return result;
}

std::string DatasetSolveSummary::FullReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3);
  out << "scanbench solve-dataset report\n"
      << "  dataset:      " << dataset_name << " (" << kind << ")\n"
      << "  images:       " << num_lights << " lights, " << width << "x" << height << ", " << mask_pixels
      << " mask pixels\n"
      << "  " << solver.BriefReport() << "\n";
  if (!light_files.empty()) {
    out << "  lights:       " << num_lights << " of " << dataset_lights << " (ring subset):";
    for (const std::string& file : light_files) out << " " << file;
    out << "\n";
  }
  if (normal_error_deg) {
    out << "  normal angular error vs Normal_gt over the mask (deg): mean " << normal_error_deg->mean << ", median "
        << normal_error_deg->median << ", p95 " << normal_error_deg->percentile_95 << ", max "
        << normal_error_deg->max << " over " << normal_error_deg->num_pixels << " px ("
        << unsolved_in_mask << " unsolved, counted)\n";
  } else {
    out << "  no Normal_gt.mat: no error report\n";
  }
  if (specular) out << "  " << specular->BriefReport() << "\n";
  if (kind == KindName(PhotometricDataset::Kind::kNearField)) out << "  " << depth.BriefReport() << "\n";
  out << "  time (s): load " << Significant(load_seconds) << "; solve " << Significant(solve_seconds)
      << "; depth refine " << Significant(depth_seconds) << "; write " << Significant(write_seconds) << "\n";
  if (!output_dir.empty()) out << "  written to:   " << output_dir.string() << "\n";
  return out.str();
}

DatasetController::DatasetController(fs::path dataset_dir, DatasetSolveOptions options)
    : dataset_dir_(std::move(dataset_dir)), options_(std::move(options)) {}

void DatasetController::Run() {
  options_.Check();
  summary_ = DatasetSolveSummary();
  const PhotometricDataset dataset = LoadDataset();
  const DatasetSolveResult result = Solve(dataset);
  if (!options_.output_dir.empty()) WriteOutputs(dataset, result);
}

PhotometricDataset DatasetController::LoadDataset() {
  const auto start = Clock::now();
  BeginStage("load dataset");
  PhotometricDataset dataset = LoadPhotometricDataset(dataset_dir_);
  summary_.dataset_lights = dataset.num_lights();
  if (options_.ring_lights > 0) {
    if (options_.ring_lights > dataset.num_lights()) {
      throw FieldError("DatasetSolveOptions", "ring_lights", options_.ring_lights,
                       "must not exceed the " + std::to_string(dataset.num_lights()) + " lights of " +
                           dataset.folder.string());
    }
    dataset.KeepLights(SelectRingLights(dataset.CentralLightDirections(), options_.ring_lights));
    summary_.light_files = dataset.image_files;
  }
  summary_.dataset_name = dataset.name;
  summary_.kind = KindName(dataset.kind);
  summary_.width = dataset.width;
  summary_.height = dataset.height;
  summary_.num_lights = dataset.num_lights();
  for (size_t i = 0; i < dataset.mask.num_pixels(); ++i) summary_.mask_pixels += dataset.mask.data()[i] != 0;
  summary_.load_seconds = SecondsSince(start);
  ReportProgress("load dataset", 1);
  ThrowIfStopRequested("load dataset");
  return dataset;
}

DatasetSolveResult DatasetController::Solve(const PhotometricDataset& dataset) {
  const auto start = Clock::now();
  DatasetSolveResult result =
      SolveDataset(dataset, options_.solver, options_.depth, StageCallback("solve"), StageCallback("depth refine"));
  RequireSuccess(result.first_pass, "solve");
  RequireSuccess(result.depth, "depth refine");
  RequireSuccess(result.solver, "solve");
  summary_.solver = result.solver;
  summary_.specular = SpecularMapStatisticsOf(result.solution);
  summary_.normal_error_deg = result.normal_error_deg;
  summary_.unsolved_in_mask = result.unsolved_in_mask;
  summary_.depth = result.depth;
  summary_.depth_seconds = result.depth_seconds;
  summary_.solve_seconds = SecondsSince(start) - result.depth_seconds;
  return result;
}

// Maps and report into a staging folder renamed into place at the end: the
// output folder appears complete or not at all.
void DatasetController::WriteOutputs(const PhotometricDataset& dataset, const DatasetSolveResult& result) {
  const auto start = Clock::now();
  BeginStage("write maps");
  const fs::path out = options_.output_dir;
  if (fs::exists(out)) fs::remove_all(out);  // Check() allowed it: overwrite
  StagedFolder staged = StagedFolder::OntoAbsent(out);
  std::map<std::string, std::string> outputs =
      WriteSolutionMaps(staged.staging(), result.solution, {}, ResultMapExrEncoding(), result.error_map_deg);
  summary_.output_dir = out;
  summary_.write_seconds = SecondsSince(start);
  outputs["report"] = "report.json";
  outputs["summary"] = "summary.txt";
  const nlohmann::json report =
      DatasetReportJson(dataset_dir_, dataset, options_.solver, options_.depth, result, summary_, outputs);
  WriteFileAtomic(staged.staging() / "report.json", report.dump(2) + "\n", OverwritePolicy::kRefuse);
  WriteFileAtomic(staged.staging() / "summary.txt", summary_.FullReport(), OverwritePolicy::kRefuse);
  ThrowIfStopRequested("write maps");
  staged.Commit();
  ReportProgress("write maps", 1);
}

}  // namespace scanbench
