// Settings mapping on libgphoto2 widget trees built in memory with
// gp_widget_new, shaped like the tree libgphoto2 2.5 gives for a Nikon D5100.
#include <gphoto2/gphoto2.h>

#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/devices/camera/gphoto2_support.h"

namespace scanbench {
namespace {

using namespace gphoto2_support;
using ::testing::AllOf;
using ::testing::Contains;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::StartsWith;

const char kCamera[] = "camera Nikon DSC D5100 (PTP mode) on usb:001,004";

CameraWidget* Add(CameraWidget* parent, CameraWidgetType type, const char* name, const char* label) {
  CameraWidget* widget = nullptr;
  EXPECT_EQ(gp_widget_new(type, label, &widget), GP_OK);
  gp_widget_set_name(widget, name);
  gp_widget_append(parent, widget);
  return widget;
}

CameraWidget* Radio(CameraWidget* parent, const char* name, const char* label, const std::vector<std::string>& choices,
                    const std::string& value, bool read_only = false) {
  CameraWidget* widget = Add(parent, GP_WIDGET_RADIO, name, label);
  for (const std::string& choice : choices) gp_widget_add_choice(widget, choice.c_str());
  gp_widget_set_value(widget, value.c_str());
  gp_widget_set_readonly(widget, read_only ? 1 : 0);
  gp_widget_set_changed(widget, 0);
  return widget;
}

CameraWidget* Text(CameraWidget* parent, const char* name, const char* label, const char* value) {
  CameraWidget* widget = Add(parent, GP_WIDGET_TEXT, name, label);
  gp_widget_set_value(widget, value);
  gp_widget_set_readonly(widget, 1);
  return widget;
}

const std::vector<std::string> kIsoChoices = {"100",  "125",  "160",  "200",  "250",  "320",  "400",
                                              "500",  "640",  "800",  "1000", "1250", "1600", "2000",
                                              "2500", "3200", "4000", "5000", "6400", "12800", "25600"};
const std::vector<std::string> kNikonShutterChoices = {"30",    "15",    "8",     "4",     "2",     "1",
                                                       "10/13", "1/2",   "1/4",   "1/8",   "1/15",  "1/30",
                                                       "1/60",  "1/80",  "1/100", "1/125", "1/250", "1/500",
                                                       "1/1000", "1/2000", "1/4000", "Bulb"};
const std::vector<std::string> kGenericShutterChoices = {"30.0000s", "1.0000s", "0.0167s", "0.0125s",
                                                         "0.0100s",  "0.0080s", "0.0040s", "0.0003s"};
const std::vector<std::string> kApertureChoices = {"f/1.8", "f/2", "f/2.8", "f/4", "f/5.6", "f/8", "f/11", "f/16"};

struct TreeSpec {
  std::string expprogram = "A";
  std::string focusmode = "AF-S";
  std::string focusmode2 = "AF-A";
  std::string imagequality = "NEF+Fine";
  std::vector<std::string> quality_choices = {"JPEG Basic", "JPEG Normal", "JPEG Fine", "NEF (Raw)",
                                              "NEF+Basic",  "NEF+Normal",  "NEF+Fine"};
  std::string autoiso = "On";
  bool nikon_shutter = true;  // the D5100 tree has shutterspeed2 beside the generic shutterspeed
};

WidgetPtr MakeD5100Tree(const TreeSpec& spec = {}) {
  CameraWidget* root = nullptr;
  gp_widget_new(GP_WIDGET_WINDOW, "Camera and Driver Configuration", &root);
  gp_widget_set_name(root, "main");
  WidgetPtr tree(root);

  CameraWidget* actions = Add(root, GP_WIDGET_SECTION, "actions", "Camera Actions");
  CameraWidget* viewfinder = Add(actions, GP_WIDGET_TOGGLE, "viewfinder", "Nikon Viewfinder");
  const int off = 0;
  gp_widget_set_value(viewfinder, &off);
  Add(actions, GP_WIDGET_BUTTON, "autofocusdrive", "Drive Nikon DSLR Autofocus");

  CameraWidget* settings = Add(root, GP_WIDGET_SECTION, "settings", "Camera Settings");
  Radio(settings, "capturetarget", "Capture Target", {"Internal RAM", "Memory card"}, "Memory card");
  CameraWidget* range = Add(settings, GP_WIDGET_RANGE, "exposurecompensation2", "Exposure Compensation");
  gp_widget_set_range(range, -5, 5, 0.3333f);
  const float zero = 0;
  gp_widget_set_value(range, &zero);

  CameraWidget* status = Add(root, GP_WIDGET_SECTION, "status", "Camera Status Information");
  Text(status, "serialnumber", "Serial Number", "0000000000000000000000003105553");
  Text(status, "manufacturer", "Camera Manufacturer", "Nikon Corporation");
  Text(status, "cameramodel", "Camera Model", "D5100");
  Text(status, "deviceversion", "Device Version", "V1.01");
  Text(status, "lensname", "Lens Name", "AF-S Nikkor 85mm f/1.8G");

  CameraWidget* image = Add(root, GP_WIDGET_SECTION, "imgsettings", "Image Settings");
  Radio(image, "iso", "ISO Speed", kIsoChoices, "400");
  Radio(image, "autoiso", "Auto ISO", {"On", "Off"}, spec.autoiso);

  CameraWidget* capture = Add(root, GP_WIDGET_SECTION, "capturesettings", "Capture Settings");
  Radio(capture, "f-number", "F-Number", kApertureChoices, "f/8");
  Radio(capture, "imagequality", "Image Quality", spec.quality_choices, spec.imagequality);
  Radio(capture, "focusmode", "Focus Mode", {"Manual", "Automatic", "AF-S", "AF-C", "AF-A"}, spec.focusmode);
  Radio(capture, "expprogram", "Exposure Program",
        {"M", "P", "A", "S", "Auto", "Portrait", "Landscape", "Macro", "Sports", "No Flash", "Children", "Scene",
         "Effects"},
        spec.expprogram, /*read_only=*/true);
  Radio(capture, "focusmode2", "Focus Mode 2", {"AF-S", "AF-C", "AF-A", "MF (fixed)", "MF (selection)"},
        spec.focusmode2);
  Radio(capture, "shutterspeed", "Shutter Speed", kGenericShutterChoices, "0.0167s");
  if (spec.nikon_shutter) Radio(capture, "shutterspeed2", "Shutter Speed 2", kNikonShutterChoices, "1/60");
  return tree;
}

std::string Value(CameraWidget* root, const char* name) { return ReadWidget(FindWidget(root, {name})).value; }

TEST(GphotoWidgets, ReadsTheThreeSettingsPreferringNikonsExactShutter) {
  WidgetPtr tree = MakeD5100Tree();
  const std::optional<CameraSettingState> shutter = ReadSetting(tree.get(), CameraSetting::kShutter);
  ASSERT_TRUE(shutter);
  EXPECT_EQ(shutter->current, "1/60");
  EXPECT_EQ(shutter->source, "widget shutterspeed2");
  EXPECT_EQ(shutter->choices, kNikonShutterChoices);

  const ExposureSettings exposure = ReadExposure(tree.get());
  EXPECT_EQ(exposure.iso, 400);
  EXPECT_DOUBLE_EQ(exposure.exposure_time_s, 1.0 / 60);
  EXPECT_EQ(exposure.f_number, 8);
}

TEST(GphotoWidgets, AppliesSettingsByTextOrNumber) {
  WidgetPtr tree = MakeD5100Tree();
  CameraWidget* widget = ApplySetting(tree.get(), CameraSetting::kShutter, "0.008", kCamera);
  EXPECT_EQ(ReadWidget(widget).name, "shutterspeed2");
  EXPECT_EQ(Value(tree.get(), "shutterspeed2"), "1/125");
  EXPECT_EQ(gp_widget_changed(widget), 1);  // what gp_camera_set_config will push

  ApplySetting(tree.get(), CameraSetting::kIso, "ISO 100", kCamera);
  EXPECT_EQ(Value(tree.get(), "iso"), "100");
  ApplySetting(tree.get(), CameraSetting::kAperture, "5.6", kCamera);
  EXPECT_EQ(Value(tree.get(), "f-number"), "f/5.6");
}

TEST(GphotoWidgets, GenericShutterWidgetWithRoundedSeconds) {
  TreeSpec spec;
  spec.nikon_shutter = false;
  WidgetPtr tree = MakeD5100Tree(spec);
  ApplySetting(tree.get(), CameraSetting::kShutter, "1/125", kCamera);
  EXPECT_EQ(Value(tree.get(), "shutterspeed"), "0.0080s");
  ApplySetting(tree.get(), CameraSetting::kShutter, "1/4000", kCamera);
  EXPECT_EQ(Value(tree.get(), "shutterspeed"), "0.0003s");
}

TEST(GphotoWidgets, UnsupportedValueOrSettingNamesCameraValueAndChoices) {
  WidgetPtr tree = MakeD5100Tree();
  try {
    ApplySetting(tree.get(), CameraSetting::kIso, "80", kCamera);  // a third of a stop below 100
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kNotSupported);
    EXPECT_THAT(error.what(), AllOf(StartsWith(kCamera), HasSubstr("ISO '80'"), HasSubstr("nearest: 100"),
                                    HasSubstr("widget iso"), HasSubstr("100, 125, 160")));
  }
  EXPECT_EQ(Value(tree.get(), "iso"), "400");  // unchanged
  ApplySetting(tree.get(), CameraSetting::kIso, "90", kCamera);  // within a sixth of a stop
  EXPECT_EQ(Value(tree.get(), "iso"), "100");

