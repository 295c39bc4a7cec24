// What the scan bench is: camera geometry and LEDs, in the table frame.
//
// Table frame: origin at the centre of the sample area on the table top, x to
// the right of the image, y to the top of the image, z up towards the camera;
// millimetres. This is also the tangent frame of the normal maps (a flat
// sample has normal_in_table = (0, 0, 1)).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace scanbench {

// OpenCV's pinhole model with 5 distortion terms; pixel centres at integers.
struct CameraIntrinsics {
  int width = 0;                 // pixels
  int height = 0;                // pixels
  double fx = 0, fy = 0;         // focal length, pixels
  double cx = 0, cy = 0;         // principal point, pixels
  double k1 = 0, k2 = 0, k3 = 0; // radial distortion
  double p1 = 0, p2 = 0;         // tangential distortion
};

struct CameraGeometry {
  CameraIntrinsics intrinsics;
  // Maps table-frame points (mm) to the OpenCV camera frame (x right, y down,
  // z forward, mm).
  Eigen::Isometry3d cam_from_table = Eigen::Isometry3d::Identity();
};

struct LedDescription {
  int id = 0;                                          // firmware channel, 0..9
  Eigen::Vector3d position_in_table_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_in_table = -Eigen::Vector3d::UnitZ();  // unit, where it points
  double mu = 1.0;                                     // angular falloff: cos(angle off axis)^mu, >= 0
  // Linear pixel value (fraction of the raw range above black, per raw colour
  // channel, so it carries the sensor's white balance) that a white Lambertian
  // patch facing the LED on its axis at 1000 mm would read.
  Eigen::Vector3d rgb_intensity = Eigen::Vector3d::Ones();
};

struct RigDescription {
  std::string name;
  CameraGeometry camera;
  std::vector<LedDescription> leds;
};

// Distance at which LedDescription::rgb_intensity is stated.
inline constexpr double kLedReferenceDistanceMm = 1000.0;

}  // namespace scanbench
