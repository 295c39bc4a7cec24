#include "calibration/camera_model.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/field_error.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

cv::Matx33d CameraMatrix(const CameraIntrinsics& k) {
  return cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

cv::Vec<double, 5> DistortionVector(const CameraIntrinsics& k) {
  return cv::Vec<double, 5>(k.k1, k.k2, k.p1, k.p2, k.k3);
}

// The unit rays in the camera frame of pixels (x0 + i step, y), i < count,
// as floats (the stored form), interleaved into `rays`: OpenCV's iterative
// undistortion, each pixel on its own, so a span (or every step-th pixel of
// one) gives the same floats as the whole image.
void RaysInCamOfRow(const CameraIntrinsics& intrinsics, int x0, int step, int y, int count, float* rays) {
  // Short spans (TablePlanePoints' pieces and single points) on the stack:
  // OpenCV's call costs about as much as one point's undistortion already.
  constexpr int kOnStack = 64;
  cv::Point2d stack[2 * kOnStack];
  std::vector<cv::Point2d> heap;
  cv::Point2d* points = stack;
  if (count > kOnStack) {
    heap.resize(2 * static_cast<size_t>(count));
    points = heap.data();
  }
  cv::Point2d* undistorted = points + count;
  for (int i = 0; i < count; ++i) points[i] = cv::Point2d(x0 + i * step, y);
  // The layout std::vector<cv::Point2d> has as an array (count x 1, two
  // doubles); OpenCV writes into `undistorted` in place.
  const cv::Mat distorted_mat(count, 1, CV_64FC2, points);
  cv::Mat undistorted_mat(count, 1, CV_64FC2, undistorted);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12);
  cv::undistortPoints(distorted_mat, undistorted_mat, CameraMatrix(intrinsics), DistortionVector(intrinsics),
                      cv::noArray(), cv::noArray(), criteria);
  if (undistorted_mat.data != reinterpret_cast<uchar*>(undistorted)) {
    throw std::logic_error("RaysInCamOfRow: cv::undistortPoints reallocated its output");
  }
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d ray = Eigen::Vector3d(undistorted[i].x, undistorted[i].y, 1.0).normalized();
    rays[3 * i + 0] = static_cast<float>(ray.x());
    rays[3 * i + 1] = static_cast<float>(ray.y());
    rays[3 * i + 2] = static_cast<float>(ray.z());
  }
}

}  // namespace

void CheckCameraIntrinsics(const CameraIntrinsics& k) {
  const std::string where = "CameraIntrinsics";
  SCANBENCH_REQUIRE_GT(where, "width", k.width, 0);
  SCANBENCH_REQUIRE_GT(where, "height", k.height, 0);
  SCANBENCH_REQUIRE_FINITE_GT(where, "fx", k.fx, 0);
  SCANBENCH_REQUIRE_FINITE_GT(where, "fy", k.fy, 0);
  if (!(k.cx >= 0 && k.cx <= k.width - 1)) throw FieldError(where, "cx", k.cx, "must lie in [0, width - 1]");
  if (!(k.cy >= 0 && k.cy <= k.height - 1)) throw FieldError(where, "cy", k.cy, "must lie in [0, height - 1]");
  for (const auto& [name, value] : {std::pair{"k1", k.k1}, {"k2", k.k2}, {"k3", k.k3}, {"p1", k.p1}, {"p2", k.p2}}) {
    SCANBENCH_REQUIRE_FINITE(where, name, value);
  }
}

Eigen::Vector2d ProjectToPixel(const CameraIntrinsics& k, const Eigen::Vector3d& point_in_cam) {
  const double x = point_in_cam.x() / point_in_cam.z();
  const double y = point_in_cam.y() / point_in_cam.z();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  const double xd = x * radial + 2 * k.p1 * x * y + k.p2 * (r2 + 2 * x * x);
  const double yd = y * radial + k.p1 * (r2 + 2 * y * y) + 2 * k.p2 * x * y;
  return {k.fx * xd + k.cx, k.fy * yd + k.cy};
}

std::vector<Eigen::Vector3d> ComputeRayDirectionsInCam(const CameraIntrinsics& intrinsics,
                                                       const std::vector<Eigen::Vector2d>& pixels) {
  CheckCameraIntrinsics(intrinsics);
  std::vector<cv::Point2d> distorted(pixels.size()), undistorted;
  for (size_t i = 0; i < pixels.size(); ++i) distorted[i] = cv::Point2d(pixels[i].x(), pixels[i].y());
  std::vector<Eigen::Vector3d> rays(pixels.size());
  if (pixels.empty()) return rays;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-12);
  cv::undistortPoints(distorted, undistorted, CameraMatrix(intrinsics), DistortionVector(intrinsics), cv::noArray(),
                      cv::noArray(), criteria);
  for (size_t i = 0; i < pixels.size(); ++i) {
    rays[i] = Eigen::Vector3d(undistorted[i].x, undistorted[i].y, 1.0).normalized();
  }
  return rays;
}

