#include "app/sim/bench_template.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/rig_json.h"
#include "calibration/camera_model.h"

namespace scanbench {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180;

double ElevationDeg(const Eigen::Vector3d& p) { return std::atan2(p.z(), p.head<2>().norm()) / kDeg; }
double AzimuthDeg(const Eigen::Vector3d& p) {
  const double a = std::atan2(p.y(), p.x()) / kDeg;
  return a < -1e-9 ? a + 360 : a;
}

// The seed's bench: 10 LEDs evenly over a hemisphere (5 at 30 deg, 5 at 60 deg
// elevation, 500 mm out, azimuths interleaved), aimed at the centre, camera
// 600 mm above it.
TEST(BenchTemplateTest, DefaultsAreTheSeedsBench) {
  const RigDescription rig = MakeBenchTemplate(BenchTemplateOptions());
  ASSERT_EQ(rig.leds.size(), 10u);
  for (int k = 0; k < 10; ++k) {
    const LedDescription& led = rig.leds[k];
    EXPECT_EQ(led.id, k);
    EXPECT_NEAR(led.position_in_table_mm.norm(), 500, 0.1) << k;
    EXPECT_NEAR(ElevationDeg(led.position_in_table_mm), k % 2 == 0 ? 30 : 60, 0.01) << k;
    EXPECT_NEAR(AzimuthDeg(led.position_in_table_mm), 36.0 * k, 1e-9) << k;
    EXPECT_NEAR((led.axis_in_table + led.position_in_table_mm.normalized()).norm(), 0, 1e-12) << "aimed at the centre";
  }
  // The table centre projects to the principal point, the table is 600 mm away.
  const Eigen::Vector3d centre_in_cam = rig.camera.cam_from_table * Eigen::Vector3d::Zero();
  EXPECT_NEAR(centre_in_cam.z(), 600, 1e-9);
  EXPECT_NEAR(centre_in_cam.head<2>().norm(), 0, 1e-9);
  // Image x is table +x, image up (-y) is table +y.
  const Eigen::Vector3d x_in_cam = rig.camera.cam_from_table.linear() * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d y_in_cam = rig.camera.cam_from_table.linear() * Eigen::Vector3d::UnitY();
  EXPECT_NEAR(x_in_cam.x(), 1, 1e-12);
  EXPECT_NEAR(y_in_cam.y(), -1, 1e-12);
  // D5100 + 85 mm at 600 mm: about 143 x 95 mm of table in view.
  const double width_mm = rig.camera.intrinsics.width / rig.camera.intrinsics.fx * 600;
  EXPECT_NEAR(width_mm, 143, 1);
  EXPECT_NO_THROW(CheckRigDescription(rig, "template"));
  EXPECT_NO_THROW(RigDescriptionFromJson(RigDescriptionToJson(rig), "template.json"));
}

TEST(BenchTemplateTest, RingsAndCountsFollowTheOptions) {
  BenchTemplateOptions options;
  options.num_leds = 7;
  options.ring_radii_mm = {400, 300, 100};
  options.ring_heights_mm = {100, 300, 450};
  const RigDescription rig = MakeBenchTemplate(options);
  ASSERT_EQ(rig.leds.size(), 7u);
  EXPECT_NEAR(rig.leds[0].position_in_table_mm.z(), 100, 1e-9);
  EXPECT_NEAR(rig.leds[1].position_in_table_mm.z(), 300, 1e-9);
  EXPECT_NEAR(rig.leds[2].position_in_table_mm.z(), 450, 1e-9);
  EXPECT_NEAR(rig.leds[3].position_in_table_mm.head<2>().norm(), 400, 1e-9);
  // Ring 0 holds LEDs 0, 3, 6: 120 deg apart.
  EXPECT_NEAR(AzimuthDeg(rig.leds[3].position_in_table_mm), 120, 1e-9);
  EXPECT_NEAR(AzimuthDeg(rig.leds[6].position_in_table_mm), 240, 1e-9);
}

TEST(BenchTemplateTest, OptionsAreChecked) {
  BenchTemplateOptions options;
  options.num_leds = 11;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = BenchTemplateOptions();
  options.ring_heights_mm = {250};
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = BenchTemplateOptions();
  options.camera = "d850";
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = BenchTemplateOptions();
  options.camera_height_mm = 50;  // inside the focal length
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = BenchTemplateOptions();
  options.ring_radii_mm = {-1, 250};
  EXPECT_THROW(MakeBenchTemplate(options), std::invalid_argument);
}

TEST(BenchTemplateTest, FieldsToMeasureNameEveryPart) {
  const std::vector<std::string> fields = BenchFieldsToMeasure(MakeBenchTemplate(BenchTemplateOptions()));
  using ::testing::Contains;
  using ::testing::StartsWith;
  EXPECT_THAT(fields, Contains(StartsWith("camera.intrinsics")));
  EXPECT_THAT(fields, Contains(StartsWith("camera.cam_from_table")));
  EXPECT_THAT(fields, Contains(StartsWith("leds[0..9].position_in_table_mm")));
  EXPECT_THAT(fields, Contains(StartsWith("leds[0..9].mu, .rgb_intensity")));
}

}  // namespace
}  // namespace scanbench
