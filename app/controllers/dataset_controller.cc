#include "app/controllers/dataset_controller.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <iomanip>
#include <limits>
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
  if (summary.material) {
    const ClothMaterialFitSummary& fit = *summary.material;
    report["material"] = {{"message", fit.BriefReport()},
                          {"model", "glTF 2.0 metallic-roughness (metallic 0) + KHR_materials_sheen (Charlie, "
                                    "Neubelt visibility) + KHR_materials_specular (white); solver/cloth_material.h"},
                          {"pixels_fitted", fit.pixels_fitted},
                          {"pixels_sheen", fit.pixels_sheen},
                          {"pixels_specular", fit.pixels_specular},
                          {"pixels_too_few_samples", fit.pixels_too_few_samples},
                          {"seconds", summary.material_seconds}};
  }
  if (summary.relighting) {
    const RelightingCheckSummary& check = *summary.relighting;
    nlohmann::json lights = nlohmann::json::array();
    for (size_t i = 0; i < check.lights.size(); ++i) {
      lights.push_back({{"file", i < summary.predicted_files.size() ? summary.predicted_files[i] : ""},
                        {"material", check.lights[i].material},
                        {"lambertian", check.lights[i].lambertian},
                        {"pixels", check.lights[i].samples}});
    }
    report["relighting"] = {
        {"mode", summary.relighting_mode},
        {"error", "sum |predicted - photo| / sum photo over the mask's fitted pixels, RGB"},
        {"material_error", check.material_error},
        {"lambertian_error", check.lambertian_error},
        {"ratio", check.Ratio()},
        {"pixels_scored", check.pixels_scored},
        {"lights", lights}};
  }
  report["outputs"] = outputs;
  return report;
}

// The material maps into `folder`; their names and files.
std::map<std::string, std::string> WriteMaterialMaps(const fs::path& folder, const ClothMaterialMaps& maps) {
  WriteExr(folder / "base_color.exr", maps.base_color, OverwritePolicy::kRefuse);
  WriteExr(folder / "sheen_color.exr", maps.sheen_color, OverwritePolicy::kRefuse);
  WriteExr(folder / "sheen_roughness.exr", maps.sheen_roughness, OverwritePolicy::kRefuse);
  WriteExr(folder / "material_specular.exr", maps.specular, OverwritePolicy::kRefuse, {"f0", "roughness"});
  WriteExr(folder / "material_confidence.exr", maps.confidence, OverwritePolicy::kRefuse,
           {"sheen_color_stderr", "sheen_roughness_stderr", "specular_f0_stderr", "specular_roughness_stderr"});
  WritePng(folder / "material_terms.png", maps.terms, OverwritePolicy::kRefuse);
  return {{"base_color", "base_color.exr"},           {"sheen_color", "sheen_color.exr"},
          {"sheen_roughness", "sheen_roughness.exr"}, {"material_specular", "material_specular.exr"},
          {"material_confidence", "material_confidence.exr"}, {"material_terms", "material_terms.png"}};
}

// The 0-based indices of the 1-based light numbers `numbers` of a folder of `count` lights.
std::vector<int> LightIndices(const std::vector<int>& numbers, int count, const std::string& folder) {
  std::vector<int> indices;
  for (int number : numbers) {
    if (number < 1 || number > count) {
      throw FieldError("DatasetSolveOptions", "fit_lights", number,
                       "must name lights 1 to " + std::to_string(count) + " of " + folder);
    }
    if (std::find(indices.begin(), indices.end(), number - 1) != indices.end()) {
      throw FieldError("DatasetSolveOptions", "fit_lights", number, "is given twice");
    }
    indices.push_back(number - 1);
  }
  std::sort(indices.begin(), indices.end());
  return indices;
}

// `image` (values 0..1 of the file's range) rounded to T's whole range.
template <typename T>
Image<T> Quantised(const ImageF& image) {
  constexpr double kMax = std::numeric_limits<T>::max();
  Image<T> out(image.width(), image.height(), image.channels());
  for (size_t i = 0; i < image.size(); ++i) {
    out.data()[i] = static_cast<T>(std::lround(std::clamp(static_cast<double>(image.data()[i]), 0.0, 1.0) * kMax));
  }
  return out;
}

