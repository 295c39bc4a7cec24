// Issue #15, draped samples: the depth-aware light field on simulated folds of
// +-25 mm against the default +-2.5 mm, at 400x264 (docs/solver.md has the
// full-size figures).
#include "app/controllers/depth_refinement.h"

#include <cmath>
#include <fstream>
#include <iostream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "app/sim/simulated_rig.h"
#include "calibration/camera_model.h"
#include "core/field_error.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

constexpr int kWidth = 400, kHeight = 264;

fs::path SimulateFolds(const TemporaryFolder& folder, const std::string& name, double fold_amplitude_mm) {
  SimulateOptions options;
  options.rig.width = kWidth;
  options.rig.height = kHeight;
  options.scene.fold_amplitude_mm = fold_amplitude_mm;
  const fs::path session_dir = folder / name;
  SimulateController(session_dir, options).Run();
  return session_dir;
}

SolveSummary Solve(const fs::path& session_dir, bool depth_refine) {
  SolveOptions options;
  options.depth.enabled = depth_refine;
  options.run_label = depth_refine ? "depth" : "plane";
  SolveController solve(session_dir, options);
  solve.Run();
  return solve.summary();
}

TEST(DepthRefinementTest, OptionsAreChecked) {
  DepthRefinementOptions options;
  EXPECT_NO_THROW(options.Check());
  options.max_iterations = 0;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("DepthRefinementOptions.max_iterations = 0")));
  options = {};
  options.tolerance_mm = 0;
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("tolerance_mm")));
  options = {};
  options.anchor_percentile = 60;
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("anchor_percentile")));
  SolveOptions solve;
  solve.depth.min_height_range_mm = -1;
  EXPECT_THAT([&] { solve.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("min_height_range_mm")));
}

// A point moved to height h lies on its pixel's ray at z = h.
TEST(DepthRefinementTest, SurfacePointsLieOnTheRaysAtTheHeight) {
  const CameraGeometry camera = MakeDefaultSimulatedRig(kWidth, kHeight).camera;
  ImageF height(kWidth, kHeight, 1);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) height(x, y) = static_cast<float>(0.1 * x - 0.05 * y);
  }
  const ImageF points = SurfacePointsAtHeight(camera, height);
  const ImageF table = ComputeTablePoints(camera);
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  for (const auto& [x, y] : std::vector<std::pair<int, int>>{{0, 0}, {399, 0}, {200, 132}, {17, 263}}) {
    const Eigen::Vector3d p(points(x, y, 0), points(x, y, 1), points(x, y, 2));
    const Eigen::Vector3d t(table(x, y, 0), table(x, y, 1), table(x, y, 2));
    EXPECT_NEAR(p.z(), height(x, y), 1e-3);
    const double off_ray = (p - centre).normalized().cross((t - centre).normalized()).norm();
    EXPECT_LT(off_ray, 1e-5) << "pixel " << x << "," << y;
  }
}

// The integration's frame and anchor: the ground-truth normals of the +-25 mm
// scene give its ground-truth height back (table at 0, folds up to 50 mm).
TEST(DepthRefinementTest, GroundTruthNormalsIntegrateToTheGroundTruthHeight) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateFolds(folder, "draped", 25);
  const Session session = LoadSession(session_dir);
  PhotometricSolution solution;
  solution.normal_in_table = ReadImageFloat(session_dir / session.ground_truth->normal_file);
  solution.status = ImageU8(kWidth, kHeight, 1);  // all kSolved (0)
  const ImageF truth = ReadImageFloat(session_dir / session.ground_truth->height_file);
  const ImageF height = AnchoredHeightFromSolution({}, solution, session.rig.camera);
  double error = 0, truth_max = 0;
  for (size_t i = 0; i < height.num_pixels(); ++i) {
    error += std::abs(height.data()[i] - truth.data()[i]);
    truth_max = std::max<double>(truth_max, truth.data()[i]);
  }
  error /= double(height.num_pixels());
  std::cout << "mean |height - truth| " << error << " mm, truth max " << truth_max << " mm\n";
  {
    double table_h = 0, n_table = 0, sh = 0, st = 0, stt = 0, sht = 0, n = 0;
    for (size_t i = 0; i < height.num_pixels(); ++i) {
      const double h = height.data()[i], t = truth.data()[i];
      if (t < 0.01) { table_h += h; n_table++; }
      sh += h; st += t; stt += t * t; sht += h * t; n++;
    }
    const double a = (sht / n - sh / n * st / n) / (stt / n - st / n * st / n);
    std::cout << "table mean h " << table_h / n_table << " over " << n_table << " px; fit h = " << a << " t + "
              << (sh / n - a * st / n) << "\n";
    for (int y = 0; y < kHeight; y += 33) {
      for (int x = 0; x < kWidth; x += 50) std::cout << int(height(x, y)) << "/" << int(truth(x, y)) << " ";
      std::cout << "\n";
    }
  }
  EXPECT_GT(truth_max, 30.0) << "the folds must be tens of mm high";
  EXPECT_LT(error, 2.0) << "mean absolute height error, mm";
}

// The target: on folds of +-25 mm the default solve (with the loop)
// is at most 1.3x the default solve's error on the default +-2.5 mm sample.
TEST(DepthRefinementTest, DrapedSampleSolvesNearlyAsWellAsTheFlatOne) {
  TemporaryFolder folder;
  const fs::path flat = SimulateFolds(folder, "flat", 2.5);
  const fs::path draped = SimulateFolds(folder, "draped", 25);
  const SolveSummary flat_default = Solve(flat, true);
  const SolveSummary draped_plane = Solve(draped, false);
  const SolveSummary draped_default = Solve(draped, true);
  const double flat_error = flat_default.normal_error_deg->mean;
  const double plane_error = draped_plane.normal_error_deg->mean;
  const double depth_error = draped_default.normal_error_deg->mean;
  RecordProperty("flat_mean_deg", std::to_string(flat_error));
  std::cout << "mean error (deg): flat " << flat_error << " (" << flat_default.depth.BriefReport()
            << "); draped on the table plane " << plane_error << "; draped with the loop " << depth_error << " ("
            << draped_default.depth.BriefReport() << ")\n";

  EXPECT_FALSE(draped_plane.depth.refined);
  ASSERT_TRUE(draped_default.depth.refined);
  EXPECT_GT(draped_default.depth.first_height_range_mm, 30.0);
  EXPECT_LE(depth_error, 1.3 * flat_error);
  EXPECT_GT(plane_error, 1.3 * flat_error) << "without the loop the folds must cost accuracy";
  // The surface moved by centimetres first, then less.
  const std::vector<DepthIteration>& iterations = draped_default.depth.iterations;
  EXPECT_GT(iterations.front().max_move_mm, 20.0);
  if (iterations.size() > 1) EXPECT_LT(iterations.back().max_move_mm, iterations.front().max_move_mm);

  // The report line and report.json say what ran.
  EXPECT_THAT(draped_default.FullReport(), HasSubstr("Depth refinement: success, " +
                                                      std::to_string(iterations.size()) + " iteration(s)"));
  std::ifstream in(draped_default.result_dir / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report.at("depth_refinement").at("iterations").size(), iterations.size());
  EXPECT_EQ(report.at("depth_refinement").at("stop_reason"), draped_default.depth.stop_reason);
}

}  // namespace
}  // namespace scanbench
