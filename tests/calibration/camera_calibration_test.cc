#include "calibration/camera_calibration.h"

#include <cmath>
#include <numeric>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "calibration/camera_model.h"
#include "tests/calibration/sim_targets.h"

namespace scanbench {
namespace {

using testing::kCalibrationTestHeight;
using testing::kCalibrationTestWidth;

// One capture of the board per pose with every LED on, developed to gray.
class CameraCalibrationTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new RigDescription(MakeDefaultSimulatedRig(kCalibrationTestWidth, kCalibrationTestHeight));
    renderer_ = new TargetRenderer(testing::CalibrationTestSensor(), *truth_);
    views_ = new std::vector<CalibrationView>();
    const std::vector<Eigen::Isometry3d> poses = DefaultCheckerboardPoses();
    for (size_t i = 0; i < poses.size(); ++i) {
      views_->push_back(RenderView("pose " + std::to_string(i), poses[i], 100 * i, {}));
      views_->back().on_table = i == 0;
    }
  }
  static void TearDownTestSuite() {
    delete views_;
    delete renderer_;
    delete truth_;
  }

  static CalibrationView RenderView(const std::string& name, const Eigen::Isometry3d& pose, uint64_t frame_index,
                                    TargetRenderOptions render) {
    render.exposure = 0.15;  // all ten LEDs at once: keep the light squares below white
    const PreparedTarget target = renderer_->Prepare(SimulatedTarget::Checkerboard(board_, pose), render);
    std::vector<int> all(renderer_->num_leds());
    std::iota(all.begin(), all.end(), 0);
    const RawImage dark = renderer_->RenderFrame(target, {}, frame_index, render);
    const RawImage lit = renderer_->RenderFrame(target, all, frame_index + 1, render);
    CalibrationView view;
    view.name = name;
    view.gray = BalancedGray(DevelopRaw(lit, &dark, {}).rgb);
    return view;
  }

  static inline const CheckerboardTarget board_{};
  static inline RigDescription* truth_ = nullptr;
  static inline TargetRenderer* renderer_ = nullptr;
  static inline std::vector<CalibrationView>* views_ = nullptr;
};

// Pixel shift that the lens distortion causes at normalised point (x, y).
Eigen::Vector2d DistortionShift(const CameraIntrinsics& k, double x, double y) {
  const double r2 = x * x + y * y;
  const double radial = r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
  return {k.fx * (x * radial + 2 * k.p1 * x * y + k.p2 * (r2 + 2 * x * x)),
          k.fy * (y * radial + k.p1 * (r2 + 2 * y * y) + 2 * k.p2 * x * y)};
}

TEST_F(CameraCalibrationTest, RecoversTheTrueIntrinsicsDistortionAndTablePose) {
  const CameraCalibrationSummary summary = CalibrateCamera({}, board_, *views_);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.num_used_views, 9);
  EXPECT_LT(summary.reprojection_rms_px, 0.2);
  EXPECT_LT(summary.table_view_rms_px, 0.2);
  const CameraIntrinsics& k = summary.camera.intrinsics;
  const CameraIntrinsics& t = truth_->camera.intrinsics;
  // Stated tolerances (616 x 408, 9 views of a 9 x 6 board):
  // focal lengths within 0.2 %;
  EXPECT_NEAR(k.fx / t.fx, 1.0, 2e-3);
  EXPECT_NEAR(k.fy / t.fy, 1.0, 2e-3);
  // the principal point within 3 reported standard deviations + 1 px (a
  // narrow field ties it to the tilt of every view: some pixels of spread);
  EXPECT_NEAR(k.cx, t.cx, 3 * summary.intrinsics_std[2] + 1) << "std " << summary.intrinsics_std[2];
  EXPECT_NEAR(k.cy, t.cy, 3 * summary.intrinsics_std[3] + 1) << "std " << summary.intrinsics_std[3];
  // the distortion's pixel shift within 0.6 px everywhere in the image (the
  // coefficients themselves trade off against each other across this field);
  double worst_shift = 0;
  for (int y = 0; y < t.height; y += 8) {
    for (int x = 0; x < t.width; x += 8) {
      const double nx = (x - t.cx) / t.fx, ny = (y - t.cy) / t.fy;
      worst_shift = std::max(worst_shift, (DistortionShift(k, nx, ny) - DistortionShift(t, nx, ny)).norm());
    }
  }
  EXPECT_LT(worst_shift, 0.6);
  // every pixel's ray meets the table within 0.3 mm (1.3 px) of where it
  // truly does: what the light field is built on;
  const ImageF truth_points = ComputeTablePoints(truth_->camera);
  const ImageF points = ComputeTablePoints(summary.camera);
  double worst_point = 0;
  for (size_t i = 0; i < points.num_pixels(); i += 7) {
    const Eigen::Vector3d a(truth_points.data()[3 * i], truth_points.data()[3 * i + 1], truth_points.data()[3 * i + 2]);
    const Eigen::Vector3d b(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
    worst_point = std::max(worst_point, (a - b).norm());
  }
  EXPECT_LT(worst_point, 0.3);
  // the camera centre within 10 mm (laterally weak: a flat board seen by a
  // narrow lens leaves tilt and shift nearly interchangeable).
  EXPECT_LT((CameraCentreInTable(summary.camera) - CameraCentreInTable(truth_->camera)).norm(), 10.0);
}

