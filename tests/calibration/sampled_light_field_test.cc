#include "calibration/sampled_light_field.h"

#include <array>
#include <cmath>
#include <numbers>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/camera_model.h"
#include "calibration/rig_light_field.h"
#include "tests/calibration/test_rig.h"

namespace scanbench {
namespace {

// Two near-field LEDs over a distorted camera: a field with curvature in
// both direction and intensity.
RigDescription NearFieldRig(int width, int height) {
  RigDescription rig;
  rig.camera = testing::DownLookingCamera(width, height, 600, /*distorted=*/true);
  // The bench's field of view: about 143 mm across at 600 mm.
  rig.camera.intrinsics.fx = rig.camera.intrinsics.fy = 4.2 * width;
  for (const Eigen::Vector3d& position : {Eigen::Vector3d(430, 20, 250), Eigen::Vector3d(-120, 200, 430)}) {
    LedDescription led;
    led.id = static_cast<int>(rig.leds.size());
    led.position_in_table_mm = position;
    led.axis_in_table = -position.normalized();
    led.mu = 2.2;
    led.rgb_intensity = {0.3, 0.6, 0.45};
    rig.leds.push_back(led);
  }
  return rig;
}

// atan2 of cross and dot: acos of a float dot product near 1 is too coarse.
double AngleDeg(const float* a, const float* b) {
  const Eigen::Vector3d u(a[0], a[1], a[2]), v(b[0], b[1], b[2]);
  return std::atan2(u.cross(v).norm(), u.dot(v)) * 180.0 / std::numbers::pi;
}

TEST(SampledLightFieldTest, InterpolatesANearFieldRigWithinTolerance) {
  // 13 px is no divisor of the size: the last nodes lie beyond the image.
  const int width = 400, height = 260, step = 13;
  const auto exact = MakeRigLightField(NearFieldRig(width, height));
  const SampledLightField sampled = SampledLightField::Sample(*exact, step);
  EXPECT_EQ(sampled.width(), width);
  EXPECT_EQ(sampled.height(), height);
  EXPECT_EQ(sampled.num_lights(), 2);
  EXPECT_EQ(sampled.grid().nodes_x, 32);  // nodes at 0, 13, ..., 403 >= 399
  EXPECT_EQ(sampled.grid().nodes_y, 21);  // 0 .. 260 >= 259
  double worst_angle = 0, worst_relative = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      float d0[6], e0[6], d1[6], e1[6];
      exact->Evaluate(x, y, d0, e0);
      sampled.Evaluate(x, y, d1, e1);
      for (int k = 0; k < 2; ++k) {
        worst_angle = std::max(worst_angle, AngleDeg(d0 + 3 * k, d1 + 3 * k));
        for (int c = 0; c < 3; ++c) {
          worst_relative = std::max(worst_relative, std::abs(e1[3 * k + c] / e0[3 * k + c] - 1.0));
        }
      }
    }
  }
  // A 13 px cell is 4.6 mm on the table (the bench's 16 px at 1232 px wide is
  // 1.9 mm), 0.6 deg seen from the nearer LED: bilinear interpolation of these
  // smooth fields, extrapolation at the border included, stays below noise.
  EXPECT_LT(worst_angle, 2e-3);
  EXPECT_LT(worst_relative, 2e-4);
}

TEST(SampledLightFieldTest, MemoryIsBoundedAtSixteenMegapixels) {
  const LightFieldGrid grid = LightFieldGrid::Covering(4928, 3264, 16);
  EXPECT_EQ(grid.nodes_x, 309);
  EXPECT_EQ(grid.nodes_y, 205);
  const size_t values = grid.num_nodes() * 10 * 3;
  std::vector<float> dirs(values), intensities(values, 0.5f);
  for (size_t v = 2; v < values; v += 3) dirs[v] = 1;
  const SampledLightField field(grid, 10, std::move(dirs), std::move(intensities));
  EXPECT_LT(field.MemoryBytes(), 16u << 20);  // 15.2 MB for 10 lights
  float d[30], e[30];
  field.Evaluate(4927, 3263, d, e);
  EXPECT_FLOAT_EQ(d[2], 1.0f);
  EXPECT_FLOAT_EQ(e[29], 0.5f);
}

// View directions per node (here from the rig's camera centre over the table):
// interpolated like the lights, orthographic when none are set.
TEST(SampledLightFieldTest, ViewDirectionsInterpolateTheNodes) {
  const int width = 320, height = 240;
  const RigDescription rig = NearFieldRig(width, height);
  const std::unique_ptr<PointLightField> exact = MakeRigLightField(rig);
  SampledLightField field = SampledLightField::Sample(*exact, 16);
  float view[3], expected[3];
  field.ViewDirection(100, 50, view);
  EXPECT_EQ(view[2], 1.0f);
  const LightFieldGrid& grid = field.grid();
  std::vector<float> dirs;
  for (int j = 0; j < grid.nodes_y; ++j) {
    for (int i = 0; i < grid.nodes_x; ++i) {
      // Nodes beyond the image: the border pixel's direction is close enough here.
      exact->ViewDirection(std::min(width - 1, int(grid.NodeX(i))), std::min(height - 1, int(grid.NodeY(j))), expected);
      dirs.insert(dirs.end(), expected, expected + 3);
    }
  }
  field.SetViewDirections(dirs);
  for (const auto& [x, y] : {std::pair{0, 0}, std::pair{100, 50}, std::pair{200, 170}}) {
    field.ViewDirection(x, y, view);
    exact->ViewDirection(x, y, expected);
    EXPECT_LT(AngleDeg(view, expected), 0.01) << x << ", " << y;
  }
  EXPECT_GT(AngleDeg(view, std::array<float, 3>{0, 0, 1}.data()), 1.0) << "perspective, not orthographic";
  EXPECT_THROW(field.SetViewDirections({1, 0, 0}), std::invalid_argument);
  dirs[4] = NAN;
  EXPECT_THROW(field.SetViewDirections(dirs), std::invalid_argument);
}

TEST(SampledLightFieldTest, RejectsBadInputNamingTheProblem) {
  LightFieldGrid grid = LightFieldGrid::Covering(10, 10, 9);
  EXPECT_THAT([&] { SampledLightField(grid, 1, std::vector<float>(5), std::vector<float>(5)); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("required for each")));
  std::vector<float> dirs(grid.num_nodes() * 3, 0.0f), intensities(grid.num_nodes() * 3, 1.0f);
  EXPECT_THAT([&] { SampledLightField(grid, 1, dirs, intensities); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("direction must be finite")));
  for (size_t v = 2; v < dirs.size(); v += 3) dirs[v] = 1;
  intensities[4] = -1;
  EXPECT_THAT([&] { SampledLightField(grid, 1, dirs, intensities); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("rgb_intensity[1]")));
  grid.nodes_x = 1;
  EXPECT_THAT([&] { grid.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("LightFieldGrid.nodes_x = 1")));
}

}  // namespace
}  // namespace scanbench
