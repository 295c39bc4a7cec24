// Camera calibration from checkerboard views (OpenCV): intrinsics and lens
// distortion from all usable views, the pose of the table from the view of
// the board lying flat on it. Views where the board is not found, is blurred
// or has too little contrast are rejected with the reason, as are views that
// do not fit the others (reprojection RMS above a limit).
//
// The solver then uses these intrinsics as ray maps (calibration/camera_model.h:
// every pixel's ray through the inverse distortion); images are never resampled.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/progress.h"
#include "core/summary.h"
#include "calibration/calibration_targets.h"
#include "calibration/raw_develop.h"
#include "calibration/rig.h"
#include "core/image.h"

namespace scanbench {

struct CheckerboardDetectionOptions {
  // 10-90 % rise width of the square edges, pixels, above which a view is
  // rejected as blurred (an in-focus board measures 1-2 px), (0, 100].
  double max_edge_width_px = 3.0;
  // (light - dark) / light of the squares below which a view is rejected as
  // too dark or washed out, (0, 1).
  double min_contrast = 0.3;
  // Half side of the cornerSubPix search window, pixels, [2, 50]; also the
  // least distance a corner must keep from the image border.
  int subpixel_window_px = 5;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct CheckerboardDetection {
  bool found = false;       // the full grid of inner corners was located
  bool usable = false;      // found, sharp and contrasty enough
  std::string reason;       // why not usable ("" when usable)
  // Pixel positions, row by row in CheckerboardTarget order; the orientation
  // is made canonical (corner 0 left of corner inner_corners_x - 1).
  std::vector<Eigen::Vector2d> corners;
  double edge_width_px = 0;  // mean 10-90 % edge rise width; 0 when not found
  double contrast = 0;       // (light - dark) / light; 0 when not found
};

// `gray`: 1 channel, linear (any scale). Never throws for an image without a
// board: found = false with the reason. Throws std::invalid_argument for bad
// options or an empty or multi-channel image. A measurement of one view (one
// OpenCV call, nothing to cancel), so it returns the detection itself rather
// than a summary: "not found" and "blurred" are results, not failures.
CheckerboardDetection DetectCheckerboard(const CheckerboardDetectionOptions& options, const ImageF& gray,
                                         const CheckerboardTarget& board);

// A gray image for detection from a developed RAW frame: each colour channel
// divided by its mean, then averaged (the CFA colours weigh alike).
ImageF BalancedGray(const ImageF& rgb);

struct CameraCalibrationOptions {
  CheckerboardDetectionOptions detection;  // how each view's board is found and judged
  int min_views = 4;               // usable views needed, [3, 1000]
  // Radial distortion terms to fit, [1, 3]: 1 = k1, 2 = k1 k2, 3 = k1 k2 k3
  // (the others stay 0). Across the narrow field of a short tele lens the
  // higher terms are indistinguishable from k1 and only add noise.
  int radial_terms = 2;
  bool fix_tangential = false;     // keep p1 = p2 = 0
  // A view whose reprojection RMS after calibration exceeds this, pixels,
  // is rejected and the calibration rerun without it, > 0.
  double max_view_rms_px = 1.0;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct CalibrationView {
  std::string name;            // what the reports call it (e.g. the session folder)
  ImageF gray;                 // 1 channel, linear (BalancedGray of a developed frame)
  // The board lies flat on the table in the table's orientation (its x along
  // the image's x): this view fixes cam_from_table. Exactly one view should.
  bool on_table = false;
  double board_height_mm = 0;  // its face above the table top (the board's thickness), [0, 200]
};

struct CalibrationViewReport {
  std::string name;
  bool used = false;
  std::string reason;          // why rejected ("" when used)
  bool on_table = false;
  double edge_width_px = 0;
  double contrast = 0;
  double rms_px = 0;           // reprojection RMS of its corners; 0 when not used
  Eigen::Isometry3d cam_from_target = Eigen::Isometry3d::Identity();  // when used
};

struct CameraCalibrationSummary : AlgorithmSummary {
  CameraGeometry camera;                     // intrinsics and cam_from_table
  double reprojection_rms_px = 0;            // over all corners of the used views
  double table_view_rms_px = 0;              // the on-table view's corners under cam_from_table
  // One standard deviation of fx, fy, cx, cy, k1, k2, p1, p2, k3 (0 when fixed).
  std::array<double, 9> intrinsics_std{};
  std::vector<CalibrationViewReport> views;  // in input order
  int num_used_views = 0;

  std::string BriefReport() const;
};


// The camera (intrinsics and cam_from_table) is a figure of the summary (the
// calibration set stores it as it is). Throws std::invalid_argument for bad
// options or target, or views of different sizes. A calibration that cannot
// be made (too few usable views, no on-table view) returns
// Termination::kFailure with the reason; Termination::kCancelled when the
// progress callback asks to stop.
CameraCalibrationSummary CalibrateCamera(const CameraCalibrationOptions& options, const CheckerboardTarget& board,
                                         const std::vector<CalibrationView>& views,
                                         const ProgressCallback& progress = {});

}  // namespace scanbench
