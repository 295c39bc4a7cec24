#include "app/devices/camera/camera.h"

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/devices/camera/replay_camera.h"

namespace scanbench {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(ParseSettingValue, ReadsTheCamerasTexts) {
  EXPECT_EQ(ParseSettingValue(CameraSetting::kIso, "100"), 100);
  EXPECT_EQ(ParseSettingValue(CameraSetting::kIso, "ISO 3200"), 3200);
  EXPECT_EQ(ParseSettingValue(CameraSetting::kIso, "Auto"), std::nullopt);

  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kShutter, "1/125"), 1.0 / 125);
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kShutter, "10/13"), 10.0 / 13);  // Nikon's 1/1.3
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kShutter, "1 1/3"), 4.0 / 3);
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kShutter, "0.0080s"), 0.008);  // generic PTP
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kShutter, "30"), 30);
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kShutter, "2.5\""), 2.5);
  EXPECT_EQ(ParseSettingValue(CameraSetting::kShutter, "Bulb"), std::nullopt);
  EXPECT_EQ(ParseSettingValue(CameraSetting::kShutter, "1/0"), std::nullopt);

  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kAperture, "f/5.6"), 5.6);
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kAperture, "F8"), 8);
  EXPECT_DOUBLE_EQ(*ParseSettingValue(CameraSetting::kAperture, "11"), 11);
  EXPECT_EQ(ParseSettingValue(CameraSetting::kAperture, "f/-2"), std::nullopt);
  EXPECT_EQ(ParseSettingValue(CameraSetting::kAperture, "implicit auto"), std::nullopt);
}

CameraSettingState Radio(CameraSetting setting, std::vector<std::string> choices) {
  CameraSettingState state;
  state.setting = setting;
  state.choices = std::move(choices);
  state.current = state.choices.front();
  state.source = "widget test";
  return state;
}

TEST(MatchSettingValue, ExactChoiceOrNearestWithinASixthOfAStop) {
  const CameraSettingState shutter = Radio(CameraSetting::kShutter, {"1/60", "1/80", "1/100", "1/125", "1/160"});
  EXPECT_EQ(MatchSettingValue(shutter, "1/125", "cam"), "1/125");
  EXPECT_EQ(MatchSettingValue(shutter, "0.008", "cam"), "1/125");
  EXPECT_EQ(MatchSettingValue(shutter, "1/128", "cam"), "1/125");

  const CameraSettingState aperture = Radio(CameraSetting::kAperture, {"f/4", "f/5.6", "f/8"});
  EXPECT_EQ(MatchSettingValue(aperture, "F/5.6", "cam"), "f/5.6");  // case-insensitive
  EXPECT_EQ(MatchSettingValue(aperture, "5.6", "cam"), "f/5.6");
}

TEST(MatchSettingValue, RoundedSecondsOfGenericPtpStillMatchTheFraction) {
  // libgphoto2's generic PTP shutter widget prints 4 decimals: 1/4000 s is "0.0003s".
  const CameraSettingState shutter = Radio(CameraSetting::kShutter, {"0.0003s", "0.0004s", "0.0080s"});
  EXPECT_EQ(MatchSettingValue(shutter, "1/4000", "cam"), "0.0003s");
  EXPECT_EQ(MatchSettingValue(shutter, "1/125", "cam"), "0.0080s");
}

TEST(MatchSettingValue, ErrorNamesCameraSettingValueNearestAndAllowedValues) {
  const CameraSettingState iso = Radio(CameraSetting::kIso, {"100", "200", "400"});
  try {
    MatchSettingValue(iso, "140", "camera Nikon DSC D5100 (PTP mode) on usb:001,004");
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kNotSupported);
    EXPECT_EQ(error.camera(), "camera Nikon DSC D5100 (PTP mode) on usb:001,004");
    const std::string message = error.what();
    EXPECT_THAT(message, StartsWith("camera Nikon DSC D5100 (PTP mode) on usb:001,004: ISO '140'"));
    EXPECT_THAT(message, HasSubstr("nearest: 100"));
    EXPECT_THAT(message, HasSubstr("allowed values (widget test): 100, 200, 400"));
  }
  EXPECT_THROW(MatchSettingValue(iso, "lots", "cam"), CameraError);
  EXPECT_THROW(MatchSettingValue(iso, "", "cam"), CameraError);
}

TEST(MatchSettingValue, ReadOnlyAndRangeAndFreeSettings) {
  CameraSettingState aperture = Radio(CameraSetting::kAperture, {"f/8"});
  aperture.read_only = true;
  try {
    MatchSettingValue(aperture, "f/8", "cam");
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_THAT(error.what(), HasSubstr("read-only"));
    EXPECT_THAT(error.what(), HasSubstr("lens"));
  }

  CameraSettingState range;
  range.setting = CameraSetting::kAperture;
  range.range_min = 1.8;
  range.range_max = 22;
  EXPECT_EQ(MatchSettingValue(range, "f/5.6", "cam"), "5.6");
  EXPECT_THROW(MatchSettingValue(range, "f/32", "cam"), CameraError);
  EXPECT_THROW(MatchSettingValue(range, "wide", "cam"), CameraError);

  CameraSettingState free_text;
  free_text.setting = CameraSetting::kIso;
  EXPECT_EQ(MatchSettingValue(free_text, " 250 ", "cam"), "250");
}

