// Solves a public photometric-stereo dataset folder (DiLiGenT, or the
// LUCES-style near-field layout; see app/io/dataset_io.h) and writes normals,
// albedo, confidence and, with ground truth, an error report.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/io/dataset_io.h"
#include "app/io/result_maps.h"
#include "pipeline/depth_refinement.h"
#include "pipeline/relighting_check.h"
#include "solver/angular_error.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// solve-dataset's depth refinement: `scanbench solve`'s defaults (the same
// options, --depth-*), but the anchor. `solve` puts the lowest 0.5 % of the
// integrated height on its calibrated table. A folder has no table: its
// mean_distance.txt is, as in LUCES, the object's mean distance from the
// camera (or a writer's guess of it, or missing), so the distances' factor
// is chosen by the images (anchor_by_residual, ResidualScaleChooser), the
// search centred where the median of the height lies on that plane
// (anchor_percentile 50).
DepthRefinementOptions DatasetDepthRefinementOptions();

struct DatasetSolveOptions {
  PhotometricSolverOptions solver;
  // Near-field folders (issue #33): integrate the first pass's normals to a
  // depth, move each pixel's surface point along its ray to it, re-solve
  // with the LEDs evaluated there (pipeline/depth_refinement.h, as `solve`).
  // Distant-light folders have no light field to move: ignored there.
  DepthRefinementOptions depth = DatasetDepthRefinementOptions();
  // Folder the maps and report go to; created, must not exist unless
  // `overwrite`. Empty = no files written (figures only).
  std::filesystem::path output_dir;
  bool overwrite = false;  // replace an existing output_dir
  // 0 = every light; else only this many, chosen like the scanner's two LED
  // rings (SelectRingLights, solver/light_subset.h), in [3, the dataset's lights].
  int ring_lights = 0;
  // Issue #34: fit the cloth material (solver/cloth_material.h) at the solved
  // normals, write its maps and check it by relighting: without fit_lights,
  // each light predicted from the others (CheckRelighting).
  bool material = false;
  RelightingCheckOptions relighting;  // the fit's options are relighting.fit
  // Light numbers (1 = the folder's first image, after ring_lights), each in
  // [1, lights], at least 6, distinct: the solve and the material use only
  // these, and every other light is predicted from them and scored against
  // its photograph. Implies material. Empty = every light.
  std::vector<int> fit_lights;
  // With fit_lights: the predicted photograph of every other light, under its
  // file name and in its format (PNG of its bit depth), into this folder
  // (created; must not exist). Empty = none written.
  std::filesystem::path predict_dir;

  void Check() const;
};

// The folder `solve-dataset` writes to when none is given:
// <parent>/<dataset folder name>-<method>, or the first of -2, -3, ... that does
// not exist yet, so a re-solve writes a new result beside the earlier one.
std::filesystem::path DefaultDatasetOutputFolder(const std::filesystem::path& parent,
                                                 const std::filesystem::path& dataset_dir,
                                                 PhotometricSolverOptions::Method method);

// Everything a solve of a loaded dataset gives, without files.
struct DatasetSolveResult {
  PhotometricSolution solution;
  PhotometricSolverSummary solver;
  // Against Normal_gt over the mask, every mask pixel (unsolved ones with
  // their (0, 0, 1) placeholder, as the benchmark counts them).
  std::optional<ErrorStatistics> normal_error_deg;
  ImageF error_map_deg;  // 1 channel, 0 off the mask; empty without ground truth
  size_t unsolved_in_mask = 0;
  // The depth-aware re-solves: solution and solver are the last re-solve's
  // when it ran (depth.refined), else the first pass's. Distant lights:
  // stop_reason "not applicable: ...".
  DepthRefinementSummary depth;
  PhotometricSolverSummary first_pass;  // the first pass's summary (= solver when not refined)
  double depth_seconds = 0;             // the refinement's wall time (the decision included)
};

// Solves `dataset` (images loaded) on its mask, then on a near-field
// dataset refines the depth as `depth` says (RefineDepth in the dataset's
// TableFrame; a K that frame cannot hold skips it, the stop reason says
// why). Throws std::invalid_argument for bad options; a cancelled solve
// returns with solver.termination kCancelled.
DatasetSolveResult SolveDataset(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                const DepthRefinementOptions& depth, const ProgressCallback& progress = {});
// The same with DatasetDepthRefinementOptions().
DatasetSolveResult SolveDataset(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                const ProgressCallback& progress = {});
// The same with the refinement's progress (and cancel) apart from the first pass's.
DatasetSolveResult SolveDataset(const PhotometricDataset& dataset, const PhotometricSolverOptions& options,
                                const DepthRefinementOptions& depth, const ProgressCallback& progress,
                                const ProgressCallback& depth_progress);

struct DatasetSolveSummary {
  std::string dataset_name;
  std::string kind;  // "distant_lights (DiLiGenT)" or "near_field (LUCES-style)"
  int width = 0, height = 0, num_lights = 0;
  int dataset_lights = 0;                 // lights in the folder (num_lights = those solved with)
  std::vector<std::string> light_files;   // with ring_lights: the images kept
  size_t mask_pixels = 0;
  PhotometricSolverSummary solver;
  std::optional<ErrorStatistics> normal_error_deg;
  size_t unsolved_in_mask = 0;
  std::optional<SpecularMapStatistics> specular;  // when the method made a specular map (specular.exr)
  // With material: the fit, and its check (leave one light out, or with
  // fit_lights the other lights' predictions, one entry each in
  // predicted_files' order).
  std::optional<ClothMaterialFitSummary> material;
  std::optional<RelightingCheckSummary> relighting;
  std::vector<std::string> predicted_files;
  std::string relighting_mode;  // "leave_one_light_out" or "fit_lights"
  double material_seconds = 0;
  DepthRefinementSummary depth;                   // the depth-aware re-solves (near field)
  double load_seconds = 0, solve_seconds = 0, depth_seconds = 0, write_seconds = 0;
  std::filesystem::path output_dir;

  std::string FullReport() const;
};

class DatasetController : public BaseController {
 public:
  DatasetController(std::filesystem::path dataset_dir, DatasetSolveOptions options);
  void Run() override;
  const DatasetSolveSummary& summary() const { return summary_; }

 private:
  PhotometricDataset LoadDataset();
  DatasetSolveResult Solve(const PhotometricDataset& dataset);
  // The material at the solve's normals and its check; `all_lights` is the
  // folder's every light when fit_lights chose `dataset`'s, else null.
  ClothMaterialMaps FitMaterial(const PhotometricDataset& dataset, const PhotometricDataset* all_lights,
                                const DatasetSolveResult& result);
  void WriteOutputs(const PhotometricDataset& dataset, const DatasetSolveResult& result,
                    const ClothMaterialMaps* material);
  void WritePredictions(const PhotometricDataset& all_lights, const DatasetSolveResult& result,
                        const ClothMaterialMaps& material);

  std::filesystem::path dataset_dir_;
  DatasetSolveOptions options_;
  DatasetSolveSummary summary_;
};

}  // namespace scanbench
