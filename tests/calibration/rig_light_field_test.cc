#include "calibration/rig_light_field.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/camera_model.h"

#include "tests/calibration/test_rig.h"
#include "tests/util/eigen_matchers.h"

namespace scanbench {
namespace {

TEST(RigLightFieldTest, PixelsSeeTheirLedFromTheirTablePoint) {
  RigDescription rig;
  rig.camera = testing::DownLookingCamera(40, 30, 600, /*distorted=*/true);
  LedDescription led;
  led.position_in_table_mm = {300, 0, 400};
  led.axis_in_table = -led.position_in_table_mm.normalized();
  led.mu = 2;
  led.rgb_intensity = {0.4, 0.5, 0.6};
  rig.leds = {led};
  const auto field = MakeRigLightField(rig);
  ASSERT_EQ(field->num_lights(), 1);
  ASSERT_EQ(field->width(), 40);

  const ImageF points = ComputeTablePoints(rig.camera);
  for (auto [x, y] : {std::pair{0, 0}, std::pair{39, 29}, std::pair{20, 15}}) {
    float dir[3], intensity[3];
    field->Evaluate(x, y, dir, intensity);
    const Eigen::Vector3d point(points(x, y, 0), points(x, y, 1), points(x, y, 2));
    const Eigen::Vector3d to_led = led.position_in_table_mm - point;
    EXPECT_THAT(Eigen::Vector3f(dir[0], dir[1], dir[2]), testing::EigenNear(to_led.normalized().cast<float>(), 1e-6));
    const double cos_off_axis = (-to_led.normalized()).dot(led.axis_in_table);
    const double expected = 0.5 * std::pow(cos_off_axis, 2) * std::pow(1000.0 / to_led.norm(), 2);
    EXPECT_NEAR(intensity[1], expected, 1e-6 * expected);
  }
}

TEST(RigLightFieldTest, LedBelowTheTableIsRejected) {
  RigDescription rig;
  rig.camera = testing::DownLookingCamera(8, 8, 600, false);
  LedDescription led;
  led.id = 7;
  led.position_in_table_mm = {0, 100, -5};
  rig.leds = {led};
  EXPECT_THAT([&] { MakeRigLightField(rig); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("rig.leds[0] (id 7)")));
}

}  // namespace
}  // namespace scanbench
