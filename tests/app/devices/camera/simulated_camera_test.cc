#include "app/devices/camera/simulated_camera.h"

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/io/raw_decoder.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

// A flat, uniformly coloured patch on the table at 1/16 of the D5100's
// resolution: what lights it is then plain from the image.
std::shared_ptr<const SimulatedRig> FlatRig() {
  static const std::shared_ptr<const SimulatedRig> rig = [] {
    SimulatedRigOptions options;
    options.width = kD5100Width / 16;
    options.height = kD5100Height / 16;
    options.cast_shadows = false;  // nothing casts one on a flat patch
    options.shadow_grid_mm = 1.0;  // coarsest: the grid is what takes time to build
    TextileSceneOptions scene;
    scene.thread_height_mm = 0;
    scene.crossing_amplitude_mm = 0;
    scene.thread_height_variation = 0;
    scene.base_thickness_mm = 0;
    scene.fold_amplitude_mm = 0;
    scene.color_variation = 0;
    scene.gap_darkening = 0;
    scene.warp_rgb = scene.weft_rgb = scene.table_rgb = Eigen::Vector3d(0.5, 0.5, 0.5);
    return std::make_shared<const SimulatedRig>(options, TextileScene(scene),
                                                MakeDefaultSimulatedRig(options.width, options.height));
  }();
  return rig;
}

// Mean signal above black over columns [x0, x1) of the decoded frame.
double MeanSignal(const RawImage& raw, int x0, int x1) {
  double sum = 0;
  int count = 0;
  for (int y = 0; y < raw.height(); ++y) {
    for (int x = x0; x < x1; ++x) {
      sum += double(raw.mosaic(x, y)) - raw.BlackAt(x, y);
      ++count;
    }
  }
  return sum / count;
}

// The LEDs furthest to the right (+x in the table frame: the image's right)
// and to the left.
std::pair<int, int> RightAndLeftLeds(const SimulatedRig& rig) {
  int right = 0, left = 0;
  for (int k = 0; k < rig.num_leds(); ++k) {
    const double x = rig.rig().leds[k].position_in_table_mm.x();
    if (x > rig.rig().leds[right].position_in_table_mm.x()) right = k;
    if (x < rig.rig().leds[left].position_in_table_mm.x()) left = k;
  }
  return {right, left};
}

TEST(SimulatedCamera, RendersTheLedThatIsLitAtCaptureTime) {
  const std::shared_ptr<const SimulatedRig> rig = FlatRig();
  const auto [right, left] = RightAndLeftLeds(*rig);
  ASSERT_GT(rig->rig().leds[right].position_in_table_mm.x(), 100);
  ASSERT_LT(rig->rig().leds[left].position_in_table_mm.x(), -100);

  std::optional<int> lit;  // what the "board" has lit
  SimulatedCamera camera(rig, [&lit] { return lit; });
  const int third = rig->width() / 3;
  const auto left_and_right = [&](const CapturedFrame& frame) {
    const RawImage raw = DecodeRaw(frame.bytes, frame.source_name);
    EXPECT_EQ(raw.width(), rig->width());
    return std::pair(MeanSignal(raw, 0, third), MeanSignal(raw, rig->width() - third, rig->width()));
  };

  lit = right;
  const auto [right_lit_left, right_lit_right] = left_and_right(camera.Capture());
  EXPECT_GT(right_lit_right, 1.3 * right_lit_left);
  EXPECT_EQ(camera.last_lit_led(), right);

  lit = left;
  const auto [left_lit_left, left_lit_right] = left_and_right(camera.Capture());
  EXPECT_GT(left_lit_left, 1.3 * left_lit_right);

  lit.reset();
  const CapturedFrame dark = camera.Capture();
  const auto [dark_left, dark_right] = left_and_right(dark);
  EXPECT_LT(dark_left + dark_right, 0.2 * (left_lit_left + left_lit_right));
  EXPECT_EQ(camera.last_lit_led(), std::nullopt);
  EXPECT_EQ(camera.capture_count(), 3u);
  EXPECT_EQ(dark.extension, ".dng");
  EXPECT_EQ(dark.source_name, "SIM_0002.DNG");

  const std::vector<CameraEvent> events = camera.DrainEvents(std::chrono::milliseconds(0));
  ASSERT_EQ(events.size(), 6u);
  EXPECT_EQ(events[1].detail, "LED " + std::to_string(right) + " lit");
  EXPECT_EQ(events[5].detail, "no LED lit");
}