// A prediction as the photograph would be: the file's format and bit depth.
void WritePredictedPhoto(const fs::path& path, const fs::path& like, const ImageF& predicted) {
  const ImageFileInfo info = ReadImageFileInfo(like);
  std::string extension = like.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  if (extension != ".png" || info.is_float) {
    WriteExr(fs::path(path).replace_extension(".exr"), predicted, OverwritePolicy::kRefuse);
    return;
  }
  if (info.bits_per_sample > 8) {
    WritePng(path, Quantised<uint16_t>(predicted), OverwritePolicy::kRefuse);
  } else {
    WritePng(path, Quantised<uint8_t>(predicted), OverwritePolicy::kRefuse);
  }
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
  relighting.Check();
  if (!fit_lights.empty() && fit_lights.size() < 6) {
    throw FieldError("DatasetSolveOptions", "fit_lights", fit_lights.size(), "lights: give at least 6");
  }
  if (!predict_dir.empty() && fit_lights.empty()) {
    throw std::invalid_argument("DatasetSolveOptions.predict_dir = " + predict_dir.string() +
                                " needs fit_lights: the lights to predict are those not fitted");
  }
  if (!predict_dir.empty() && fs::exists(predict_dir)) {
    throw std::invalid_argument("DatasetSolveOptions.predict_dir = " + predict_dir.string() +
                                " already exists; choose a new folder");
  }
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
  if (material) out << "  " << material->BriefReport() << "\n";
  if (relighting) {
    out << "  " << relighting->BriefReport() << " (" << relighting_mode << ")\n";
    // Per light where they fit on a screen; report.json has them all.
    for (size_t i = 0; i < relighting->lights.size() && relighting->lights.size() <= 16; ++i) {
      out << "    " << (i < predicted_files.size() ? predicted_files[i] : std::to_string(i + 1)) << ": material "
          << Significant(100 * relighting->lights[i].material, 3) << " %, Lambertian "
          << Significant(100 * relighting->lights[i].lambertian, 3) << " %\n";
    }
  }
  if (kind == KindName(PhotometricDataset::Kind::kNearField)) out << "  " << depth.BriefReport() << "\n";
  out << "  time (s): load " << Significant(load_seconds) << "; solve " << Significant(solve_seconds)
      << "; depth refine " << Significant(depth_seconds) << "; material " << Significant(material_seconds)
      << "; write " << Significant(write_seconds) << "\n";
  if (!output_dir.empty()) out << "  written to:   " << output_dir.string() << "\n";
  return out.str();
}

DatasetController::DatasetController(fs::path dataset_dir, DatasetSolveOptions options)
    : dataset_dir_(std::move(dataset_dir)), options_(std::move(options)) {}