std::vector<Eigen::Vector3d> ComputePlanePointsInTable(const CameraGeometry& camera,
                                                       const std::vector<Eigen::Vector2d>& pixels,
                                                       double plane_height_mm) {
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  const Eigen::Matrix3d table_from_cam_rotation = camera.cam_from_table.rotation().transpose();
  std::vector<Eigen::Vector3d> points = ComputeRayDirectionsInCam(camera.intrinsics, pixels);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d ray = table_from_cam_rotation * points[i];
    const double t = (plane_height_mm - centre.z()) / ray.z();
    if (!(t > 0) || !std::isfinite(t)) {
      throw std::invalid_argument("camera geometry: the ray of pixel " + std::to_string(pixels[i].x()) + "," +
                                  std::to_string(pixels[i].y()) + " does not reach the plane z = " +
                                  std::to_string(plane_height_mm) + " mm in front of the camera");
    }
    points[i] = centre + t * ray;
  }
  return points;
}

ImageF ComputeRayDirectionsInCam(const CameraIntrinsics& intrinsics, int num_threads) {
  CheckCameraIntrinsics(intrinsics);
  ImageF rays(intrinsics.width, intrinsics.height, 3);
  // Row by row bounds the temporary memory at 16 MP; rows on the pool, since
  // the iterative undistortion is seconds of one core at 16 MP.
  ParallelFor(intrinsics.height, ResolveThreadCount(num_threads), 16, [&](int first, int last, int) {
    for (int y = first; y < last; ++y) RaysInCamOfRow(intrinsics, 0, 1, y, intrinsics.width, rays.row(y));
  });
  return rays;
}

Eigen::Vector3d CameraCentreInTable(const CameraGeometry& camera) {
  return camera.cam_from_table.inverse().translation();
}

ImageF ComputeRayDirectionsInTable(const CameraGeometry& camera, int num_threads) {
  ImageF rays = ComputeRayDirectionsInCam(camera.intrinsics, num_threads);
  const Eigen::Matrix3f table_from_cam_rotation =
      camera.cam_from_table.rotation().transpose().cast<float>();
  float* data = rays.data();
  for (size_t i = 0; i < rays.num_pixels(); ++i) {
    Eigen::Map<Eigen::Vector3f> ray(data + 3 * i);
    ray = table_from_cam_rotation * ray;
  }
  return rays;
}

void ComputeTablePointsOfSpan(const CameraGeometry& camera, int x0, int y, int count, float* xyz) {
  ComputeTablePointsOfRow(camera, x0, 1, y, count, xyz);
}

void ComputeTablePointsOfRow(const CameraGeometry& camera, int x0, int step, int y, int count, float* xyz) {
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  if (!(centre.z() > 0)) {
    throw std::invalid_argument("camera geometry: camera centre z = " + std::to_string(centre.z()) +
                                " mm must be above the table (> 0)");
  }
  RaysInCamOfRow(camera.intrinsics, x0, step, y, count, xyz);
  // The same float rotation and double intersection as the whole image's
  // (ComputeRayDirectionsInTable, then the plane), so the same floats.
  const Eigen::Matrix3f table_from_cam_rotation = camera.cam_from_table.rotation().transpose().cast<float>();
  for (int i = 0; i < count; ++i) {
    Eigen::Map<Eigen::Vector3f> p(xyz + 3 * i);
    p = table_from_cam_rotation * p;
    const Eigen::Vector3d ray = p.cast<double>();
    if (!(ray.z() < -1e-6)) {
      throw std::invalid_argument("camera geometry: the ray of pixel " + std::to_string(x0 + i * step) + "," +
                                  std::to_string(y) + " does not reach the table");
    }
    const double t = -centre.z() / ray.z();
    p = (centre + t * ray).cast<float>();
  }
}

ImageF ComputeTablePoints(const CameraGeometry& camera, int num_threads) {
  CheckCameraIntrinsics(camera.intrinsics);
  ImageF points(camera.intrinsics.width, camera.intrinsics.height, 3);
  ParallelFor(points.height(), ResolveThreadCount(num_threads), 16, [&](int first, int last, int) {
    for (int y = first; y < last; ++y) ComputeTablePointsOfSpan(camera, 0, y, points.width(), points.row(y));
  });
  return points;
}

CameraGeometry BlockCamera(const CameraGeometry& camera, int block_px) {
  const CameraIntrinsics& k = camera.intrinsics;
  if (block_px < 1 || k.width / block_px < 1 || k.height / block_px < 1) {
    throw std::invalid_argument("BlockCamera: block of " + std::to_string(block_px) + " px for a " +
                                std::to_string(k.width) + "x" + std::to_string(k.height) +
                                " image must be >= 1 and fit the image");
  }
  CameraGeometry blocks = camera;
  const double scale = 1.0 / block_px;
  const double centre_offset = 0.5 * (block_px - 1);  // a block's centre, in pixels from its first pixel
  blocks.intrinsics.width = k.width / block_px;
  blocks.intrinsics.height = k.height / block_px;
  blocks.intrinsics.fx = k.fx * scale;
  blocks.intrinsics.fy = k.fy * scale;
  blocks.intrinsics.cx = (k.cx - centre_offset) * scale;
  blocks.intrinsics.cy = (k.cy - centre_offset) * scale;
  return blocks;
}

double TablePixelFootprintMm(const CameraGeometry& camera) {
  const double cx = camera.intrinsics.width / 2, cy = camera.intrinsics.height / 2;
  const std::vector<Eigen::Vector3d> points =
      ComputePlanePointsInTable(camera, {{cx, cy}, {cx + 1, cy}, {cx, cy + 1}}, 0.0);
  return 0.5 * ((points[1] - points[0]).norm() + (points[2] - points[0]).norm());
}

}  // namespace scanbench