TEST(SimulatedCamera, ExposureSettingsScaleTheSignalAndAreRecorded) {
  const std::shared_ptr<const SimulatedRig> rig = FlatRig();
  const int led = RightAndLeftLeds(*rig).first;
  SimulatedCamera camera(rig, [led] { return std::optional<int>(led); });
  EXPECT_EQ(camera.GetSetting(CameraSetting::kShutter).current, "1/60");
  EXPECT_DOUBLE_EQ(camera.SignalScale(), 1.0);

  const CapturedFrame reference = camera.Capture();
  camera.SetExposureTime(1.0 / 125);
  camera.SetSetting(CameraSetting::kIso, "200");
  camera.SetFNumber(8);
  EXPECT_EQ(camera.GetSetting(CameraSetting::kShutter).current, "1/125");
  EXPECT_NEAR(camera.SignalScale(), 2.0 * 60 / 125, 1e-12);
  const CapturedFrame shorter = camera.Capture();

  const DecodedRaw a = DecodeRawWithInfo(reference.bytes, "reference");
  const DecodedRaw b = DecodeRawWithInfo(shorter.bytes, "shorter");
  const double ratio = MeanSignal(b.image, 0, rig->width()) / MeanSignal(a.image, 0, rig->width());
  EXPECT_NEAR(ratio, 2.0 * 60 / 125, 0.03);
  EXPECT_NEAR(a.exposure_time_s, 1.0 / 60, 1e-6);
  EXPECT_NEAR(b.exposure_time_s, 1.0 / 125, 1e-6);
  EXPECT_EQ(b.iso, 200);
  EXPECT_EQ(b.f_number, 8);
  EXPECT_NEAR(shorter.settings.exposure_time_s, 1.0 / 125, 1e-12);
  EXPECT_EQ(b.model, "Simulated D5100");
  EXPECT_EQ(b.serial, "SIM-0001");

  EXPECT_THROW(camera.SetSetting(CameraSetting::kAperture, "f/1.2"), CameraError);
  EXPECT_THROW(camera.SetIso(80), CameraError);
  camera.SetIso(150);  // within a sixth of a stop of 160
  EXPECT_EQ(camera.GetSetting(CameraSetting::kIso).current, "160");
}

// What the GUI offers is the simulated camera's own list, and each value,
// carried as the number a capture takes, sets that very value again.
TEST(SimulatedCamera, EveryExposureChoiceRoundTripsThroughItsNumber) {
  SimulatedCamera camera(FlatRig(), [] { return std::optional<int>(); });
  for (const CameraSetting setting : {CameraSetting::kIso, CameraSetting::kShutter, CameraSetting::kAperture}) {
    const ExposureChoices choices = ExposureChoicesOf(camera, setting);
    EXPECT_EQ(choices.unavailable, "");
    EXPECT_EQ(choices.values, SimulatedCameraChoices(setting));
    for (const std::string& value : choices.values) {
      const double number = ExposureChoiceNumber(choices, value);
      switch (setting) {
        case CameraSetting::kIso:
          camera.SetIso(number);
          break;
        case CameraSetting::kShutter:
          camera.SetExposureTime(number);
          break;
        case CameraSetting::kAperture:
          camera.SetFNumber(number);
          break;
      }
      EXPECT_EQ(camera.GetSetting(setting).current, value) << CameraSettingName(setting) << " " << number;
    }
  }
}