TEST_F(CameraCalibrationTest, BlurredAndMissingBoardsAreRejectedWithTheReason) {
  std::vector<CalibrationView> views = *views_;
  TargetRenderOptions defocus;
  defocus.blur_px = 2.5;
  views.push_back(RenderView("defocused", DefaultCheckerboardPoses()[3], 5000, defocus));
  CalibrationView empty = views.back();
  empty.name = "no board";
  for (size_t i = 0; i < empty.gray.size(); ++i) empty.gray.data()[i] = 0.5f;
  views.push_back(empty);
  const CameraCalibrationSummary summary = CalibrateCamera({}, board_, views);
  ASSERT_TRUE(summary.IsUsable()) << summary.message;
  EXPECT_EQ(summary.num_used_views, 9);
  ASSERT_EQ(summary.views.size(), 11u);
  EXPECT_FALSE(summary.views[9].used);
  EXPECT_THAT(summary.views[9].reason, ::testing::StartsWith("blurred: edge width"));
  EXPECT_GT(summary.views[9].edge_width_px, 3.0);
  EXPECT_FALSE(summary.views[10].used);
  EXPECT_THAT(summary.views[10].reason, ::testing::HasSubstr("not found"));
  // The sharp views measure as sharp.
  EXPECT_LT(summary.views[0].edge_width_px, 2.6);
  EXPECT_GT(summary.views[0].contrast, 0.8);
}

TEST_F(CameraCalibrationTest, DetectedCornersLieOnTheTrueProjections) {
  const CheckerboardDetection detection = DetectCheckerboard({}, (*views_)[0].gray, board_);
  ASSERT_TRUE(detection.usable) << detection.reason;
  const std::vector<Eigen::Vector3d> corners = board_.CornersInTarget();
  double sum_squares = 0;
  for (size_t i = 0; i < corners.size(); ++i) {
    const Eigen::Vector2d truth = ProjectToPixel(truth_->camera.intrinsics, truth_->camera.cam_from_table * corners[i]);
    sum_squares += (detection.corners[i] - truth).squaredNorm();
  }
  // Canonical order: corner 0 is the top-left one of the board on the table.
  EXPECT_LT(std::sqrt(sum_squares / corners.size()), 0.15);
}

TEST_F(CameraCalibrationTest, WithoutAnOnTableViewTheCalibrationFailsSayingWhy) {
  std::vector<CalibrationView> views = *views_;
  for (CalibrationView& view : views) view.on_table = false;
  const CameraCalibrationSummary summary = CalibrateCamera({}, board_, views);
  EXPECT_FALSE(summary.IsUsable());
  EXPECT_THAT(summary.message, ::testing::HasSubstr("no view has the board lying flat on the table"));
  views.resize(2);
  views[0].on_table = true;
  EXPECT_THAT(CalibrateCamera({}, board_, views).message, ::testing::HasSubstr("2 usable views, min_views = 4"));
}

TEST_F(CameraCalibrationTest, ACancelEndsCancelledNotFailed) {
  // Stop while detecting the second view, then just before the table pose.
  std::vector<double> reported;
  const CameraCalibrationSummary detecting = CalibrateCamera({}, board_, *views_, [&](double fraction) {
    reported.push_back(fraction);
    return reported.size() < 2;
  });
  EXPECT_TRUE(detecting.IsCancelled());
  EXPECT_FALSE(detecting.IsUsable());
  EXPECT_EQ(detecting.views.size(), 1u);
  const CameraCalibrationSummary solved =
      CalibrateCamera({}, board_, *views_, [](double fraction) { return fraction < 0.9; });
  EXPECT_EQ(solved.termination, Termination::kCancelled);
  EXPECT_EQ(solved.views.size(), views_->size());
  EXPECT_EQ(solved.num_used_views, 0);
}

TEST(CameraCalibrationOptionsTest, CheckNamesTheFieldValueAndRule) {
  CameraCalibrationOptions options;
  options.radial_terms = 4;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("CameraCalibrationOptions.radial_terms = 4 must lie in [1, 3]")));
  options = {};
  options.detection.max_edge_width_px = 0;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("CheckerboardDetectionOptions.max_edge_width_px = 0")));
  CheckerboardTarget board;
  board.square_mm = -1;
  EXPECT_THAT([&] { board.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("CheckerboardTarget.square_mm = -1")));
}

}  // namespace
}  // namespace scanbench
