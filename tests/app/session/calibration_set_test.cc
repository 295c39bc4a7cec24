#include "app/session/calibration_set.h"

#include <chrono>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/session/calibration_target.h"
#include "tests/app/session/session_test_util.h"

namespace scanbench {
namespace {

using testing_util::MakeTestRig;
using testing_util::MakeTestSession;
using testing_util::ReadText;
using testing_util::TemporaryFolder;
using testing_util::WriteText;
using ::testing::HasSubstr;
using ::testing::ThrowsMessage;

const std::string kSha(64, 'a');

TargetCaptureRecord Target(const std::string& kind) {
  TargetCaptureRecord t;
  t.session = "/bench/targets/" + kind;
  t.kind = kind;
  t.captured = "2024-05-01T09:00:00Z";
  t.manifest_sha256 = kSha;
  t.target_sha256 = std::string(64, 'b');
  t.frame_sha256 = {std::string(64, 'c'), std::string(64, 'd')};
  return t;
}

// A set as the three calibrations leave it, for MakeTestSession's camera and
// its 3 LEDs: figures made up, a 4 x 3 node per-pixel field.
CalibrationSet MakeTestSet() {
  const Session session = MakeTestSession(3);
  CalibrationSet set;
  set.created = "2024-05-01T10:00:00.000Z";
  set.software_version = "scanbench 0.1.0";
  set.camera = {session.camera.make, session.camera.model, session.camera.serial, session.camera.lens,
                session.camera.width, session.camera.height};

  CameraCalibrationSection camera;
  camera.date = set.created;
  camera.targets = {Target("checkerboard")};
  camera.summary.termination = Termination::kSuccess;
  camera.summary.camera = session.rig.camera;
  camera.summary.reprojection_rms_px = 0.0751;
  camera.summary.table_view_rms_px = 0.113;
  camera.summary.num_used_views = 1;
  camera.summary.intrinsics_std = {5.1, 5.0, 10.2, 6.8, 0.04, 5.7, 4e-4, 6e-4, 0};
  CalibrationViewReport view;
  view.name = "/bench/targets/checkerboard";
  view.used = true;
  view.on_table = true;
  view.edge_width_px = 2.4;
  view.contrast = 0.95;
  view.rms_px = 0.113;
  camera.summary.views = {view, view};
  camera.summary.views[1].used = false;
  camera.summary.views[1].reason = "blurred: edge width 4.10 px > max_edge_width_px 3.00 px";
  set.camera_calibration = camera;

  WhiteBalanceSection white;
  white.date = "2024-05-01T10:05:00Z";
  white.targets = {Target("gray_chart")};
  white.summary.termination = Termination::kSuccess;
  for (int k = 0; k < 3; ++k) {
    LedWhiteBalance led;
    led.led_index = k;
    led.gains = {2.06 + k / 100.0, 1.0, 1.45};
    led.gains_std = {0.002, 0, 0.001};
    led.response_exponent = {1.001, 1.0, 0.999};
    led.linearity_rms = {0.002, 0.001, 0.0015};
    led.linear_range_min = 0.011;
    led.linear_range_max = 0.55;
    PatchMeasurement patch;
    patch.name = "N5";
    patch.reflectance = 0.1927;
    patch.mean = {0.05, 0.1, 0.07};
    patch.samples = {300, 600, 300};
    patch.used = true;
    led.patches = {patch};
    led.used_patches = 1;
    white.summary.leds.push_back(led);
    white.led_ids.push_back(session.rig.leds[k].id);
  }
  set.white_balance = white;

  LightsSection lights;
  lights.date = "2024-05-01T10:10:00Z";
  lights.targets = {Target("white_sheet"), Target("white_sheet")};
  WhiteSheetTarget raised;
  raised.height_mm = 40;
  lights.sheets = {WhiteSheetTarget(), raised};
  LightCalibrationSummary& s = lights.summary;
  s.termination = Termination::kSuccess;
  s.cell_px = 16;
  s.selected = LightCalibrationSummary::Choice::kPerPixel;
  s.selection_reason = "test";
  s.warnings = {"a warning"};
  for (int k = 0; k < 3; ++k) {
    LedModelFit fit;
    fit.usable = true;
    fit.led = session.rig.leds[k];
    fit.position_std_mm = {0.3, 0.4, 0.5};
    fit.chi = 1.1;
    fit.termination = "converged";
    s.model.push_back(fit);
    LedPerPixelFit per_pixel;
    per_pixel.iterations = 3;
    per_pixel.converged = true;
    per_pixel.direction_change_deg = {0.5, 0.01, 1e-5};
    per_pixel.intensity_change = {0.01, 1e-4, 1e-6};
    per_pixel.position_in_table_mm = fit.led.position_in_table_mm;
    s.per_pixel.push_back(per_pixel);
  }
  LightFieldGrid grid;
  grid.width = session.camera.width;
  grid.height = session.camera.height;
  grid.origin_x = grid.origin_y = 7.5;
  grid.step = 16;
  grid.nodes_x = 4;
  grid.nodes_y = 3;
  std::vector<float> dirs(grid.num_nodes() * 3 * 3), intensities(dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) {
    dirs[i] = i % 3 == 2 ? 0.9f : 0.1f * (i % 7);
    intensities[i] = 0.25f + 0.001f * i;
  }
  s.per_pixel_field.emplace(grid, 3, dirs, intensities);
  set.lights = lights;

  ColorSection color;
  color.date = "2024-05-01T10:15:00Z";
  color.targets = {Target("color_chart")};
  color.raw_files = {{"/photos/chart.nef", std::string(64, 'e')}};
  color.white_reference = "light_field";
  color.num_frames = 3;
  ColorCorrectionSummary& c = color.summary;
  c.termination = Termination::kSuccess;
  c.method = "ciede2000_fit";
  c.used_patches = 1;
  c.rec709_from_camera << 1.61, -0.52, -0.09, -0.17, 1.31, -0.14, 0.02, -0.43, 1.41;
  c.mean_delta_e_before = 6.6;
  c.max_delta_e_before = 10.8;
  c.mean_delta_e_after = 0.99;
  c.max_delta_e_after = 3.25;
  ColorPatchResult patch;
  patch.name = "cyan";
  patch.used = true;
  patch.status = "used";
  patch.measured_camera = {0.12, 0.26, 0.37};
  patch.reference_linear_rec709 = {-0.028, 0.249, 0.383};
  patch.corrected_linear_rec709 = {-0.005, 0.246, 0.408};
  patch.delta_e_before = 10.6;
  patch.delta_e_after = 3.25;
  c.patches = {patch};
  set.color = color;
  return set;
}

TEST(CalibrationSetTest, WritesAndLoadsEveryFigureAndTheField) {
  TemporaryFolder folder;
  CalibrationSet set = MakeTestSet();
  WriteCalibrationSet(folder / "cal", set);
  ASSERT_EQ(set.lights->field_sha256.size(), 6u);
  EXPECT_TRUE(std::filesystem::exists(folder / "cal" / "lights" / "led_02_intensity.exr"));
  const CalibrationSet loaded = LoadCalibrationSet(folder / "cal");
  EXPECT_EQ(loaded.camera.serial, set.camera.serial);
  ASSERT_TRUE(loaded.camera_calibration && loaded.white_balance && loaded.lights);
  testing_util::ExpectSameBits(set.camera_calibration->summary.camera.intrinsics.fx,
                               loaded.camera_calibration->summary.camera.intrinsics.fx, "fx");
  EXPECT_EQ(loaded.camera_calibration->summary.views[1].reason, set.camera_calibration->summary.views[1].reason);
  EXPECT_EQ(loaded.camera_calibration->targets[0].frame_sha256, set.camera_calibration->targets[0].frame_sha256);
  EXPECT_DOUBLE_EQ(loaded.white_balance->summary.leds[1].gains[0], 2.07);
  EXPECT_EQ(loaded.white_balance->led_ids, set.white_balance->led_ids);
  EXPECT_EQ(loaded.lights->summary.selected, LightCalibrationSummary::Choice::kPerPixel);
  EXPECT_EQ(loaded.lights->summary.per_pixel[2].direction_change_deg, set.lights->summary.per_pixel[2].direction_change_deg);
  EXPECT_DOUBLE_EQ(loaded.lights->sheets[1].height_mm, 40.0);
  ASSERT_TRUE(loaded.lights->summary.per_pixel_field.has_value());
  EXPECT_EQ(loaded.lights->summary.per_pixel_field->node_rgb_intensities(),
            set.lights->summary.per_pixel_field->node_rgb_intensities());
  EXPECT_EQ(loaded.lights->summary.per_pixel_field->node_light_dirs(),
            set.lights->summary.per_pixel_field->node_light_dirs());
  ASSERT_TRUE(loaded.color.has_value());
  EXPECT_EQ(loaded.color->summary.rec709_from_camera, set.color->summary.rec709_from_camera);
  EXPECT_EQ(loaded.color->raw_files[0].path, "/photos/chart.nef");
  EXPECT_EQ(loaded.color->white_reference, "light_field");
  ASSERT_EQ(loaded.color->summary.patches.size(), 1u);
  EXPECT_EQ(loaded.color->summary.patches[0].reference_linear_rec709, set.color->summary.patches[0].reference_linear_rec709);
  EXPECT_DOUBLE_EQ(loaded.color->summary.max_delta_e_after, 3.25);
  EXPECT_EQ(loaded.color->summary.used_patches, 1);
  EXPECT_EQ(loaded.color->summary.patches[0].status, "used");
  EXPECT_EQ(loaded.color->summary.termination, Termination::kSuccess);
}

TEST(CalibrationSetTest, LoaderNamesTheFileFieldValueAndRule) {
  TemporaryFolder folder;
  CalibrationSet set = MakeTestSet();
  WriteCalibrationSet(folder / "cal", set);
  const std::filesystem::path manifest = folder / "cal" / "calibration.json";
  const std::string original = ReadText(manifest);
  auto load_after = [&](const std::function<void(nlohmann::ordered_json&)>& edit) {
    nlohmann::ordered_json json = nlohmann::ordered_json::parse(original);
    edit(json);
    WriteText(manifest, json.dump(2));
    return [&] { LoadCalibrationSet(folder / "cal"); };
  };
  EXPECT_THAT(load_after([](auto& j) { j["schema_version"] = 2; }),
              ThrowsMessage<SessionError>(HasSubstr("calibration.json: schema_version: 2 is newer")));
  EXPECT_THAT(load_after([](auto& j) { j["camera"]["lense"] = "x"; }),
              ThrowsMessage<SessionError>(HasSubstr("camera.lense: unknown field")));
  EXPECT_THAT(load_after([](auto& j) { j["lights"]["selected"] = "both"; }),
              ThrowsMessage<SessionError>(HasSubstr("lights.selected: \"both\" must be \"model\" or \"per_pixel\"")));
  EXPECT_THAT(load_after([](auto& j) { j["white_balance"]["leds"][1]["gains"] = {2, 1, -1}; }),
              ThrowsMessage<SessionError>(HasSubstr("white_balance.leds[1].gains: [2, 1, -1] must be finite and > 0")));
  EXPECT_THAT(load_after([](auto& j) { j["color"]["white_reference"] = "sun"; }),
              ThrowsMessage<SessionError>(
                  HasSubstr("color.white_reference: \"sun\" must be \"light_field\" or \"neutral_patches\"")));
  EXPECT_THAT(load_after([](auto& j) { j["color"]["rec709_from_camera"] = {{1, 0, 0}, {0, 1, 0}}; }),
              ThrowsMessage<SessionError>(HasSubstr("color.rec709_from_camera: ")));
  EXPECT_THAT(load_after([](auto& j) { j["color"]["rec709_from_camera"] = {{1, 0, 0}, {1, 0, 0}, {0, 0, 1}}; }),
              ThrowsMessage<SessionError>(HasSubstr("non-zero determinant")));
  EXPECT_THAT(load_after([](auto& j) { j["color"]["targets"][0]["kind"] = "gray_chart"; }),
              ThrowsMessage<SessionError>(HasSubstr("color.targets[0].kind: \"gray_chart\" must be \"color_chart\"")));
  EXPECT_THAT(load_after([](auto& j) { j["lights"]["date"] = "yesterday"; }),
              ThrowsMessage<SessionError>(HasSubstr("lights.date: \"yesterday\" must be an ISO 8601 UTC time")));
  EXPECT_THAT(load_after([](auto& j) { j["camera_calibration"]["targets"][0]["manifest_sha256"] = "x"; }),
              ThrowsMessage<SessionError>(HasSubstr("camera_calibration.targets[0].manifest_sha256: \"x\" must be 64")));
  // A field file changed behind the manifest's back.
  WriteText(manifest, original);
  WriteText(folder / "cal" / "lights" / "led_01_direction.exr", "not an image");
  EXPECT_THAT([&] { LoadCalibrationSet(folder / "cal"); },
              ThrowsMessage<SessionError>(HasSubstr("lights.leds[1].per_pixel.direction_file.sha256: ")));
  EXPECT_THAT([&] { LoadCalibrationSet(folder / "nowhere"); },
              ThrowsMessage<SessionError>(HasSubstr("does not exist (is ")));
}

TEST(CalibrationSetTest, ACalibrationOfAnotherCameraLensOrResolutionIsRefused) {
  const CalibrationSet set = MakeTestSet();
  Session session = MakeTestSession(3);
  EXPECT_NO_THROW(CheckCalibrationFitsSession(set, "cal.json", session, "s.json"));
  Session other = session;
  other.camera.serial = "999";
  EXPECT_THAT([&] { CheckCalibrationFitsSession(set, "cal.json", other, "s.json"); },
              ThrowsMessage<SessionError>(HasSubstr(
                  "cal.json: camera.serial \"0123456789\" differs from s.json camera.serial \"999\": a calibration "
                  "of another camera body is refused")));
  other = session;
  other.camera.lens = "RF 50mm";
  EXPECT_THAT([&] { CheckCalibrationFitsSession(set, "cal.json", other, "s.json"); },
              ThrowsMessage<SessionError>(HasSubstr("of another lens is refused")));
  other = session;
  other.camera.width = 3000;
  EXPECT_THAT([&] { CheckCalibrationFitsSession(set, "cal.json", other, "s.json"); },
              ThrowsMessage<SessionError>(HasSubstr(
                  "camera size 6000x4000 differs from s.json camera.settings 3000x4000: a calibration at another "
                  "resolution is refused")));
  other = MakeTestSession(4);
  EXPECT_THAT([&] { CheckCalibrationFitsSession(set, "cal.json", other, "s.json"); },
              ThrowsMessage<SessionError>(HasSubstr("lights.leds has 3 LEDs but s.json rig.leds has 4")));
}

TEST(CalibrationSetTest, AnOldSetWarnsAfterTheConfiguredAge) {
  const CalibrationSet set = MakeTestSet();
  const auto created = ParseUtcTimestamp("2024-05-01T10:00:00Z", "test");
  EXPECT_FALSE(CalibrationAgeWarning(set, "cal.json", 30, created + std::chrono::hours(24 * 29)));
  const auto warning = CalibrationAgeWarning(set, "cal.json", 30, created + std::chrono::hours(24 * 45));
  ASSERT_TRUE(warning.has_value());
  EXPECT_THAT(*warning, HasSubstr("cal.json: stale calibration: camera_calibration.date 2024-05-01T10:00:00.000Z is 45.0 "
                                  "days old, older than the limit of 30 days"));
  EXPECT_THAT([] { ParseUtcTimestamp("2024-05-01 10:00", "x.json: date"); },
              ThrowsMessage<SessionError>(HasSubstr("x.json: date: \"2024-05-01 10:00\" must be an ISO 8601")));
  // 1970 + one day and a half second.
  EXPECT_EQ(ParseUtcTimestamp("1970-01-02T00:00:00.5Z", "t").time_since_epoch(),
            std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::milliseconds(86400500)));
}

TEST(CalibrationTargetTest, RoundTripsEveryKindAndNamesBadFields) {
  TemporaryFolder folder;
  CalibrationTargetDescription board;
  board.kind = CalibrationTargetDescription::Kind::kCheckerboard;
  board.on_table = true;
  board.board_height_mm = 1.5;
  WriteCalibrationTarget(folder.path(), board);
  CalibrationTargetDescription loaded = LoadCalibrationTarget(folder.path());
  EXPECT_EQ(loaded.kind, board.kind);
  EXPECT_EQ(loaded.checkerboard.inner_corners_x, 9);
  EXPECT_TRUE(loaded.on_table);
  EXPECT_DOUBLE_EQ(loaded.board_height_mm, 1.5);

  CalibrationTargetDescription chart;
  chart.kind = CalibrationTargetDescription::Kind::kGrayChart;
  chart.gray_chart = GrayChartTarget::MunsellNeutralScale();
  WriteCalibrationTarget(folder.path(), chart);
  loaded = LoadCalibrationTarget(folder.path());
  ASSERT_EQ(loaded.gray_chart.patches.size(), 9u);
  EXPECT_EQ(loaded.gray_chart.patches[1].name, "N9.5");
  EXPECT_DOUBLE_EQ(loaded.gray_chart.patches[1].reflectance, chart.gray_chart.patches[1].reflectance);

  CalibrationTargetDescription sheet;
  sheet.white_sheet.height_mm = 40;
  WriteCalibrationTarget(folder.path(), sheet);
  EXPECT_DOUBLE_EQ(LoadCalibrationTarget(folder.path()).white_sheet.height_mm, 40);

  const std::string file = "/x/target.json";
  EXPECT_THAT([&] { CalibrationTargetFromJson(R"({"schema": "scanbench.calibration_target", "schema_version": 1,
      "kind": "checkerboard", "checkerboard": {"inner_corners": [2, 6], "square_mm": 9, "on_table": false,
      "board_height_mm": 0}})", file); },
              ThrowsMessage<SessionError>(HasSubstr("/x/target.json: checkerboard: CheckerboardTarget.inner_corners_x = 2")));
  EXPECT_THAT([&] { CalibrationTargetFromJson(R"({"schema": "scanbench.calibration_target", "schema_version": 1,
      "kind": "mirror"})", file); },
              ThrowsMessage<SessionError>(HasSubstr("kind: \"mirror\" must be \"checkerboard\", \"gray_chart\"")));
  EXPECT_THAT([&] { LoadCalibrationTarget(folder / "scan"); },
              ThrowsMessage<SessionError>(HasSubstr("is no calibration target session")));
}

}  // namespace
}  // namespace scanbench
