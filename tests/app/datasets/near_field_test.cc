// Issue #33, item 5: near-field (LUCES-style) folders from the simulated rig
// (SimulateDatasetController) and solve-dataset's depth refinement on them:
// a draped LAMBERTIAN twill with cast shadows lit by the rig's point LEDs,
// folds of +-6 and +-24 mm. docs/solver.md ("Datasets") has the figures.
#include <cmath>
#include <fstream>
#include <iostream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/dataset_controller.h"
#include "app/controllers/simulate_dataset_controller.h"
#include "app/io/dataset_io.h"
#include "app/sim/simulated_rig.h"
#include "calibration/camera_model.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

// The default scene (its twill, folds, seeds; RAW frames with noise, cast
// shadows) at width x height, the weave scaled with the image so that a
// thread keeps the ~20 px it has at the default 1232x816 (finer weaves are
// mostly demosaicing error, docs/simulated-rig.md).
fs::path SimulateFolder(const fs::path& folder, int width, int height, double fold_amplitude_mm, bool raw = true) {
  SimulateDatasetOptions options;
  options.rig.width = width;
  options.rig.height = height;
  options.rig.num_threads = 1;
  const double weave_scale = 1232.0 / width;
  options.scene.warp_pitch_mm *= weave_scale;
  options.scene.weft_pitch_mm *= weave_scale;
  options.scene.fold_amplitude_mm = fold_amplitude_mm;
  options.raw_path = raw;
  SimulateDatasetController controller(folder, options);
  controller.Run();
  return folder;
}

struct Solved {
  DatasetSolveResult result;
  size_t mask_pixels = 0;
  size_t non_lambertian = 0;  // pixels with a specular lobe (per pixel or shared) or a shared sheen
  double mean_error() const { return result.normal_error_deg->mean; }
  double non_lambertian_share() const { return double(non_lambertian) / double(mask_pixels); }
};

Solved Solve(const PhotometricDataset& dataset, const DepthRefinementOptions& depth) {
  PhotometricSolverOptions solver;
  solver.num_threads = 1;
  Solved solved;
  solved.result = SolveDataset(dataset, solver, depth);
  const PhotometricSolution& s = solved.result.solution;
  for (size_t i = 0; i < dataset.mask.num_pixels(); ++i) {
    if (!dataset.mask.data()[i]) continue;
    ++solved.mask_pixels;
    const bool lobe = !s.specular_status.empty() &&
                      s.specular_status.data()[i] == static_cast<uint8_t>(SpecularStatus::kEstimated);
    const bool sheen = !s.coherent_sheen.empty() && s.coherent_sheen.data()[i] != 0;
    solved.non_lambertian += lobe || sheen;
  }
  return solved;
}

DepthRefinementOptions PlaneOnly() {
  DepthRefinementOptions depth = DatasetDepthRefinementOptions();
  depth.enabled = false;
  return depth;
}

// The folder holds the layout solve-dataset reads, in its conventions (OpenCV
// camera frame, readings at 1 mm): a noise-free render of a flat sample
// solves to a few hundredths of a degree, and the table frame's camera
// matches K.
TEST(SimulatedNearFieldFolderTest, WritesTheLucesLayoutInItsConventions) {
  TemporaryFolder folder;
  const fs::path dir = SimulateFolder(folder / "flat", 160, 120, 0.0, /*raw=*/false);
  for (const char* name : {"01.png", "10.png", "filenames.txt", "light_positions.txt", "light_directions.txt",
                           "light_intensities.txt", "light_mu.txt", "K.txt", "mean_distance.txt", "mask.png",
                           "Normal_gt.mat"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / name)) << name;
  }
  const PhotometricDataset dataset = LoadPhotometricDataset(dir);
  EXPECT_EQ(dataset.kind, PhotometricDataset::Kind::kNearField);
  EXPECT_EQ(dataset.num_lights(), 10);
  // The sample (0.3 mm base and 0.22 mm threads) lies on the table 600 mm away.
  EXPECT_GT(dataset.surface_distance_mm, 599.0);
  EXPECT_LT(dataset.surface_distance_mm, 600.0);
  const NearFieldTableFrame frame = dataset.TableFrame();
  EXPECT_DOUBLE_EQ(frame.camera.intrinsics.fx, dataset.camera_matrix(0, 0));
  EXPECT_NEAR(CameraCentreInTable(frame.camera).z(), dataset.surface_distance_mm, 1e-9);
  // The LEDs 500 mm from the sample centre, above it.
  for (const PointLight& light : frame.lights) {
    EXPECT_NEAR(light.position.norm(), 500.0, 10.0);
    EXPECT_GT(light.position.z(), 200.0);
  }
  const Solved solved = Solve(dataset, DatasetDepthRefinementOptions());
  std::cout << "flat, noise-free: mean error " << solved.mean_error() << " deg; " << solved.result.depth.BriefReport()
            << "\n";
  EXPECT_LT(solved.mean_error(), 0.05);
  EXPECT_EQ(solved.result.unsolved_in_mask, 0u);
  EXPECT_FALSE(solved.result.depth.refined);  // flat: the plane is kept
  EXPECT_EQ(solved.non_lambertian, 0u);
}

