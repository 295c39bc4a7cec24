// Issue #15, draped samples: the depth-aware light field on simulated folds of
// +-25 mm against the default +-2.5 mm, at 400x264 (docs/solver.md has the
// full-size figures).
#include "pipeline/depth_refinement.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/solve_controller.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/textile_scene.h"
#include "calibration/camera_model.h"
#include "core/field_error.h"
#include "tests/util/solved_session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

constexpr int kWidth = 400, kHeight = 264;

fs::path SimulateFolds(const TemporaryFolder& folder, const std::string& name, double fold_amplitude_mm) {
  return testing::SimulateFoldedSession(folder / name, kWidth, kHeight, fold_amplitude_mm);
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
// The integration is perspective-exact (the log of the distance along each
// camera ray). Measured: 0.07 mm high on the sample on average, 1.37 mm mean
// absolute shape error about that (most of it at the steep edge blend); the
// orthographic integration at the table's pixel footprint it replaced gave
// 0.53 mm low and 2.3 mm.
TEST(DepthRefinementTest, GroundTruthNormalsIntegrateToTheGroundTruthHeight) {
  TemporaryFolder folder;
  const fs::path session_dir = SimulateFolds(folder, "draped", 25);
  const Session session = LoadSession(session_dir);
  PhotometricSolution solution;
  solution.normal_in_table = ReadImageFloat(session_dir / session.ground_truth->normal_file);
  solution.status = ImageU8(kWidth, kHeight, 1);  // all kSolved (0)
  const ImageF truth = ReadImageFloat(session_dir / session.ground_truth->height_file);
  const ImageF height = AnchoredHeightFromSolution({}, solution, session.rig.camera);
  const ImageU8 mask = ReadImageU8(session_dir / session.ground_truth->mask_file);
  // On the sample: the offset (the anchor) and the shape about it.
  double offset = 0, truth_max = 0;
  size_t count = 0;
  for (size_t i = 0; i < height.num_pixels(); ++i) {
    if (mask.data()[i * mask.channels()] < 128) continue;
    offset += height.data()[i] - truth.data()[i];
    truth_max = std::max<double>(truth_max, truth.data()[i]);
    ++count;
  }
  offset /= double(count);
  double shape_error = 0;
  for (size_t i = 0; i < height.num_pixels(); ++i) {
    if (mask.data()[i * mask.channels()] < 128) continue;
    shape_error += std::abs(height.data()[i] - truth.data()[i] - offset);
  }
  shape_error /= double(count);
  std::cout << "on the sample: mean offset " << offset << " mm, mean |shape error| " << shape_error
            << " mm, truth max " << truth_max << " mm\n";
  EXPECT_GT(truth_max, 30.0) << "the folds must be tens of mm high";
  EXPECT_LT(shape_error, 1.8) << "mean absolute height error about the mean offset, mm";
  EXPECT_LT(std::abs(offset), 0.4) << "the anchor, mm";
}

// The loop's decision on 8 px block means (a 64th of the pixels integrated)
// equals the full-size one on the draped and the flat scene, its height range
// close to the full-size range. From the ground-truth normals, and from the
// table-plane solve that the decision sees in a real run.
TEST(DepthRefinementTest, BlockMeanDecisionEqualsTheFullSizeDecision) {
  TemporaryFolder folder;
  const DepthRefinementOptions options;
  for (const double amplitude_mm : {25.0, 2.5}) {
    const fs::path session_dir = SimulateFolds(folder, "folds-" + std::to_string(amplitude_mm), amplitude_mm);
    const Session session = LoadSession(session_dir);
    PhotometricSolution truth;
    truth.normal_in_table = ReadImageFloat(session_dir / session.ground_truth->normal_file);
    truth.status = ImageU8(kWidth, kHeight, 1);  // all kSolved (0)
    const SolveSummary plane = Solve(session_dir, false);
    PhotometricSolution solved;
    solved.normal_in_table = ReadImageFloat(plane.result_dir / "normal.exr");
    const ImageU8 solved_mask = ReadImageU8(plane.result_dir / "solved_mask.png");
    solved.status = ImageU8(kWidth, kHeight, 1);
    for (size_t i = 0; i < solved.status.num_pixels(); ++i) {
      solved.status.data()[i] = static_cast<uint8_t>(solved_mask.data()[i * solved_mask.channels()] > 127
                                                         ? PixelStatus::kSolved
                                                         : PixelStatus::kOutsideRegion);
    }
    for (const auto& [name, solution] : {std::pair{"truth", &truth}, std::pair{"table-plane solve", &solved}}) {
      const double full =
          SolvedHeightRangeMm(*solution, AnchoredHeightFromSolution(options, *solution, session.rig.camera));
      int block_px = 0;
      const double block = DecisionHeightRangeMm(options, *solution, session.rig.camera, &block_px);
      std::cout << "+-" << amplitude_mm << " mm, " << name << ": height range full size " << full << " mm, "
                << block_px << " px blocks " << block << " mm\n";
      EXPECT_EQ(block_px, kDepthDecisionBlockPx);
      EXPECT_EQ(block > options.min_height_range_mm, full > options.min_height_range_mm) << name;
      EXPECT_EQ(block > options.min_height_range_mm, amplitude_mm > 10) << name;
      // Measured at this size (50 x 33 blocks): +-25 mm truth 40.88 vs 45.98 mm, solve 39.04 vs 42.44 mm;
      // +-2.5 mm 4.82 vs 5.04 / 5.03 mm. The blocks average the steep edge walls' slopes away; the
      // decision's margin to the 8 mm threshold is far larger.
      EXPECT_NEAR(block, full, 0.15 * full + 0.2) << name << ": 15 % + 0.2 mm";

      // Gathered band by band (as the solve streams its bands), any band
      // heights: the blocks of a plain per-block mean, bit for bit, and the
      // same decision as RefineDepth's on the whole first pass.
      PhotometricSolution reference;
      reference.normal_in_table = ImageF(kWidth / 8, kHeight / 8, 3);
      reference.status = ImageU8(kWidth / 8, kHeight / 8, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
      for (int by = 0; by < kHeight / 8; ++by) {
        for (int bx = 0; bx < kWidth / 8; ++bx) {
          Eigen::Vector3d sum = Eigen::Vector3d::Zero();
          int count = 0;
          for (int y = 8 * by; y < 8 * by + 8; ++y) {
            for (int x = 8 * bx; x < 8 * bx + 8; ++x) {
              if (solution->status(x, y) != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
              sum += Eigen::Vector3d(solution->normal_in_table(x, y, 0), solution->normal_in_table(x, y, 1),
                                     solution->normal_in_table(x, y, 2));
              ++count;
            }
          }
          const bool usable = count >= 32 && sum.norm() > 0;
          const Eigen::Vector3d mean = usable ? sum.normalized() : Eigen::Vector3d::UnitZ();
          for (int c = 0; c < 3; ++c) reference.normal_in_table(bx, by, c) = static_cast<float>(mean[c]);
          if (usable) reference.status(bx, by) = static_cast<uint8_t>(PixelStatus::kSolved);
        }
      }
      for (const int band_rows : {1, 7, 13, kHeight}) {
        SCOPED_TRACE(std::string(name) + ", bands of " + std::to_string(band_rows));
        DepthDecisionBlocks blocks(kWidth, kHeight);
        for (int y = 0; y < kHeight; y += band_rows) {
          PhotometricSolution band;
          const int rows = std::min(band_rows, kHeight - y);
          band.normal_in_table = ImageF(kWidth, rows, 3);
          band.status = ImageU8(kWidth, rows, 1);
          std::copy(solution->normal_in_table.row(y), solution->normal_in_table.row(y) + band.normal_in_table.size(),
                    band.normal_in_table.data());
          std::copy(solution->status.row(y), solution->status.row(y) + band.status.size(), band.status.data());
          blocks.AddRows(band, 2);
        }
        ASSERT_EQ(blocks.block_px(), kDepthDecisionBlockPx);
        const PhotometricSolution& gathered = blocks.blocks();
        ASSERT_TRUE(gathered.normal_in_table.SameSize(reference.normal_in_table));
        EXPECT_TRUE(std::equal(gathered.normal_in_table.data(),
                               gathered.normal_in_table.data() + gathered.normal_in_table.size(),
                               reference.normal_in_table.data()));
        EXPECT_TRUE(std::equal(gathered.status.data(), gathered.status.data() + gathered.status.size(),
                               reference.status.data()));
        EXPECT_EQ(DecisionHeightRangeMm(options, blocks, session.rig.camera), block);
        const std::optional<DepthRefinementSummary> kept = TablePlaneKept(options, blocks, session.rig.camera);
        EXPECT_EQ(kept.has_value(), amplitude_mm < 10);
        if (kept) {
          PhotometricSolution whole = *solution;
          const DepthResolve never = [](const LightField&, PhotometricSolution*, const ProgressCallback&,
                                        size_t*) -> PhotometricSolverSummary {
            throw std::logic_error("no re-solve when the table plane is kept");
          };
          const DepthRefinementSummary refined = RefineDepth(options, never, {}, session.rig.camera, &whole);
          EXPECT_EQ(kept->first_height_range_mm, refined.first_height_range_mm);
          EXPECT_EQ(kept->decision_block_px, refined.decision_block_px);
          EXPECT_EQ(kept->stop_reason, refined.stop_reason);
          EXPECT_FALSE(kept->refined);
          EXPECT_TRUE(kept->IsUsable());
        }
      }
    }
  }
}

// Lit samples next to a shadowed one of the same light are left out, shadowed
// ones are the solver's own (its shadow level); a pixel that would keep fewer
// lit samples than the solver needs keeps them all.
TEST(DepthRefinementTest, ShadowEdgeSamplesAreLeftOutWhereEnoughLightsRemain) {
  constexpr int kW = 40, kH = 12;
  // Light 0: shadowed left of x = 20; lights 1, 2: lit everywhere; light 3:
  // lit in rows 0-5 only, so that rows 6-11 have only lights 1 and 2 besides 0.
  std::vector<ImageF> images(4, ImageF(kW, kH, 3));
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      for (int c = 0; c < 3; ++c) {
        images[0](x, y, c) = x < 20 ? 0.0f : 0.4f;
        images[1](x, y, c) = images[2](x, y, c) = 0.3f;
        images[3](x, y, c) = y < 6 ? 0.2f : 0.0f;
      }
    }
  }
  ImageU8 clipped(kW, kH, 1);
  std::fill(clipped.data(), clipped.data() + clipped.num_pixels(), uint8_t{1});
  clipped(30, 2) = 0;  // a clipped sample stays unusable
  PhotometricSolverInput input;
  for (const ImageF& image : images) input.images.push_back(&image);
  input.sample_valid = {&clipped, nullptr, nullptr, nullptr};
  DepthRefinementOptions options;
  options.shadow_edge_radius_px = 2;
  size_t left_out = 0;
  const std::vector<ImageU8> masks = ShadowEdgeSampleMasks(options, PhotometricSolverOptions{}, input, &left_out);
  ASSERT_EQ(masks.size(), 4u);
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      // Lit within 2 px of x = 19; in rows 4-11 only lights 1 and 2 would be
      // left besides (light 3 at its own edge, or dark).
      const bool edge = x == 20 || x == 21;
      const bool expected = (x == 30 && y == 2) ? false : !(edge && y < 4);
      EXPECT_EQ(masks[0](x, y) != 0, expected) << "light 0 at " << x << "," << y;
      EXPECT_EQ(masks[1](x, y), 1) << x << "," << y;
    }
  }
  // Light 3's own edge (rows 4, 5: lit within 2 rows of row 6) is left out
  // where light 0 is lit too (x >= 22), kept where it is not.
  EXPECT_EQ(masks[3](30, 4), 0);
  EXPECT_EQ(masks[3](30, 3), 1);
  EXPECT_EQ(masks[3](10, 4), 1) << "light 0 dark there: only lights 1 and 2 would be left";
  EXPECT_EQ(masks[3](20, 5), 1) << "lights 0 and 3 both at an edge: only lights 1 and 2 would be left";
  // Light 0: 2 columns x rows 0-3; light 3: 2 rows x columns 22-39.
  EXPECT_EQ(left_out, size_t(2 * 4 + 2 * (kW - 22)));
  options.shadow_edge_radius_px = 0;
  size_t none = 0;
  const std::vector<ImageU8> kept = ShadowEdgeSampleMasks(options, PhotometricSolverOptions{}, input, &none);
  EXPECT_EQ(none, 0u);
  EXPECT_EQ(kept[0](20, 2), 1);
  EXPECT_EQ(kept[0](30, 2), 0);
}

