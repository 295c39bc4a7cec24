#include "solver/light_subset.h"
#include "solver/synthetic_scene.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

constexpr double kPi = 3.14159265358979323846;

double ElevationDeg(const Eigen::Vector3d& d) { return std::asin(d.z() / d.norm()) * 180.0 / kPi; }

TEST(RingLightDirectionsTest, TurnedTwoInterleavedRingsLikeTheRig) {
  const std::vector<Eigen::Vector3d> dirs = RingLightDirections(10, 30, 60, 12.0);
  ASSERT_EQ(dirs.size(), 10u);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(ElevationDeg(dirs[i]), 30.0, 1e-9);
  for (int i = 5; i < 10; ++i) EXPECT_NEAR(ElevationDeg(dirs[i]), 60.0, 1e-9);
  // Turned by 12 deg; the upper ring sits half a step (36 deg) between the lower ring's LEDs.
  EXPECT_NEAR(std::atan2(dirs[0].y(), dirs[0].x()) * 180.0 / kPi, 12.0, 1e-9);
  EXPECT_NEAR(std::atan2(dirs[5].y(), dirs[5].x()) * 180.0 / kPi, 48.0, 1e-9);
  for (const Eigen::Vector3d& d : dirs) EXPECT_NEAR(d.norm(), 1.0, 1e-12);
}

TEST(SelectRingLightsTest, FindsATurnedLayoutHiddenAmongOtherLights) {
  // The layout turned by 17 deg, shuffled into 200 random upper-hemisphere lights.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Eigen::Vector3d> dirs;
  while (dirs.size() < 200) {
    Eigen::Vector3d d(uniform(rng), uniform(rng), std::abs(uniform(rng)));
    if (d.norm() > 0.2 && d.norm() < 1 && ElevationDeg(d) > 5) dirs.push_back(2.5 * d.normalized());
  }
  const std::vector<Eigen::Vector3d> layout = RingLightDirections(10, 30, 60, 17.0);
  std::vector<int> planted;
  for (size_t k = 0; k < layout.size(); ++k) {
    const int at = static_cast<int>(13 * k + 5);
    dirs.insert(dirs.begin() + at, layout[k]);
  }
  for (size_t i = 0; i < dirs.size(); ++i) {
    for (const Eigen::Vector3d& l : layout) {
      if ((dirs[i] - l).norm() < 1e-12) planted.push_back(static_cast<int>(i));
    }
  }
  ASSERT_EQ(planted.size(), 10u);
  EXPECT_EQ(SelectRingLights(dirs, 10), planted);
}

TEST(SelectRingLightsTest, AllLightsWhenCountIsTheirNumberAndBadInputThrows) {
  const std::vector<Eigen::Vector3d> dirs = RingLightDirections(6, 20, 70, 5.0);
  const std::vector<int> all = SelectRingLights(dirs, 6);
  EXPECT_EQ(all, (std::vector<int>{0, 1, 2, 3, 4, 5}));
  EXPECT_THROW(SelectRingLights(dirs, 7), std::invalid_argument);
  EXPECT_THROW(SelectRingLights(dirs, 2), std::invalid_argument);
  std::vector<Eigen::Vector3d> bad = dirs;
  bad[2] = Eigen::Vector3d::Zero();
  EXPECT_THROW(SelectRingLights(bad, 4), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
