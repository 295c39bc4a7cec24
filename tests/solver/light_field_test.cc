#include "solver/light_field.h"

#include <cmath>
#include <vector>

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

// The span form is the per-pixel model in planar layout, within 1e-6
// relative (cos^mu there is exp(mu log cos)), including mu = 0 and points
// behind an LED (cos clamped to 0).
TEST(PointLightFieldTest, EvaluateSpanMatchesEvaluate) {
  const int width = 37, height = 3;
  ImageF points(width, height, 3, 0.0f);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      points(x, y, 0) = -90.0f + 5.0f * x;
      points(x, y, 1) = -40.0f + 30.0f * y;
      points(x, y, 2) = 0.5f * std::sin(0.3f * x);
    }
  }
  std::vector<PointLight> lights(4);
  const double mus[] = {0.0, 1.0, 1.6, 7.3};
  for (int k = 0; k < 4; ++k) {
    lights[k].position = {60.0 * (k - 1.5), 20.0 * k, 120 + 10.0 * k};
    lights[k].axis = {0.2 * k, -0.1, -1};
    lights[k].mu = mus[k];
    lights[k].rgb_intensity = {0.4 + 0.1 * k, 1.0, 0.3};
    lights[k].reference_distance = 200;
  }
  lights[3].axis = {1, 0, 0};  // half the points behind this LED
  const PointLightField field(lights, points);
  const int x0 = 3, count = width - 5, stride = count + 7, y = 1;
  std::vector<float> dirs(12 * stride, -1.0f), intensities(12 * stride, -1.0f);
  field.EvaluateSpan(x0, y, count, stride, dirs.data(), intensities.data());
  float pixel_dirs[12], pixel_intensities[12];
  int zero_intensities = 0;
  for (int i = 0; i < count; ++i) {
    field.Evaluate(x0 + i, y, pixel_dirs, pixel_intensities);
    for (int j = 0; j < 12; ++j) {
      const float dir = dirs[j * stride + i], intensity = intensities[j * stride + i];
      EXPECT_NEAR(dir, pixel_dirs[j], 1e-6 * std::abs(pixel_dirs[j]) + 1e-7) << "pixel " << i << " value " << j;
      EXPECT_NEAR(intensity, pixel_intensities[j], 1e-6 * std::abs(pixel_intensities[j]))
          << "pixel " << i << " value " << j;
      zero_intensities += pixel_intensities[j] == 0;
    }
  }
  EXPECT_GT(zero_intensities, 0);  // the clamped case was exercised
}

// The span form's inline ln and exp over the whole range of the falloff:
// cos from 1 down to 1e-6 off the axis, exponents from 0.05 to 80 (where
// cos^mu leaves float's range), against std::pow.
TEST(PointLightFieldTest, EvaluateSpanFalloffOverTheWholeRange) {
  const int count = 400;
  ImageF points(count, 1, 3, 0.0f);
  for (int i = 0; i < count; ++i) {
    // Points on a circle of radius 100 round the LED, from straight below it
    // to nearly level with it: cos off the downward axis from 1 to 1e-6.
    const double cosine = std::pow(1e-6, double(i) / (count - 1));
    const double angle = std::acos(cosine);
    points(i, 0, 0) = static_cast<float>(100 * std::sin(angle));
    points(i, 0, 2) = static_cast<float>(-100 * cosine);
  }
  std::vector<PointLight> lights;
  for (double mu : {0.05, 0.5, 1.0, 2.7, 13.0, 80.0}) {
    PointLight light;
    light.position = {0, 0, 0};
    light.axis = {0, 0, -1};
    light.mu = mu;
    light.reference_distance = 100;
    lights.push_back(light);
  }
  const PointLightField field(lights, points);
  const int values = 3 * static_cast<int>(lights.size());
  std::vector<float> dirs(values * count), intensities(values * count);
  field.EvaluateSpan(0, 0, count, count, dirs.data(), intensities.data());
  for (size_t k = 0; k < lights.size(); ++k) {
    for (int i = 0; i < count; ++i) {
      // The cosine of the point as stored (float), as the field sees it.
      const Eigen::Vector3d point(points(i, 0, 0), points(i, 0, 1), points(i, 0, 2));
      const double cosine = -point.normalized().z();
      const double expected = std::pow(cosine, lights[k].mu) * 1e4 / point.squaredNorm();
      const float got = intensities[(3 * k + 1) * count + i];
      EXPECT_NEAR(got, expected, 1e-6 * expected + 1e-38) << "mu " << lights[k].mu << " cos " << cosine;
    }
  }
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
