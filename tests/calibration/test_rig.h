// A small camera looking straight down at the table, for calibration tests.
#pragma once

#include <Eigen/Geometry>

#include "calibration/rig.h"

namespace scanbench::testing {

inline CameraGeometry DownLookingCamera(int width, int height, double height_mm, bool distorted) {
  CameraGeometry camera;
  camera.intrinsics.width = width;
  camera.intrinsics.height = height;
  camera.intrinsics.fx = camera.intrinsics.fy = 1.2 * width;
  camera.intrinsics.cx = 0.5 * (width - 1) + 1.5;
  camera.intrinsics.cy = 0.5 * (height - 1) - 2.0;
  if (distorted) {
    camera.intrinsics.k1 = -0.12;
    camera.intrinsics.k2 = 0.05;
    camera.intrinsics.p1 = 0.001;
    camera.intrinsics.p2 = -0.0015;
    camera.intrinsics.k3 = 0.01;
  }
  // Camera x = table x, camera y = -table y, camera z = -table z.
  Eigen::Matrix3d rotation;
  rotation << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  camera.cam_from_table.linear() = rotation;
  camera.cam_from_table.translation() = -rotation * Eigen::Vector3d(0, 0, height_mm);
  return camera;
}

}  // namespace scanbench::testing