// A camera that states fixed settings, or fails to: ExposureChoicesOf's inputs.
class StatedCamera : public Camera {
 public:
  std::optional<CameraSettingState> states[3];
  CameraErrorKind failure = CameraErrorKind::kNotSupported;

  std::string description() const override { return "camera stated"; }
  CameraDeviceInfo Info() override { return {}; }
  CameraSettingState GetSetting(CameraSetting setting) override {
    const std::optional<CameraSettingState>& state = states[int(setting)];
    if (!state) throw CameraError(failure, description(), "no such setting");
    return *state;
  }
  void SetSetting(CameraSetting, const std::string&) override {}
  std::vector<std::string> CheckReady() override { return {}; }
  CapturedFrame Capture() override { return {}; }
  PreviewFrame CapturePreview() override { return {}; }
  void StopPreview() override {}
  std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds) override { return {}; }
  void Reconnect() override {}
};

TEST(ExposureChoices, TheAllowedValuesThatAreNumbersOrWhyNone) {
  StatedCamera camera;
  camera.states[int(CameraSetting::kIso)] = Radio(CameraSetting::kIso, {"Auto", "100", "200", "Hi 1"});
  CameraSettingState shutter;
  shutter.setting = CameraSetting::kShutter;
  shutter.range_min = 0.001;
  shutter.range_max = 30;
  camera.states[int(CameraSetting::kShutter)] = shutter;
  CameraSettingState aperture = Radio(CameraSetting::kAperture, {"f/8"});
  aperture.read_only = true;
  camera.states[int(CameraSetting::kAperture)] = aperture;

  const ExposureChoices iso = ExposureChoicesOf(camera, CameraSetting::kIso);
  EXPECT_EQ(iso.values, (std::vector<std::string>{"100", "200"}));
  EXPECT_EQ(iso.unavailable, "");
  ASSERT_TRUE(iso.state);
  EXPECT_EQ(iso.state->choices.size(), 4u);  // the camera's whole list stays for `camera info`
  EXPECT_EQ(ExposureChoiceNumber(iso, "200"), 200);
  EXPECT_EQ(ExposureChoiceNumber(iso, ""), 0);  // leave the camera's
  try {
    ExposureChoiceNumber(iso, "Auto");
    FAIL() << "expected invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_EQ(std::string(error.what()), "ISO 'Auto' is not one of the camera's values: 100, 200");
  }

  const ExposureChoices range = ExposureChoicesOf(camera, CameraSetting::kShutter);
  EXPECT_TRUE(range.values.empty());
  EXPECT_THAT(range.unavailable, HasSubstr("shutter speed as a number from 0.001 to 30"));
  EXPECT_THROW(ExposureChoiceNumber(range, "1/125"), std::invalid_argument);

  const ExposureChoices read_only = ExposureChoicesOf(camera, CameraSetting::kAperture);
  EXPECT_TRUE(read_only.values.empty());
  EXPECT_THAT(read_only.unavailable, StartsWith("aperture is read-only on this camera"));

  camera.states[int(CameraSetting::kAperture)].reset();
  EXPECT_EQ(ExposureChoicesOf(camera, CameraSetting::kAperture).unavailable, "this camera has no aperture setting");
  camera.failure = CameraErrorKind::kBusy;
  const ExposureChoices busy = ExposureChoicesOf(camera, CameraSetting::kAperture);
  EXPECT_FALSE(busy.state);
  EXPECT_THAT(busy.unavailable, StartsWith("the camera did not say its aperture (camera stated: no such setting)"));
}

TEST(ExposureChoices, NumbersGoToTheirField) {
  ExposureSettings settings;
  SetExposureValue(&settings, CameraSetting::kShutter, 0.008);
  SetExposureValue(&settings, CameraSetting::kAperture, 5.6);
  EXPECT_EQ(settings.iso, 0);
  EXPECT_EQ(settings.exposure_time_s, 0.008);
  EXPECT_EQ(settings.f_number, 5.6);
  EXPECT_EQ(ExposureValue(settings, CameraSetting::kShutter), 0.008);
}

TEST(RawFileNames, ExtensionsAreCaseInsensitive) {
  EXPECT_TRUE(IsRawFileName("DSC_0001.NEF"));
  EXPECT_TRUE(IsRawFileName("frame.dng"));
  EXPECT_FALSE(IsRawFileName("DSC_0001.JPG"));
  EXPECT_FALSE(IsRawFileName("nef"));
  EXPECT_EQ(LowerCaseExtension("/store/DCIM/DSC_0001.NEF"), ".nef");
  EXPECT_EQ(LowerCaseExtension("folder.d/file"), "");
}

TEST(NaturalLess, OrdersNumbersByValue) {
  std::vector<std::string> names = {"led_10.dng", "LED_2.dng", "dark.dng", "led_1.dng", "led_02b.dng"};
  std::sort(names.begin(), names.end(), NaturalLess);
  EXPECT_EQ(names, (std::vector<std::string>{"dark.dng", "led_1.dng", "LED_2.dng", "led_02b.dng", "led_10.dng"}));
}

TEST(CameraError, KindNamesAreDistinct) {
  EXPECT_STREQ(CameraErrorKindName(CameraErrorKind::kClaimed), "claimed by another program");
  EXPECT_STREQ(CameraErrorKindName(CameraErrorKind::kWrongMode), "wrong mode");
  EXPECT_STREQ(CameraSettingName(CameraSetting::kShutter), "shutter speed");
}

}  // namespace
}  // namespace scanbench