// ResidualScaleChooser finds the surface's distance from the images: given
// the true shape (each pixel's true distance along its ray up to a factor)
// and a start 5 % off, it returns the true factor.
TEST(SimulatedNearFieldFolderTest, ResidualScaleChooserFindsTheTrueDistance) {
  TemporaryFolder folder;
  SimulateDatasetOptions options;
  options.rig.width = 160;
  options.rig.height = 120;
  options.rig.num_threads = 1;
  options.scene.fold_amplitude_mm = 24;
  options.scene.warp_pitch_mm *= 1232.0 / 160;
  options.scene.weft_pitch_mm *= 1232.0 / 160;
  SimulateDatasetController(folder / "folds24", options).Run();
  const PhotometricDataset dataset = LoadPhotometricDataset(folder / "folds24");
  const NearFieldTableFrame frame = dataset.TableFrame();
  // The simulator's surface points, in the folder's table frame.
  const RigDescription rig_description = SimulatedDatasetRig(160, 120, options.rig.color);
  const GroundTruthMaps truth =
      SimulatedRig(options.rig, TextileScene(options.scene), rig_description).RenderGroundTruth();
  const Eigen::Vector3d centre = CameraCentreInTable(frame.camera);
  const ImageF table = ComputeTablePoints(frame.camera);
  ImageF q(160, 120, 1);
  PhotometricSolution solution;
  solution.status = ImageU8(160, 120, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const Eigen::Vector3d p(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1),
                              truth.point_in_table(x, y, 2));
      const Eigen::Vector3d cam = rig_description.camera.cam_from_table * p;
      const Eigen::Vector3d point(cam.x(), -cam.y(), dataset.surface_distance_mm - cam.z());
      const Eigen::Vector3d on_table(table(x, y, 0), table(x, y, 1), table(x, y, 2));
      q(x, y) = static_cast<float>((point - centre).norm() / (on_table - centre).norm());
      if (dataset.mask(x, y)) solution.status(x, y) = static_cast<uint8_t>(PixelStatus::kSolved);
    }
  }
  PhotometricSolverOptions solver;
  solver.num_threads = 1;
  PhotometricSolverInput input;
  input.images = dataset.ImagePointers();
  const DepthScaleChooser choose = ResidualScaleChooser(solver, input, nullptr, frame.lights, frame.camera);
  EXPECT_NEAR(choose(solution, q, 1.05), 1.0, 0.002);
  EXPECT_NEAR(choose(solution, q, 1.0 / 1.05), 1.0, 0.002);
}