// The target: on folds of +-25 mm the default solve (with the loop)
// is at most 1.3x the default solve's error on the default +-2.5 mm sample.
// Mean angular error of a solve over the sample's interior: the pixels more
// than the edge blend inside the sample outline, where the +-25 mm folds do not
// fall to the table in a near-vertical wall.
double InteriorMeanErrorDeg(const fs::path& session_dir, const SolveSummary& solved) {
  const Session session = LoadSession(session_dir);
  const ImageF error = ReadImageFloat(solved.result_dir / "angular_error_deg.exr");
  const ImageF table = ComputeTablePoints(session.rig.camera);
  const TextileSceneOptions scene;
  double sum = 0;
  size_t count = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const bool interior = std::abs(table(x, y, 0)) < 0.5 * scene.sample_width_mm - scene.edge_blend_mm &&
                            std::abs(table(x, y, 1)) < 0.5 * scene.sample_height_mm - scene.edge_blend_mm;
      if (!interior) continue;
      sum += error(x, y);
      ++count;
    }
  }
  return sum / double(count);
}

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
  std::cout << "mean error (deg): flat " << flat_error << " (" << flat_default.depth.BriefReport()
            << "); draped on the table plane " << plane_error << "; draped with the loop " << depth_error << " ("
            << draped_default.depth.BriefReport() << ")\n";

  const double flat_interior = InteriorMeanErrorDeg(flat, flat_default);
  const double plane_interior = InteriorMeanErrorDeg(draped, draped_plane);
  const double depth_interior = InteriorMeanErrorDeg(draped, draped_default);
  std::cout << "interior mean error (deg): flat " << flat_interior << "; draped on the table plane "
            << plane_interior << "; draped with the loop " << depth_interior << "\n";
  // Measured with the Bayer blend (the default since issue #13's second
  // step): flat 0.633, table plane 1.601, with the loop 0.558 (0.88x; without
  // the blend 1.819, 2.423, 1.164: 0.64x, the blend gains more on the flat
  // sample at this small size). Since the shared lobe's pixels take their
  // raw re-solve (session 2026-12-03 #3): flat 0.449, table plane 1.492,
  // with the loop 0.559 (1.24x: the flat sample gains, the draped one with
  // the loop stays where it was), so the loop's result is held to its own
  // figure and the ratio to the 1.3x.
  EXPECT_LE(depth_interior, 1.3 * flat_interior);
  EXPECT_LE(depth_interior, 0.58);
  EXPECT_LT(depth_interior, plane_interior);

  EXPECT_FALSE(draped_plane.depth.refined);
  ASSERT_TRUE(draped_default.depth.refined);
  EXPECT_GT(draped_default.depth.first_height_range_mm, 30.0);
  // Measured: flat 0.602, table plane 1.505, with the loop 0.580 (0.96x the
  // flat sample's error: the issue asks for at most 1.3x; without the blend
  // 1.722, 2.564, 1.430: 0.83x). With the raw re-solve of the shared lobe's
  // pixels: flat 0.454, table plane 1.413, with the loop 0.580 (1.28x).
  EXPECT_LE(depth_error, 1.3 * flat_error);
  EXPECT_LE(depth_error, 0.60);
  EXPECT_GT(plane_error, 1.3 * flat_error) << "without the loop the folds must cost accuracy";
  EXPECT_GT(draped_default.depth.shadow_edge_samples, 10000u);
  // The surface moved by centimetres first, then less.
  const std::vector<DepthIteration>& iterations = draped_default.depth.iterations;
  EXPECT_GT(iterations.front().max_move_mm, 20.0);
  if (iterations.size() > 1) {
    EXPECT_LT(iterations.back().max_move_mm, iterations.front().max_move_mm);
  }

  // The report line and report.json say what ran.
  EXPECT_THAT(draped_default.FullReport(), HasSubstr("Depth refinement: success, " +
                                                      std::to_string(iterations.size()) + " iteration(s)"));
  std::ifstream in(draped_default.result_dir / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report.at("depth_refinement").at("iterations").size(), iterations.size());
  EXPECT_EQ(report.at("depth_refinement").at("stop_reason"), draped_default.depth.stop_reason);

  // The shadow edges' share: the same loop keeping the lit samples at the
  // folds' cast shadows. Measured 0.710 against 0.580 with them left out
  // (without the blend 2.218 against 1.430).
  SolveOptions keep_edges;
  keep_edges.depth.shadow_edge_radius_px = 0;
  keep_edges.run_label = "keep-edges";
  SolveController keep(draped, keep_edges);
  keep.Run();
  std::cout << "draped with the loop, shadow edges kept: " << keep.summary().normal_error_deg->mean << "\n";
  EXPECT_EQ(keep.summary().depth.shadow_edge_samples, 0u);
  EXPECT_LT(depth_error, 0.9 * keep.summary().normal_error_deg->mean);
}

}  // namespace
}  // namespace scanbench