  CameraWidget* root = nullptr;
  gp_widget_new(GP_WIDGET_WINDOW, "Directory Browse", &root);
  WidgetPtr bare(root);
  try {
    ApplySetting(bare.get(), CameraSetting::kAperture, "f/8", kCamera);
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kNotSupported);
    EXPECT_THAT(error.what(), HasSubstr("has no aperture setting (no widget named f-number or aperture"));
  }
  EXPECT_FALSE(ReadSetting(bare.get(), CameraSetting::kIso));
}

TEST(GphotoWidgets, SetWidgetTextChecksEachWidgetType) {
  WidgetPtr tree = MakeD5100Tree();
  CameraWidget* viewfinder = FindWidget(tree.get(), {"viewfinder"});
  SetWidgetText(viewfinder, "on", kCamera);
  EXPECT_EQ(ReadWidget(viewfinder).value, "1");
  SetWidgetText(viewfinder, "0", kCamera);
  EXPECT_EQ(ReadWidget(viewfinder).value, "0");
  EXPECT_THROW(SetWidgetText(viewfinder, "maybe", kCamera), CameraError);

  CameraWidget* range = FindWidget(tree.get(), {"exposurecompensation2"});
  SetWidgetText(range, "-1.5", kCamera);
  EXPECT_EQ(ReadWidget(range).value, "-1.5");
  EXPECT_THROW(SetWidgetText(range, "7", kCamera), CameraError);

  try {
    SetWidgetText(FindWidget(tree.get(), {"capturetarget"}), "Cloud", kCamera);
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_THAT(error.what(), AllOf(HasSubstr("'capturetarget'"), HasSubstr("'Cloud'"),
                                    HasSubstr("Internal RAM, Memory card")));
  }
  try {
    SetWidgetText(FindWidget(tree.get(), {"expprogram"}), "M", kCamera);
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_THAT(error.what(), AllOf(HasSubstr("'expprogram'"), HasSubstr("read-only")));
  }
  EXPECT_THROW(SetWidgetText(FindWidget(tree.get(), {"autofocusdrive"}), "1", kCamera), CameraError);
}