void DatasetController::Run() {
  options_.Check();
  summary_ = DatasetSolveSummary();
  PhotometricDataset dataset = LoadDataset();
  // --fit-lights: the solve and the material from those lights, the folder's every light kept to score against.
  std::optional<PhotometricDataset> all_lights;
  if (!options_.fit_lights.empty()) {
    all_lights = dataset;
    dataset.KeepLights(LightIndices(options_.fit_lights, dataset.num_lights(), dataset.folder.string()));
    summary_.num_lights = dataset.num_lights();
  }
  const DatasetSolveResult result = Solve(dataset);
  std::optional<ClothMaterialMaps> material;
  if (options_.material || all_lights) material = FitMaterial(dataset, all_lights ? &*all_lights : nullptr, result);
  if (!options_.output_dir.empty()) WriteOutputs(dataset, result, material ? &*material : nullptr);
  if (!options_.predict_dir.empty()) WritePredictions(*all_lights, result, *material);
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

ClothMaterialMaps DatasetController::FitMaterial(const PhotometricDataset& dataset,
                                                const PhotometricDataset* all_lights,
                                                const DatasetSolveResult& result) {
  const auto start = Clock::now();
  const std::unique_ptr<LightField> field = dataset.MakeLightField();
  PhotometricSolverInput input;
  input.images = dataset.ImagePointers();
  input.light_field = field.get();
  const ImageF& normals = result.solution.normal_in_table;
  // Only what the solve solved: its placeholders are not normals.
  ImageU8 pixels(dataset.width, dataset.height, 1);
  for (size_t i = 0; i < pixels.size(); ++i) {
    pixels.data()[i] = dataset.mask.data()[i] != 0 &&
                       result.solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
  }
  ClothMaterialFitOptions fit = options_.relighting.fit;
  fit.num_threads = options_.solver.num_threads;
  ClothMaterialMaps maps;
  const ClothMaterialFitSummary fitted = FitClothMaterial(fit, input, normals, pixels, &maps, StageCallback("material"));
  RequireSuccess(fitted, "material");
  summary_.material = fitted;

  RelightingCheckSummary check;
  if (all_lights == nullptr) {
    RelightingCheckOptions relighting = options_.relighting;
    relighting.fit.num_threads = fit.num_threads;
    check = CheckRelighting(relighting, input, normals, pixels, StageCallback("relighting check"));
    RequireSuccess(check, "relighting check");
    summary_.predicted_files = dataset.image_files;
    summary_.relighting_mode = "leave_one_light_out";
  } else {
    // The other lights, predicted by the material and by albedo x n.l from the fitted lights.
    BeginStage("predict lights");
    ClothMaterialFitOptions albedo_only = fit;
    albedo_only.fit_sheen = albedo_only.fit_specular = false;
    ClothMaterialMaps lambertian;
    RequireSuccess(FitClothMaterial(albedo_only, input, normals, pixels, &lambertian), "material");
    ImageU8 both(dataset.width, dataset.height, 1);
    for (size_t i = 0; i < both.size(); ++i) {
      both.data()[i] = (maps.terms.data()[i] & kMaterialFitted) && (lambertian.terms.data()[i] & kMaterialFitted);
      check.pixels_scored += both.data()[i];
    }
    const std::unique_ptr<LightField> all_field = all_lights->MakeLightField();
    const std::vector<int> fitted_indices = LightIndices(options_.fit_lights, all_lights->num_lights(), "");
    double material_sum = 0, lambertian_sum = 0;
    int scored = 0;
    for (int light = 0; light < all_lights->num_lights(); ++light) {
      if (std::binary_search(fitted_indices.begin(), fitted_indices.end(), light)) continue;
      ThrowIfStopRequested("predict lights");
      const RelightingLightError error = ScoreLightPrediction(
          PredictLightImage(maps, normals, *all_field, light, fit.num_threads),
          PredictLightImage(lambertian, normals, *all_field, light, fit.num_threads), all_lights->images[light], both);
      check.lights.push_back(error);
      summary_.predicted_files.push_back(all_lights->image_files[light]);
      if (error.samples > 0) material_sum += error.material, lambertian_sum += error.lambertian, ++scored;
      ReportProgress("predict lights", static_cast<double>(light + 1) / all_lights->num_lights());
    }
    if (scored > 0) {
      check.material_error = material_sum / scored;
      check.lambertian_error = lambertian_sum / scored;
    }
    check.termination = Termination::kSuccess;
    summary_.relighting_mode = "fit_lights";
  }
  summary_.relighting = check;
  summary_.material_seconds = SecondsSince(start);
  return maps;
}

void DatasetController::WritePredictions(const PhotometricDataset& all_lights, const DatasetSolveResult& result,
                                         const ClothMaterialMaps& material) {
  BeginStage("write predictions");
  StagedFolder staged = StagedFolder::OntoAbsent(options_.predict_dir);
  const std::unique_ptr<LightField> field = all_lights.MakeLightField();
  const std::vector<int> fitted = LightIndices(options_.fit_lights, all_lights.num_lights(), "");
  for (int light = 0; light < all_lights.num_lights(); ++light) {
    if (std::binary_search(fitted.begin(), fitted.end(), light)) continue;
    ThrowIfStopRequested("write predictions");
    const fs::path file = fs::path(all_lights.image_files[light]).filename();
    WritePredictedPhoto(staged.staging() / file, all_lights.folder / all_lights.image_files[light],
                        PredictLightImage(material, result.solution.normal_in_table, *field, light,
                                          options_.solver.num_threads));
    ReportProgress("write predictions", static_cast<double>(light + 1) / all_lights.num_lights());
  }
  staged.Commit();
}

// Maps and report into a staging folder renamed into place at the end: the
// output folder appears complete or not at all.
void DatasetController::WriteOutputs(const PhotometricDataset& dataset, const DatasetSolveResult& result,
                                     const ClothMaterialMaps* material) {
  const auto start = Clock::now();
  BeginStage("write maps");
  const fs::path out = options_.output_dir;
  if (fs::exists(out)) fs::remove_all(out);  // Check() allowed it: overwrite
  StagedFolder staged = StagedFolder::OntoAbsent(out);
  std::map<std::string, std::string> outputs =
      WriteSolutionMaps(staged.staging(), result.solution, {}, ResultMapExrEncoding(), result.error_map_deg);
  if (material) outputs.merge(WriteMaterialMaps(staged.staging(), *material));
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