// Why a Lambertian drape got non-Lambertian terms (issue #33): the light
// field evaluated away from the surface. On the plane at mean_distance.txt
// (no refinement), or with the surface's distance anchored where the folder's
// mean_distance.txt does not mean it (here the table's distance written
// instead of the sample's mean, as a writer may), the per-pixel Lambertian
// residual carries the wrong LED directions and falloff and the lobe and
// sheen passes take it for a material. With the depth refinement choosing
// the distance by the residual, none is left but at a few shadow edges.
// Measured at 320x240 (noise, cast shadows, RAW development): +-24 mm on the
// plane 1.618 deg, 556 px (1.0 %) lobe or sheen; table distance, percentile
// anchor 1.451 deg, 7194 px (13.2 %); refined 0.674 deg, 49 px (0.09 %),
// with either mean_distance.txt; +-6 mm 0.402 deg, 10 px (0.02 %).
TEST(NearFieldDepthRefinementTest, NoLobeOrSheenOnDrapedLambertianFoldersWithShadows) {
  TemporaryFolder folder;
  const fs::path light = SimulateFolder(folder / "folds6", 320, 240, 6.0);
  const fs::path draped = SimulateFolder(folder / "folds24", 320, 240, 24.0);
  PhotometricDataset draped_data = LoadPhotometricDataset(draped);
  const Solved refined6 = Solve(LoadPhotometricDataset(light), DatasetDepthRefinementOptions());
  const Solved plane24 = Solve(draped_data, PlaneOnly());
  const Solved refined24 = Solve(draped_data, DatasetDepthRefinementOptions());
  // The same images, mean_distance.txt as a table's distance.
  const double sample_mean_distance = draped_data.surface_distance_mm;
  draped_data.surface_distance_mm = 600.0;
  DepthRefinementOptions percentile_anchor = DatasetDepthRefinementOptions();
  percentile_anchor.anchor_by_residual = false;
  const Solved table24_percentile = Solve(draped_data, percentile_anchor);
  const Solved table24 = Solve(draped_data, DatasetDepthRefinementOptions());
  for (const auto& [name, solved] :
       std::vector<std::pair<std::string, const Solved*>>{{"+-6 refined", &refined6},
                                                          {"+-24 plane", &plane24},
                                                          {"+-24 refined", &refined24},
                                                          {"+-24 table distance, percentile anchor", &table24_percentile},
                                                          {"+-24 table distance, refined", &table24}}) {
    std::cout << name << ": mean " << solved->mean_error() << " deg, lobe or sheen at " << solved->non_lambertian
              << " px (" << 100 * solved->non_lambertian_share() << " %); " << solved->result.depth.BriefReport()
              << "\n";
  }
  EXPECT_GT(sample_mean_distance, 570.0);  // the folds lift the sample by 0 .. 48 mm
  EXPECT_LT(sample_mean_distance, 590.0);

  // The cause: surface points in the wrong place.
  EXPECT_GT(plane24.non_lambertian_share(), 0.005);
  EXPECT_GT(table24_percentile.non_lambertian_share(), 0.05);
  EXPECT_GT(table24_percentile.mean_error(), 1.5 * refined24.mean_error());
  // The fix: at most 0.2 % of the pixels (measured 0.03-0.07 %), all at cast
  // shadows' edges, whatever the folder's mean_distance.txt means.
  EXPECT_LT(refined6.non_lambertian_share(), 0.002);
  EXPECT_LT(refined24.non_lambertian_share(), 0.002);
  EXPECT_LT(table24.non_lambertian_share(), 0.002);
  EXPECT_NEAR(table24.mean_error(), refined24.mean_error(), 0.02);
  ASSERT_TRUE(table24.result.depth.refined);
  EXPECT_NEAR(table24.result.depth.iterations.back().scale_vs_percentile, sample_mean_distance / 600.0, 0.01);
  // And the refinement's own gains: no pixel left unsolved by the shadow-edge
  // masks (they were solved with their edge samples instead), less error.
  EXPECT_EQ(refined24.result.unsolved_in_mask, 0u);
  EXPECT_GT(refined24.result.depth.shadow_edge_kept_pixels, 0u);
  EXPECT_LT(refined24.mean_error(), 0.6 * plane24.mean_error());
}

