#include "solver/light_field.h"

#include <cmath>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/util/eigen_matchers.h"

namespace scanbench {
namespace {

TEST(PointLightFieldTest, InverseSquareAndAngularFalloff) {
  ImageF points(2, 1, 3, 0.0f);
  points(1, 0, 0) = 300;  // 300 mm to the side of the LED's foot point
  PointLight light;
  light.position = {0, 0, 400};
  light.axis = {0, 0, -1};
  light.mu = 2;
  light.rgb_intensity = {0.5, 1.0, 0.25};
  light.reference_distance = 1000;
  const PointLightField field({light}, points);

  float dirs[3], intensities[3];
  field.Evaluate(0, 0, dirs, intensities);
  EXPECT_THAT(Eigen::Vector3f(dirs[0], dirs[1], dirs[2]), testing::EigenNear(Eigen::Vector3f(0, 0, 1), 1e-7));
  EXPECT_NEAR(intensities[1], 1.0 * (1000.0 / 400) * (1000.0 / 400), 1e-4);

  field.Evaluate(1, 0, dirs, intensities);
  // Distance 500 mm, cos(angle off axis) = 400 / 500.
  EXPECT_THAT(Eigen::Vector3f(dirs[0], dirs[1], dirs[2]), testing::EigenNear(Eigen::Vector3f(-0.6f, 0, 0.8f), 1e-6));
  const double expected = 0.8 * 0.8 * (1000.0 / 500) * (1000.0 / 500);
  EXPECT_NEAR(intensities[0], 0.5 * expected, 1e-5);
  EXPECT_NEAR(intensities[2], 0.25 * expected, 1e-5);
}

TEST(PointLightFieldTest, ViewDirectionPointsAtTheCameraCentreOrIsOrthographic) {
  ImageF points(2, 1, 3, 0.0f);
  points(1, 0, 0) = 300;
  const PointLightField orthographic({PointLight()}, points);
  float view[3];
  orthographic.ViewDirection(1, 0, view);
  EXPECT_THAT(Eigen::Vector3f(view[0], view[1], view[2]), testing::EigenNear(Eigen::Vector3f(0, 0, 1), 0));
  const PointLightField perspective({PointLight()}, points, Eigen::Vector3d(0, 0, 400));
  perspective.ViewDirection(0, 0, view);
  EXPECT_THAT(Eigen::Vector3f(view[0], view[1], view[2]), testing::EigenNear(Eigen::Vector3f(0, 0, 1), 1e-7));
  perspective.ViewDirection(1, 0, view);  // 300 mm to the side, 400 mm below: (-0.6, 0, 0.8)
  EXPECT_THAT(Eigen::Vector3f(view[0], view[1], view[2]), testing::EigenNear(Eigen::Vector3f(-0.6f, 0, 0.8f), 1e-6));
  EXPECT_THROW(PointLightField({PointLight()}, points, Eigen::Vector3d(NAN, 0, 1)), std::invalid_argument);
}

TEST(PointLightFieldTest, RejectsInvalidLights) {
  PointLight light;
  light.mu = -1;
  EXPECT_THAT([&] { PointLightField({light}, ImageF(1, 1, 3)); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("light 0: mu = -1")));
  light = PointLight();
  light.axis = Eigen::Vector3d::Zero();
  EXPECT_THROW(PointLightField({light}, ImageF(1, 1, 3)), std::invalid_argument);
  EXPECT_THROW(PointLightField({PointLight()}, ImageF(1, 1, 1)), std::invalid_argument);
}

TEST(DirectionalLightFieldTest, NormalisesAndRepeats) {
  const DirectionalLightField field(4, 3, {{0, 0, 2}, {3, 0, 4}}, {{1, 1, 1}, {0.5, 0.6, 0.7}});
  float dirs[6], intensities[6];
  field.Evaluate(3, 2, dirs, intensities);
  EXPECT_FLOAT_EQ(dirs[2], 1.0f);
  EXPECT_FLOAT_EQ(dirs[3], 0.6f);
  EXPECT_FLOAT_EQ(dirs[5], 0.8f);
  EXPECT_FLOAT_EQ(intensities[4], 0.6f);
  EXPECT_THROW(DirectionalLightField(4, 3, {{0, 0, 0}}, {{1, 1, 1}}), std::invalid_argument);
  EXPECT_THROW(DirectionalLightField(4, 3, {{0, 0, 1}}, {}), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