// Raw samples that differ between two frames of the same size.
int DifferingSamples(const RawImage& a, const RawImage& b) {
  int differing = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) differing += a.mosaic(x, y) != b.mosaic(x, y);
  }
  return differing;
}

TEST(SimulatedCamera, PreviewRawIsTheNextCaptureSampleForSample) {
  const std::shared_ptr<const SimulatedRig> rig = FlatRig();
  const int led = RightAndLeftLeds(*rig).first;
  std::optional<int> lit = led;
  SimulatedCameraOptions options;
  options.first_frame_index = 7;
  SimulatedCamera camera(rig, [&lit] { return lit; }, options);
  // Twice the reference exposure: the preview carries the exposure scaling
  // and the clipping at the white level.
  camera.SetSetting(CameraSetting::kShutter, "1/30");

  const RawImage preview = camera.PreviewRaw();
  EXPECT_EQ(camera.capture_count(), 0u);
  EXPECT_TRUE(camera.DrainEvents(std::chrono::milliseconds(0)).empty());
  const RawImage captured = DecodeRaw(camera.Capture().bytes, "first");
  ASSERT_EQ(preview.width(), captured.width());
  ASSERT_EQ(preview.height(), captured.height());
  EXPECT_EQ(preview.white_level, captured.white_level);
  EXPECT_EQ(preview.black_level, captured.black_level);
  EXPECT_EQ(DifferingSamples(preview, captured), 0);
  EXPECT_NEAR(MeanSignal(preview, 0, rig->width()) / MeanSignal(rig->RenderFrame(led, 7), 0, rig->width()), 2.0,
              0.02);

  // After a capture the preview is the following one's, with its own noise,
  // and follows the LED lit now.
  lit.reset();
  const RawImage dark_preview = camera.PreviewRaw();
  const RawImage dark = DecodeRaw(camera.Capture().bytes, "dark");
  EXPECT_EQ(DifferingSamples(dark_preview, dark), 0);
  EXPECT_LT(MeanSignal(dark, 0, rig->width()), MeanSignal(captured, 0, rig->width()) / 10);

  lit = rig->num_leds();
  EXPECT_THROW(camera.PreviewRaw(), CameraError);
}

TEST(SimulatedCamera, CallbackFailuresAndUnknownLedsAreCameraErrors) {
  const std::shared_ptr<const SimulatedRig> rig = FlatRig();
  SimulatedCamera failing(rig, []() -> std::optional<int> { throw std::runtime_error("board stopped"); });
  try {
    failing.Capture();
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kIo);
    EXPECT_THAT(error.what(), StartsWith("simulated camera: reading which LED is lit failed: board stopped"));
  }
  SimulatedCamera eleventh(rig, [] { return std::optional<int>(10); });
  EXPECT_THROW(eleventh.Capture(), CameraError);

  EXPECT_THROW(SimulatedCamera(nullptr, [] { return std::optional<int>(); }), std::invalid_argument);
  EXPECT_THROW(SimulatedCamera(rig, {}), std::invalid_argument);
  SimulatedCameraOptions options;
  options.initial.iso = 80;
  EXPECT_THROW(SimulatedCamera(rig, [] { return std::optional<int>(); }, options), std::invalid_argument);
}

TEST(SimulatedCamera, PreviewIsASmallImage) {
  SimulatedCamera camera(FlatRig(), [] { return std::optional<int>(0); });
  const PreviewFrame preview = camera.CapturePreview();
  EXPECT_EQ(preview.extension, ".ppm");
  const std::string header(preview.bytes.begin(), preview.bytes.begin() + 12);
  EXPECT_THAT(header, StartsWith("P6\n154 102\n"));
  EXPECT_EQ(camera.capture_count(), 0u);
  EXPECT_THAT(camera.CheckReady(), ::testing::IsEmpty());
  EXPECT_EQ(camera.Info().backend, "simulated");
}

}  // namespace
}  // namespace scanbench