TEST(GphotoWidgets, PrepareForCaptureSelectsRamRawOnlyAndAutoIsoOff) {
  WidgetPtr tree = MakeD5100Tree();
  const std::vector<std::string> changed = PrepareForCapture(tree.get(), GPhotoCameraOptions{}, kCamera);
  EXPECT_THAT(changed, ElementsAre("capturetarget", "autoiso", "imagequality"));
  EXPECT_EQ(Value(tree.get(), "capturetarget"), "Internal RAM");
  EXPECT_EQ(Value(tree.get(), "autoiso"), "Off");
  EXPECT_EQ(Value(tree.get(), "imagequality"), "NEF (Raw)");
  EXPECT_THAT(PrepareForCapture(tree.get(), GPhotoCameraOptions{}, kCamera), IsEmpty());

  GPhotoCameraOptions to_card;
  to_card.capture_to_ram = false;
  to_card.force_raw_only = false;
  to_card.disable_auto_iso = false;
  WidgetPtr other = MakeD5100Tree();
  EXPECT_THAT(PrepareForCapture(other.get(), to_card, kCamera), IsEmpty());  // already on the card
  EXPECT_EQ(Value(other.get(), "imagequality"), "NEF+Fine");
  EXPECT_EQ(Value(other.get(), "autoiso"), "On");
}

