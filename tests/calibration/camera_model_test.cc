#include "calibration/camera_model.h"

#include <algorithm>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/calibration/test_rig.h"
#include "tests/util/eigen_matchers.h"

namespace scanbench {
namespace {

TEST(CameraModelTest, RaysReprojectToTheirPixelsThroughDistortion) {
  const CameraGeometry camera = testing::DownLookingCamera(64, 48, 600, /*distorted=*/true);
  const ImageF rays = ComputeRayDirectionsInCam(camera.intrinsics);
  double worst = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      const Eigen::Vector3d ray(rays(x, y, 0), rays(x, y, 1), rays(x, y, 2));
      ASSERT_NEAR(ray.norm(), 1.0, 1e-6);
      worst = std::max(worst, (ProjectToPixel(camera.intrinsics, ray) - Eigen::Vector2d(x, y)).norm());
    }
  }
  // Float storage of the ray limits the round trip, not the undistortion.
  EXPECT_LT(worst, 1e-3);
}

TEST(CameraModelTest, RaysAreTheSameOnAnyNumberOfThreads) {
  // 300 rows: more chunks of rows than threads, so the rows really are shared.
  const CameraGeometry camera = testing::DownLookingCamera(64, 300, 600, /*distorted=*/true);
  const ImageF one = ComputeRayDirectionsInCam(camera.intrinsics, 1);
  for (const int threads : {2, 3}) {
    const ImageF many = ComputeRayDirectionsInCam(camera.intrinsics, threads);
    ASSERT_EQ(many.size(), one.size());
    EXPECT_TRUE(std::equal(one.data(), one.data() + one.size(), many.data())) << threads << " threads";
  }
  // Every row written (an unwritten row would hold the image's fill, not a unit ray).
  for (int y = 0; y < 300; ++y) ASSERT_NEAR(one(63, y, 2) * one(63, y, 2) + one(63, y, 0) * one(63, y, 0) +
                                                one(63, y, 1) * one(63, y, 1), 1.0, 1e-6) << "row " << y;
}

TEST(CameraModelTest, TablePointsOfADownLookingCamera) {
  const CameraGeometry camera = testing::DownLookingCamera(64, 48, 600, /*distorted=*/false);
  EXPECT_THAT(CameraCentreInTable(camera), testing::EigenNear(Eigen::Vector3d(0, 0, 600), 1e-12));
  const ImageF points = ComputeTablePoints(camera);
  // The principal point sees the foot of the camera; image right is table +x,
  // image up is table +y.
  const double fx = camera.intrinsics.fx;
  const int x = 10, y = 5;
  const Eigen::Vector3f expected((x - camera.intrinsics.cx) / fx * 600, -(y - camera.intrinsics.cy) / fx * 600, 0);
  EXPECT_THAT(Eigen::Vector3f(points(x, y, 0), points(x, y, 1), points(x, y, 2)),
              testing::EigenNear(expected, 1e-3));
}

// A block camera's pixel sees along the full camera's ray through the block's
// centre, lens distortion included.
TEST(CameraModelTest, BlockCameraPixelsAreTheBlockCentresRays) {
  const CameraGeometry camera = testing::DownLookingCamera(67, 50, 600, /*distorted=*/true);
  const CameraGeometry blocks = BlockCamera(camera, 8);
  EXPECT_EQ(blocks.intrinsics.width, 8);  // whole blocks only
  EXPECT_EQ(blocks.intrinsics.height, 6);
  const ImageF block_rays = ComputeRayDirectionsInCam(blocks.intrinsics);
  std::vector<Eigen::Vector2d> centres;
  for (int by = 0; by < 6; ++by) {
    for (int bx = 0; bx < 8; ++bx) centres.emplace_back(8 * bx + 3.5, 8 * by + 3.5);
  }
  const std::vector<Eigen::Vector3d> full_rays = ComputeRayDirectionsInCam(camera.intrinsics, centres);
  for (int by = 0; by < 6; ++by) {
    for (int bx = 0; bx < 8; ++bx) {
      const Eigen::Vector3d ray(block_rays(bx, by, 0), block_rays(bx, by, 1), block_rays(bx, by, 2));
      EXPECT_THAT(ray, testing::EigenNear(full_rays[by * 8 + bx], 1e-6)) << "block " << bx << "," << by;
    }
  }
  EXPECT_THROW(BlockCamera(camera, 0), std::invalid_argument);
  EXPECT_THROW(BlockCamera(camera, 51), std::invalid_argument);
}

TEST(CameraModelTest, InvalidIntrinsicsNameTheField) {
  CameraIntrinsics intrinsics = testing::DownLookingCamera(64, 48, 600, false).intrinsics;
  intrinsics.fx = -1;
  EXPECT_THAT([&] { CheckCameraIntrinsics(intrinsics); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("fx = -1")));
  intrinsics = testing::DownLookingCamera(64, 48, 600, false).intrinsics;
  intrinsics.cx = 100;
  EXPECT_THAT([&] { CheckCameraIntrinsics(intrinsics); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("cx = 100")));
}

TEST(CameraModelTest, CameraBelowTheTableIsRejected) {
  const CameraGeometry camera = testing::DownLookingCamera(16, 16, -10, false);
  EXPECT_THAT([&] { ComputeTablePoints(camera); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("above the table")));
}

TEST(CameraModelTest, SubPixelRaysMeetAnyHorizontalPlaneWhereTheyProjectBack) {
  const CameraGeometry camera = testing::DownLookingCamera(64, 48, 600, /*distorted=*/true);
  const std::vector<Eigen::Vector2d> pixels = {{0, 0}, {31.5, 23.25}, {63, 47}, {10.75, 40.5}};
  for (const double height : {0.0, 40.0}) {
    const std::vector<Eigen::Vector3d> points = ComputePlanePointsInTable(camera, pixels, height);
    ASSERT_EQ(points.size(), pixels.size());
    for (size_t i = 0; i < pixels.size(); ++i) {
      EXPECT_NEAR(points[i].z(), height, 1e-9);
      const Eigen::Vector2d back = ProjectToPixel(camera.intrinsics, camera.cam_from_table * points[i]);
      EXPECT_LT((back - pixels[i]).norm(), 1e-6) << i;
    }
  }
  // The same rays as the per-pixel-centre map.
  const ImageF rays = ComputeRayDirectionsInCam(camera.intrinsics);
  const Eigen::Vector3d ray = ComputeRayDirectionsInCam(camera.intrinsics, {Eigen::Vector2d(63, 47)})[0];
  EXPECT_THAT(Eigen::Vector3f(rays(63, 47, 0), rays(63, 47, 1), rays(63, 47, 2)),
              testing::EigenNear(ray.cast<float>(), 1e-6));
  EXPECT_THAT([&] { ComputePlanePointsInTable(camera, pixels, 700.0); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("does not reach the plane z = 700")));
}

}  // namespace
}  // namespace scanbench
