#include "calibration/camera_calibration.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/format.h"
#include "calibration/camera_model.h"
#include "core/field_error.h"

namespace scanbench {
namespace {

// The image scaled so that its bright squares sit near 230 of 255: robust to
// the absolute exposure. A high percentile, not the maximum, so that a few
// hot or clipped pixels do not darken everything.
double BrightLevel(const ImageF& gray) {
  std::vector<float> values;
  const size_t stride = std::max<size_t>(1, gray.num_pixels() / 200000);
  for (size_t i = 0; i < gray.num_pixels(); i += stride) values.push_back(gray.data()[i]);
  const size_t k = static_cast<size_t>(0.995 * (values.size() - 1));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

cv::Mat ToFloatMat(const ImageF& gray, double scale) {
  cv::Mat mat(gray.height(), gray.width(), CV_32FC1);
  for (int y = 0; y < gray.height(); ++y) {
    const float* in = gray.row(y);
    float* out = mat.ptr<float>(y);
    for (int x = 0; x < gray.width(); ++x) out[x] = static_cast<float>(std::clamp(in[x] * scale, 0.0, 255.0));
  }
  return mat;
}

Eigen::Isometry3d PoseFromRodrigues(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat rotation;
  cv::Rodrigues(rvec, rotation);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.linear()(r, c) = rotation.at<double>(r, c);
    pose.translation()[r] = tvec.at<double>(r);
  }
  return pose;
}

double ReprojectionRms(const std::vector<cv::Point3f>& object, const std::vector<cv::Point2f>& image,
                       const cv::Mat& rvec, const cv::Mat& tvec, const cv::Mat& camera_matrix,
                       const cv::Mat& distortion) {
  std::vector<cv::Point2f> projected;
  cv::projectPoints(object, rvec, tvec, camera_matrix, distortion, projected);
  double sum = 0;
  for (size_t i = 0; i < image.size(); ++i) {
    const cv::Point2f d = projected[i] - image[i];
    sum += d.x * d.x + d.y * d.y;
  }
  return std::sqrt(sum / std::max<size_t>(1, image.size()));
}

// ---------------------------------------------------------------------------
// The steps of CalibrateCamera.

// Throws std::invalid_argument for views of different sizes or a board
// height out of range.
void CheckViews(const std::vector<CalibrationView>& views) {
  const int width = views[0].gray.width(), height = views[0].gray.height();
  for (size_t v = 0; v < views.size(); ++v) {
    if (!views[v].gray.SameSize(width, height)) {
      throw std::invalid_argument("CalibrateCamera: view " + views[v].name + " is " +
                                  std::to_string(views[v].gray.width()) + "x" + std::to_string(views[v].gray.height()) +
                                  " but view " + views[0].name + " is " + std::to_string(width) + "x" +
                                  std::to_string(height) + "; all views must have one size");
    }
    SCANBENCH_REQUIRE_GE_LE("CalibrationView[" + std::to_string(v) + "] (" + views[v].name + ")", "board_height_mm",
                            views[v].board_height_mm, 0, 200);
  }
}

// The board in every view, with a report per view (used = usable so far).
// Progress runs over [0, 0.8]; false when it asked to stop.
bool DetectViews(const CheckerboardDetectionOptions& options, const CheckerboardTarget& board,
                 const std::vector<CalibrationView>& views, const ProgressCallback& progress,
                 std::vector<CheckerboardDetection>* detections, std::vector<CalibrationViewReport>* reports) {
  detections->assign(views.size(), CheckerboardDetection());
  for (size_t v = 0; v < views.size(); ++v) {
    if (progress && !progress(0.8 * v / views.size())) return false;
    const CheckerboardDetection& detection = (*detections)[v] = DetectCheckerboard(options, views[v].gray, board);
    CalibrationViewReport report;
    report.name = views[v].name;
    report.on_table = views[v].on_table;
    report.used = detection.usable;
    report.reason = detection.reason;
    report.edge_width_px = detection.edge_width_px;
    report.contrast = detection.contrast;
    reports->push_back(report);
  }
  return true;
}

std::vector<cv::Point2f> ToCvPoints(const std::vector<Eigen::Vector2d>& corners) {
  std::vector<cv::Point2f> points;
  for (const Eigen::Vector2d& c : corners) points.emplace_back(float(c.x()), float(c.y()));
  return points;
}

// OpenCV's calibration of the views in `used` (their indices).
struct OpenCvCalibration {
  cv::Mat camera_matrix, distortion;
  std::vector<cv::Mat> rvecs, tvecs;
  cv::Mat std_intrinsics, std_extrinsics, per_view_rms;
  std::vector<size_t> used;
  double rms_px = 0;
};

int CalibrationFlags(const CameraCalibrationOptions& options) {
  int flags = 0;
  if (options.radial_terms < 3) flags |= cv::CALIB_FIX_K3;
  if (options.radial_terms < 2) flags |= cv::CALIB_FIX_K2;
  if (options.fix_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  return flags;
}

// Calibrate on the usable views; drop the worst view (its report says why)
// while it does not fit the others. Sets *failure when fewer than min_views
// remain.
OpenCvCalibration CalibrateOnUsableViews(const CameraCalibrationOptions& options, const CheckerboardTarget& board,
                                         const std::vector<CheckerboardDetection>& detections, cv::Size image_size,
                                         std::vector<CalibrationViewReport>* reports, std::string* failure) {
  std::vector<cv::Point3f> object;
  for (const Eigen::Vector3d& p : board.CornersInTarget()) {
    object.emplace_back(float(p.x()), float(p.y()), float(p.z()));
  }
  OpenCvCalibration calibration;
  while (true) {
    calibration.used.clear();
    std::vector<std::vector<cv::Point3f>> object_points;
    std::vector<std::vector<cv::Point2f>> image_points;
    for (size_t v = 0; v < reports->size(); ++v) {
      if (!(*reports)[v].used) continue;
      calibration.used.push_back(v);
      image_points.push_back(ToCvPoints(detections[v].corners));
      object_points.push_back(object);
    }
    if (static_cast<int>(calibration.used.size()) < options.min_views) {
      *failure = std::to_string(calibration.used.size()) + " usable views, min_views = " +
                 std::to_string(options.min_views) + " required";
      return calibration;
    }
    calibration.camera_matrix = cv::Mat();
    calibration.distortion = cv::Mat();
    calibration.rms_px = cv::calibrateCamera(
        object_points, image_points, image_size, calibration.camera_matrix, calibration.distortion, calibration.rvecs,
        calibration.tvecs, calibration.std_intrinsics, calibration.std_extrinsics, calibration.per_view_rms,
        CalibrationFlags(options), cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, DBL_EPSILON));
    const cv::Mat& per_view_rms = calibration.per_view_rms;
    size_t worst = 0;
    for (size_t u = 1; u < calibration.used.size(); ++u) {
      if (per_view_rms.at<double>(int(u)) > per_view_rms.at<double>(int(worst))) worst = u;
    }
    const double worst_rms = per_view_rms.at<double>(int(worst));
    if (worst_rms <= options.max_view_rms_px) return calibration;
    CalibrationViewReport& report = (*reports)[calibration.used[worst]];
    report.used = false;
    report.reason = "reprojection RMS " + Fixed(worst_rms, 3) + " px > max_view_rms_px " +
                    Fixed(options.max_view_rms_px, 3) + " px: the view does not fit the others";
  }
}

// OpenCV's result into the summary: intrinsics, their spread, each used
// view's RMS and pose.
void StoreCalibration(const OpenCvCalibration& calibration, int width, int height, CameraCalibrationSummary* summary) {
  summary->reprojection_rms_px = calibration.rms_px;
  CameraIntrinsics& k = summary->camera.intrinsics;
  k.width = width;
  k.height = height;
  k.fx = calibration.camera_matrix.at<double>(0, 0);
  k.fy = calibration.camera_matrix.at<double>(1, 1);
  k.cx = calibration.camera_matrix.at<double>(0, 2);
  k.cy = calibration.camera_matrix.at<double>(1, 2);
  const double* d = calibration.distortion.ptr<double>();
  k.k1 = d[0];
  k.k2 = d[1];
  k.p1 = d[2];
  k.p2 = d[3];
  k.k3 = calibration.distortion.total() > 4 ? d[4] : 0.0;
  for (int i = 0; i < 9 && i < static_cast<int>(calibration.std_intrinsics.total()); ++i) {
    summary->intrinsics_std[i] = calibration.std_intrinsics.at<double>(i);
  }
  for (size_t u = 0; u < calibration.used.size(); ++u) {
    CalibrationViewReport& report = summary->views[calibration.used[u]];
    report.rms_px = calibration.per_view_rms.at<double>(int(u));
    report.cam_from_target = PoseFromRodrigues(calibration.rvecs[u], calibration.tvecs[u]);
  }
  summary->num_used_views = static_cast<int>(calibration.used.size());
}

// The first used view of the board lying flat; sets *failure (and returns
// views.size()) when there is none.
size_t FindTableView(const std::vector<CalibrationView>& views, const std::vector<size_t>& used,
                     std::string* failure) {
  for (size_t v : used) {
    if (views[v].on_table) return v;
  }
  bool any_on_table = false;
  for (const CalibrationView& view : views) any_on_table |= view.on_table;
  *failure = any_on_table ? "the view of the board lying on the table was rejected; the table pose is unknown"
                          : "no view has the board lying flat on the table (on_table); the table pose is unknown";
  return views.size();
}

// cam_from_table from the on-table view's corners (the board's face
// board_height_mm above the table) and their reprojection RMS.
void SolveTablePose(const OpenCvCalibration& calibration, const CheckerboardTarget& board, double board_height_mm,
                    const CheckerboardDetection& detection, CameraCalibrationSummary* summary) {
  std::vector<cv::Point3f> table_points;
  for (const Eigen::Vector3d& p : board.CornersInTarget()) {
    table_points.emplace_back(float(p.x()), float(p.y()), float(board_height_mm));
  }
  const std::vector<cv::Point2f> table_corners = ToCvPoints(detection.corners);
  cv::Mat rvec, tvec;
  cv::solvePnP(table_points, table_corners, calibration.camera_matrix, calibration.distortion, rvec, tvec, false,
               cv::SOLVEPNP_ITERATIVE);
  summary->camera.cam_from_table = PoseFromRodrigues(rvec, tvec);
  summary->table_view_rms_px = ReprojectionRms(table_points, table_corners, rvec, tvec, calibration.camera_matrix,
                                               calibration.distortion);
}

}  // namespace

void CheckerboardDetectionOptions::Check() const {
  const std::string where = "CheckerboardDetectionOptions";
  SCANBENCH_REQUIRE_GT_LE(where, "max_edge_width_px", max_edge_width_px, 0, 100);
  SCANBENCH_REQUIRE_GT_LT(where, "min_contrast", min_contrast, 0, 1);
  SCANBENCH_REQUIRE_GE_LE(where, "subpixel_window_px", subpixel_window_px, 2, 50);
}

void CameraCalibrationOptions::Check() const {
  detection.Check();
  const std::string where = "CameraCalibrationOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "min_views", min_views, 3, 1000);
  SCANBENCH_REQUIRE_GE_LE(where, "radial_terms", radial_terms, 1, 3);
  SCANBENCH_REQUIRE_FINITE_GT(where, "max_view_rms_px", max_view_rms_px, 0);
}

ImageF BalancedGray(const ImageF& rgb) {
  if (rgb.channels() != 3) {
    throw std::invalid_argument("BalancedGray: image has " + std::to_string(rgb.channels()) + " channels; 3 required");
  }
  std::array<double, 3> mean{};
  for (size_t i = 0; i < rgb.num_pixels(); ++i) {
    for (int c = 0; c < 3; ++c) mean[c] += rgb.data()[3 * i + c];
  }
  std::array<double, 3> weight{};
  for (int c = 0; c < 3; ++c) weight[c] = mean[c] > 0 ? rgb.num_pixels() / (3.0 * mean[c]) : 0.0;
  ImageF gray(rgb.width(), rgb.height(), 1);
  for (size_t i = 0; i < rgb.num_pixels(); ++i) {
    double sum = 0;
    for (int c = 0; c < 3; ++c) sum += weight[c] * rgb.data()[3 * i + c];
    gray.data()[i] = static_cast<float>(sum);
  }
  return gray;
}

CheckerboardDetection DetectCheckerboard(const CheckerboardDetectionOptions& options, const ImageF& gray,
                                         const CheckerboardTarget& board) {
  options.Check();
  board.Check();
  if (gray.empty() || gray.channels() != 1) {
    throw std::invalid_argument("DetectCheckerboard: image " + std::to_string(gray.width()) + "x" +
                                std::to_string(gray.height()) + "x" + std::to_string(gray.channels()) +
                                " must be a non-empty 1-channel image");
  }
  CheckerboardDetection detection;
  const double bright = BrightLevel(gray);
  if (!(bright > 0)) {
    detection.reason = "image is black: no checkerboard can be seen";
    return detection;
  }
  const cv::Mat image_float = ToFloatMat(gray, 230.0 / bright);
  cv::Mat image8;
  image_float.convertTo(image8, CV_8UC1);

  const cv::Size pattern(board.inner_corners_x, board.inner_corners_y);
  std::vector<cv::Point2f> corners;
  const bool found = cv::findChessboardCorners(image8, pattern, corners,
                                               cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  if (!found || static_cast<int>(corners.size()) != board.num_corners()) {
    detection.reason = "checkerboard of " + std::to_string(board.inner_corners_x) + "x" +
                       std::to_string(board.inner_corners_y) + " inner corners not found";
    return detection;
  }
  const int window = options.subpixel_window_px;
  for (const cv::Point2f& corner : corners) {
    if (corner.x < window + 1 || corner.y < window + 1 || corner.x > gray.width() - window - 2 ||
        corner.y > gray.height() - window - 2) {
      detection.reason = "checkerboard corner at " + Fixed(corner.x, 1) + "," + Fixed(corner.y, 1) +
                         " lies within " + std::to_string(window + 1) + " px of the image border";
      return detection;
    }
  }
  cv::cornerSubPix(image_float, corners, cv::Size(window, window), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
  // Canonical orientation: the first row runs to the right in the image (a
  // board's 180-degree turn is otherwise ambiguous).
  if (corners[board.inner_corners_x - 1].x < corners[0].x) std::reverse(corners.begin(), corners.end());
  detection.found = true;
  for (const cv::Point2f& corner : corners) detection.corners.emplace_back(corner.x, corner.y);

  const cv::Scalar sharpness = cv::estimateChessboardSharpness(image8, pattern, corners);
  detection.edge_width_px = sharpness[0];
  detection.contrast = sharpness[2] > 0 ? (sharpness[2] - sharpness[1]) / sharpness[2] : 0.0;
  if (!(detection.edge_width_px <= options.max_edge_width_px)) {
    detection.reason = "blurred: edge width " + Fixed(detection.edge_width_px, 2) + " px > max_edge_width_px " +
                       Fixed(options.max_edge_width_px, 2) + " px";
    return detection;
  }
  if (!(detection.contrast >= options.min_contrast)) {
    detection.reason = "low contrast: (light - dark) / light = " + Fixed(detection.contrast, 3) + " < min_contrast " +
                       Fixed(options.min_contrast, 3);
    return detection;
  }
  detection.usable = true;
  return detection;
}

std::string CameraCalibrationSummary::BriefReport() const {
  std::ostringstream out;
  out << "Camera calibration: " << (IsUsable() ? "success" : "failure");
  if (!message.empty()) out << " (" << message << ")";
  if (IsUsable()) {
    const CameraIntrinsics& k = camera.intrinsics;
    out << std::setprecision(6) << ", " << num_used_views << "/" << views.size() << " views, RMS "
        << Fixed(reprojection_rms_px, 3) << " px, table view RMS " << Fixed(table_view_rms_px, 3) << " px; fx "
        << k.fx << " fy " << k.fy << " cx " << k.cx << " cy " << k.cy << " k1 " << k.k1 << " k2 " << k.k2 << " p1 "
        << k.p1 << " p2 " << k.p2 << " k3 " << k.k3;
  }
  return out.str();
}

CameraCalibrationSummary CalibrateCamera(const CameraCalibrationOptions& options, const CheckerboardTarget& board,
                                         const std::vector<CalibrationView>& views,
                                         const ProgressCallback& progress) {
  options.Check();
  board.Check();
  CameraCalibrationSummary summary;
  if (views.empty()) {
    summary.SetFailure("no views given");
    return summary;
  }
  CheckViews(views);
  const int width = views[0].gray.width(), height = views[0].gray.height();

  std::vector<CheckerboardDetection> detections;
  if (!DetectViews(options.detection, board, views, progress, &detections, &summary.views)) {
    summary.SetCancelled();
    return summary;
  }
  std::string failure;
  const OpenCvCalibration calibration =
      CalibrateOnUsableViews(options, board, detections, cv::Size(width, height), &summary.views, &failure);
  if (!failure.empty()) {
    summary.reprojection_rms_px = calibration.rms_px;  // of the last round, if any
    summary.SetFailure(failure);
    return summary;
  }
  if (progress && !progress(0.9)) {
    summary.SetCancelled();
    return summary;
  }
  StoreCalibration(calibration, width, height, &summary);
  try {
    CheckCameraIntrinsics(summary.camera.intrinsics);
  } catch (const std::invalid_argument& error) {
    summary.SetFailure(std::string("calibration gave unusable intrinsics: ") + error.what());
    return summary;
  }

  const size_t table_view = FindTableView(views, calibration.used, &failure);
  if (!failure.empty()) {
    summary.SetFailure(failure);
    return summary;
  }
  SolveTablePose(calibration, board, views[table_view].board_height_mm, detections[table_view], &summary);
  const Eigen::Vector3d centre = CameraCentreInTable(summary.camera);
  if (!(centre.z() > 0)) {
    summary.SetFailure("the table pose puts the camera below the table (z = " + Fixed(centre.z(), 1) +
                       " mm): is the on-table view's board upside down?");
    return summary;
  }
  summary.termination = Termination::kSuccess;
  summary.message = "";
  if (progress) progress(1.0);
  return summary;
}

}  // namespace scanbench
