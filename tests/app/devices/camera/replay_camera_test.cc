#include "app/devices/camera/replay_camera.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/io/dng_writer.h"
#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::StartsWith;

RawImage Raw(int width, int height, uint16_t level) {
  RawImage raw;
  raw.mosaic = ImageU16(width, height, 1, level);
  raw.black_level = {100, 100, 100, 100};
  raw.white_level = 4095;
  return raw;
}

DngMetadata Metadata(double exposure_time_s) {
  DngMetadata metadata;
  metadata.make = "NIKON CORPORATION";
  metadata.model = "NIKON D5100";
  metadata.serial = "3105553";
  metadata.exposure_time_s = exposure_time_s;
  metadata.iso = 200;
  metadata.f_number = 5.6;
  return metadata;
}

std::vector<std::string> Names(const std::vector<std::filesystem::path>& files) {
  std::vector<std::string> names;
  for (const auto& file : files) names.push_back(file.filename().string());
  return names;
}

class ReplayCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteDng(folder_ / "led_10.dng", Raw(40, 30, 1010), Metadata(1.0 / 125));
    WriteDng(folder_ / "LED_2.DNG", Raw(40, 30, 1002), Metadata(1.0 / 125));
    WriteDng(folder_ / "dark.dng", Raw(40, 30, 100), Metadata(1.0 / 60));
    WriteFileAtomic(folder_ / "notes.txt", std::string_view("bench log"), OverwritePolicy::kRefuse);
    WriteDng(folder_ / ".hidden.dng", Raw(40, 30, 7));
    options_.folder = folder_.path();
  }
  testing::TemporaryFolder folder_;
  ReplayCameraOptions options_;
};

TEST_F(ReplayCameraTest, ServesRawFilesInNaturalNameOrder) {
  ReplayCamera camera(options_);
  EXPECT_THAT(Names(camera.files()), ElementsAre("dark.dng", "LED_2.DNG", "led_10.dng"));
  EXPECT_EQ(camera.description(), "replay camera on " + folder_.path().string());

  const CameraDeviceInfo info = camera.Info();
  EXPECT_EQ(info.backend, "replay");
  EXPECT_EQ(info.model, "D5100");  // as LibRaw normalises it
  EXPECT_EQ(info.serial, "3105553");

  // Settings: the next file's metadata until one is set.
  EXPECT_EQ(camera.GetSetting(CameraSetting::kShutter).current, "1/60");
  EXPECT_EQ(camera.GetSetting(CameraSetting::kAperture).current, "f/5.6");

  const std::vector<uint16_t> levels = {100, 1002, 1010};
  for (size_t i = 0; i < levels.size(); ++i) {
    EXPECT_THAT(camera.CheckReady(), IsEmpty());
    const CapturedFrame frame = camera.Capture();
    EXPECT_EQ(frame.source_name, camera.files()[i].filename().string());
    EXPECT_EQ(frame.extension, ".dng");
    EXPECT_EQ(frame.bytes, ReadFileBytes(camera.files()[i]));
    EXPECT_EQ(DecodeRaw(frame.bytes, frame.source_name).mosaic(3, 3), levels[i]);
    EXPECT_EQ(frame.settings.iso, 200);
    EXPECT_NEAR(frame.settings.exposure_time_s, i == 0 ? 1.0 / 60 : 1.0 / 125, 1e-9);
  }
  EXPECT_THAT(camera.CheckReady(), ElementsAre(HasSubstr("all 3 files have been served")));
  try {
    camera.Capture();
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kExhausted);
    EXPECT_THAT(error.what(), HasSubstr("the last was led_10.dng"));
  }
  const std::vector<CameraEvent> events = camera.DrainEvents(std::chrono::milliseconds(0));
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[1].type, CameraEvent::Type::kFileAdded);
  EXPECT_THAT(events[1].detail, HasSubstr("LED_2.DNG"));

  camera.Rewind();
  EXPECT_EQ(camera.Capture().source_name, "dark.dng");
}

TEST_F(ReplayCameraTest, LoopsWhenAsked) {
  options_.loop = true;
  ReplayCamera camera(options_);
  for (int i = 0; i < 3; ++i) camera.Capture();
  EXPECT_EQ(camera.Capture().source_name, "dark.dng");
}

TEST_F(ReplayCameraTest, ABadFileIsNamedAndSkipped) {
  WriteFileAtomic(folder_ / "led_05.nef", std::string_view("this is not a NEF file at all"), OverwritePolicy::kRefuse);
  ReplayCamera camera(options_);
  ASSERT_THAT(Names(camera.files()), ElementsAre("dark.dng", "LED_2.DNG", "led_05.nef", "led_10.dng"));
  camera.Capture();
  camera.Capture();
  try {
    camera.Capture();
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kBadFile);
    EXPECT_THAT(error.what(), AllOf(StartsWith(camera.description() + ": frame 3 of 4: "),
                                    HasSubstr((folder_ / "led_05.nef").string())));
  }
  EXPECT_EQ(camera.Capture().source_name, "led_10.dng");

  options_.validate = false;  // then it is served as is
  ReplayCamera unchecked(options_);
  for (int i = 0; i < 2; ++i) unchecked.Capture();
  EXPECT_EQ(unchecked.Capture().source_name, "led_05.nef");
}

TEST_F(ReplayCameraTest, AFrameOfAnotherSizeIsNamed) {
  WriteDng(folder_ / "led_03.dng", Raw(44, 30, 1003), Metadata(1.0 / 125));
  ReplayCamera camera(options_);
  camera.Capture();
  camera.Capture();
  try {
    camera.Capture();
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kBadFile);
    EXPECT_THAT(error.what(), AllOf(HasSubstr("led_03.dng: image is 44x30 but the first replayed frame was 40x30")));
  }
}

TEST_F(ReplayCameraTest, MissingOrEmptyFolderIsNotFound) {
  options_.folder = folder_ / "absent";
  try {
    ReplayCamera camera(options_);
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound);
    EXPECT_THAT(error.what(), HasSubstr("absent does not exist"));
  }
  std::filesystem::create_directory(folder_ / "empty");
  options_.folder = folder_ / "empty";
  try {
    ReplayCamera camera(options_);
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound);
    EXPECT_THAT(error.what(), HasSubstr("no RAW file (.nef .nrw .dng"));
  }
  options_.folder.clear();
  EXPECT_THROW(ReplayCamera camera(options_), std::invalid_argument);
}

TEST_F(ReplayCameraTest, SettingsAreRecordedAndPreviewIsAnImage) {
  options_.extensions = {".DNG"};
  ReplayCamera camera(options_);
  camera.SetSetting(CameraSetting::kIso, "800");
  EXPECT_EQ(camera.GetSetting(CameraSetting::kIso).current, "800");
  EXPECT_THROW(camera.SetSetting(CameraSetting::kShutter, "Bulb"), CameraError);
  const PreviewFrame preview = camera.CapturePreview();
  EXPECT_EQ(preview.mime_type, "image/x-portable-pixmap");
  ASSERT_GT(preview.bytes.size(), 3u);
  EXPECT_EQ(std::string(preview.bytes.begin(), preview.bytes.begin() + 3), "P6\n");
}

}  // namespace
}  // namespace scanbench