TEST(GphotoWidgets, ReadinessNamesModeDialAndFocusOfTheD5100) {
  WidgetPtr tree = MakeD5100Tree();
  PrepareForCapture(tree.get(), GPhotoCameraOptions{}, kCamera);
  const std::vector<std::string> problems = ReadinessProblems(tree.get(), GPhotoCameraOptions{});
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_THAT(problems[0], AllOf(HasSubstr("mode dial is on 'A'"), HasSubstr("turn it to M")));
  EXPECT_THAT(problems[1], AllOf(HasSubstr("focusmode 'AF-S'"), HasSubstr("focusmode2 'AF-A'"),
                                 HasSubstr("switch to M")));

  GPhotoCameraOptions lenient;
  lenient.require_manual_exposure = false;
  lenient.require_manual_focus = false;
  EXPECT_THAT(ReadinessProblems(tree.get(), lenient), IsEmpty());
}

TEST(GphotoWidgets, ReadyInManualModeWithManualFocus) {
  TreeSpec spec;
  spec.expprogram = "M";
  spec.focusmode = "AF-S";
  spec.focusmode2 = "MF (fixed)";  // the AF-mode menu on MF counts as manual
  spec.autoiso = "Off";
  WidgetPtr tree = MakeD5100Tree(spec);
  EXPECT_THAT(ReadinessProblems(tree.get(), GPhotoCameraOptions{}), IsEmpty());

  spec.focusmode = "Manual";  // the lens switch on M
  spec.focusmode2 = "AF-S";
  WidgetPtr lens_switch = MakeD5100Tree(spec);
  EXPECT_THAT(ReadinessProblems(lens_switch.get(), GPhotoCameraOptions{}), IsEmpty());
}

TEST(GphotoWidgets, JpegOnlyQualityWithoutRawChoiceIsAProblem) {
  TreeSpec spec;
  spec.expprogram = "M";
  spec.focusmode = "Manual";
  spec.autoiso = "Off";
  spec.imagequality = "JPEG Fine";
  spec.quality_choices = {"JPEG Basic", "JPEG Normal", "JPEG Fine"};
  WidgetPtr tree = MakeD5100Tree(spec);
  EXPECT_THAT(PrepareForCapture(tree.get(), GPhotoCameraOptions{}, kCamera), ElementsAre("capturetarget"));
  EXPECT_THAT(ReadinessProblems(tree.get(), GPhotoCameraOptions{}),
              ElementsAre(AllOf(HasSubstr("image quality is 'JPEG Fine'"), HasSubstr("RAW (NEF)"))));
}