// The target: the draped sample (+-24 mm) within 1.5x the error of
// the same sample with +-6 mm folds, and better than without the depth
// refinement. Measured at 640x480: +-6 mm 0.313 deg, +-24 mm 0.441 (1.41x;
// on the plane 1.082), lobe or sheen at 22 and 6 px of 218175 (on the plane
// 4370). At 320x240 (the test above) 1.68x: the demosaicing's error on the
// steep walls, a larger share of a small image; at 1232x816 see docs/solver.md.
TEST(NearFieldDepthRefinementTest, DrapedLambertianFolderWithinOneAndAHalfTimesTheLightlyFoldedOne) {
  TemporaryFolder folder;
  const PhotometricDataset light = LoadPhotometricDataset(SimulateFolder(folder / "folds6", 640, 480, 6.0));
  const PhotometricDataset draped = LoadPhotometricDataset(SimulateFolder(folder / "folds24", 640, 480, 24.0));
  const Solved refined6 = Solve(light, DatasetDepthRefinementOptions());
  const Solved refined24 = Solve(draped, DatasetDepthRefinementOptions());
  const Solved plane24 = Solve(draped, PlaneOnly());
  std::cout << "640x480 mean error (deg): +-6 mm " << refined6.mean_error() << ", +-24 mm " << refined24.mean_error()
            << " (" << refined24.mean_error() / refined6.mean_error() << "x), +-24 mm on the plane "
            << plane24.mean_error() << "; lobe or sheen at " << refined6.non_lambertian << " / "
            << refined24.non_lambertian << " / " << plane24.non_lambertian << " px\n";
  EXPECT_LE(refined24.mean_error(), 1.5 * refined6.mean_error());
  EXPECT_LT(refined24.mean_error(), 0.5 * plane24.mean_error());
  EXPECT_LT(refined6.non_lambertian_share(), 0.001);
  EXPECT_LT(refined24.non_lambertian_share(), 0.001);
}

// solve-dataset's files say what the refinement did, as `solve`'s do.
TEST(NearFieldDepthRefinementTest, ReportNamesTheDepthRefinement) {
  TemporaryFolder folder;
  const fs::path draped = SimulateFolder(folder / "folds24", 320, 240, 24.0);
  DatasetSolveOptions options;
  options.solver.num_threads = 1;
  options.output_dir = folder / "out";
  DatasetController controller(draped, options);
  controller.Run();
  const DatasetSolveSummary& summary = controller.summary();
  ASSERT_TRUE(summary.depth.refined);
  const size_t iterations = summary.depth.iterations.size();
  EXPECT_THAT(summary.FullReport(),
              HasSubstr("Depth refinement: success, " + std::to_string(iterations) + " iteration(s)"));
  std::ifstream in(folder / "out" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  const nlohmann::json& depth = report.at("depth_refinement");
  EXPECT_TRUE(depth.at("refined").get<bool>());
  EXPECT_EQ(depth.at("iterations").size(), iterations);
  EXPECT_EQ(depth.at("stop_reason"), summary.depth.stop_reason);
  EXPECT_GT(depth.at("iterations").at(0).at("scale_vs_percentile").get<double>(), 0.9);
  EXPECT_TRUE(report.at("solver").at("depth_refinement").at("anchor_by_residual").get<bool>());
  EXPECT_EQ(report.at("solver").at("depth_refinement").at("anchor_percentile").get<double>(), 50.0);
  EXPECT_EQ(report.at("result").at("pixels_by_specular").at("estimated").get<size_t>(),
            summary.solver.pixels_by_specular[static_cast<int>(SpecularStatus::kEstimated)]);
  EXPECT_TRUE(report.at("result").contains("first_pass_message"));
  EXPECT_GT(report.at("timings_s").at("depth_refine").get<double>(), 0.0);

  // --no-depth-refine: the plane at mean_distance.txt, and the report says so.
  options.depth.enabled = false;
  options.output_dir = folder / "plane";
  DatasetController plane(draped, options);
  plane.Run();
  EXPECT_FALSE(plane.summary().depth.refined);
  EXPECT_THAT(plane.summary().FullReport(), HasSubstr("stopped: disabled"));
  EXPECT_GT(plane.summary().normal_error_deg->mean, summary.normal_error_deg->mean);
}

}  // namespace
}  // namespace scanbench