TEST(GphotoWidgets, InfoAndDescription) {
  WidgetPtr tree = MakeD5100Tree();
  CameraDeviceInfo info;
  FillInfo(tree.get(), &info);
  EXPECT_EQ(info.make, "Nikon Corporation");
  EXPECT_EQ(info.model, "D5100");
  EXPECT_EQ(info.serial, "0000000000000000000000003105553");
  EXPECT_EQ(info.lens, "AF-S Nikkor 85mm f/1.8G");
  EXPECT_EQ(info.firmware, "V1.01");

  const std::vector<std::string> lines = DescribeTree(tree.get());
  EXPECT_THAT(lines, Contains(StartsWith("/main/capturesettings/shutterspeed2 = 1/60 [30, 15, 8")));
  EXPECT_THAT(lines, Contains("/main/capturesettings/expprogram = A [M, P, A, S, Auto, Portrait, Landscape, Macro, "
                              "Sports, No Flash, Children, Scene, Effects] (read-only)"));
  EXPECT_THAT(lines, Contains("/main/settings/exposurecompensation2 = 0 [-5 .. 5]"));
  for (const std::string& line : lines) EXPECT_THAT(line, ::testing::Not(HasSubstr("autofocusdrive")));
}

TEST(GphotoErrors, EveryResultBecomesAClearMessage) {
  const auto error = [](int result, const std::string& text = "", Phase phase = Phase::kSession) {
    return ErrorFromResult(result, kCamera, "capture", text, phase);
  };
  const CameraError claimed = error(GP_ERROR_IO_USB_CLAIM, "Could not claim the USB device", Phase::kOpen);
  EXPECT_EQ(claimed.kind(), CameraErrorKind::kClaimed);
  EXPECT_THAT(claimed.what(), AllOf(StartsWith(std::string(kCamera) + ": capture failed: "), HasSubstr("gvfs"),
                                    HasSubstr("gio mount -s gphoto2"), HasSubstr("gvfs-gphoto2-volume-monitor"),
                                    HasSubstr("libgphoto2: Could not claim the USB device; error -53")));

  EXPECT_EQ(error(GP_ERROR_CAMERA_BUSY).kind(), CameraErrorKind::kBusy);
  EXPECT_EQ(error(GP_ERROR_MODEL_NOT_FOUND).kind(), CameraErrorKind::kNotFound);
  EXPECT_EQ(error(GP_ERROR_NOT_SUPPORTED).kind(), CameraErrorKind::kNotSupported);
  EXPECT_EQ(error(GP_ERROR_TIMEOUT).kind(), CameraErrorKind::kTimeout);
  EXPECT_EQ(error(GP_ERROR_IO_USB_FIND, "", Phase::kOpen).kind(), CameraErrorKind::kNotFound);
  EXPECT_EQ(error(GP_ERROR_IO_USB_FIND).kind(), CameraErrorKind::kDisconnected);
  EXPECT_EQ(error(GP_ERROR_IO_READ).kind(), CameraErrorKind::kDisconnected);
  EXPECT_EQ(error(GP_ERROR_BAD_PARAMETERS, "", Phase::kOpen).kind(), CameraErrorKind::kNotFound);
  EXPECT_EQ(error(GP_ERROR_CAMERA_ERROR, "Out of Focus").kind(), CameraErrorKind::kWrongMode);
  EXPECT_EQ(error(-12345).kind(), CameraErrorKind::kIo);

  const CameraError denied = error(GP_ERROR_IO, "Could not open USB device (Access denied)", Phase::kOpen);
  EXPECT_EQ(denied.kind(), CameraErrorKind::kPermissionDenied);
  EXPECT_THAT(denied.what(), HasSubstr("plugdev"));
}

}  // namespace
}  // namespace scanbench
