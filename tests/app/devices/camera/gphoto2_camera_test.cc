// The libgphoto2 backend without a camera: the no-camera error path, and
// downloads through libgphoto2's own "Directory Browse" driver, which serves
// a folder on disk as a camera (port "disk:/folder").
#include "app/devices/camera/gphoto2_camera.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/devices/camera/device_discovery.h"
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
using ::testing::Not;
using ::testing::StartsWith;

// These tests expect a machine without a camera (CI, a container).
bool CameraAttached() { return !DetectCameras().empty(); }

CameraError OpenError(const GPhotoCameraOptions& options) {
  try {
    GPhotoCamera camera(options);
  } catch (const CameraError& error) {
    return error;
  }
  ADD_FAILURE() << "opening the camera succeeded";
  return CameraError(CameraErrorKind::kIo, "", "");
}

TEST(GPhotoCamera, NoCameraAttachedIsAClearNotFound) {
  if (CameraAttached()) GTEST_SKIP() << "a camera is attached";
  const CameraError error = OpenError({});
  EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound);
  EXPECT_THAT(error.what(), AllOf(StartsWith("camera (autodetect): no camera found"),
                                  HasSubstr("connect the camera by USB and switch it on")));
}

TEST(GPhotoCamera, NamedCameraNotAttachedSaysWhatWasFound) {
  if (CameraAttached()) GTEST_SKIP() << "a camera is attached";
  GPhotoCameraOptions options;
  options.model = "Nikon DSC D5100 (PTP mode)";
  const CameraError error = OpenError(options);
  EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound);
  EXPECT_THAT(error.what(), AllOf(StartsWith("camera Nikon DSC D5100 (PTP mode) (autodetect): "),
                                  HasSubstr("not found by libgphoto2's autodetect (it found: none)")));
}

TEST(GPhotoCamera, NamedCameraOnAnAbsentUsbPortIsNotFound) {
  GPhotoCameraOptions options;
  options.model = "Nikon DSC D5100 (PTP mode)";
  options.port = "usb:250,127";
  const CameraError error = OpenError(options);
  EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound) << error.what();
  EXPECT_THAT(error.what(), StartsWith("camera Nikon DSC D5100 (PTP mode) on usb:250,127: "));
}

TEST(GPhotoCamera, UnknownModelIsNotSupported) {
  GPhotoCameraOptions options;
  options.model = "Nikon DSC D9999 (no such camera)";
  options.port = "usb:";
  const CameraError error = OpenError(options);
  EXPECT_EQ(error.kind(), CameraErrorKind::kNotSupported);
  EXPECT_THAT(error.what(), HasSubstr("libgphoto2 knows no camera model 'Nikon DSC D9999 (no such camera)'"));
}

TEST(GPhotoCamera, OptionsAreChecked) {
  GPhotoCameraOptions options;
  options.event_timeout_ms = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = {};
  options.busy_timeout_ms = -1;
  EXPECT_THROW(GPhotoCamera camera(options), std::invalid_argument);
}

RawImage SmallRaw(uint16_t seed) {
  RawImage raw;
  raw.mosaic = ImageU16(40, 30, 1);
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) raw.mosaic(x, y) = static_cast<uint16_t>(64 + (x * 7 + y * 13 + seed) % 3000);
  }
  raw.black_level = {64, 64, 64, 64};
  raw.white_level = 4095;
  return raw;
}

class DirectoryBrowse : public ::testing::Test {
 protected:
  void SetUp() override {
    WriteDng(folder_ / "frame_01.dng", SmallRaw(1));
    WriteDng(folder_ / "frame_02.DNG", SmallRaw(2));
    WriteFileAtomic(folder_ / "notes.txt", std::string_view("not an image"), OverwritePolicy::kRefuse);
    std::filesystem::create_directory(folder_ / "DCIM");
    WriteDng(folder_ / "DCIM" / "DSC_0001.dng", SmallRaw(3));
    options_.model = "Directory Browse";
    options_.port = "disk:" + folder_.path().string();
  }

  testing::TemporaryFolder folder_;
  GPhotoCameraOptions options_;
};

TEST_F(DirectoryBrowse, ListsDownloadsAndDeletes) {
  GPhotoCamera camera(options_);
  EXPECT_EQ(camera.description(), "camera Directory Browse on " + options_.port);
  const CameraDeviceInfo info = camera.Info();
  EXPECT_EQ(info.backend, "gphoto2");
  EXPECT_EQ(info.model, "Directory Browse");
  EXPECT_EQ(info.port, options_.port);

  EXPECT_THAT(camera.ListFolders("/"), ElementsAre("DCIM"));
  EXPECT_THAT(camera.ListFiles("/"), ElementsAre("frame_01.dng", "frame_02.DNG"));  // notes.txt is no image
  EXPECT_THAT(camera.ListFiles("/DCIM"), ElementsAre("DSC_0001.dng"));

  const CapturedFrame frame = camera.Download("/", "frame_02.DNG");
  EXPECT_EQ(frame.bytes, ReadFileBytes(folder_ / "frame_02.DNG"));
  EXPECT_EQ(frame.extension, ".dng");
  EXPECT_EQ(frame.source_name, "frame_02.DNG");
  const RawImage decoded = DecodeRaw(frame.bytes, frame.source_name);
  EXPECT_EQ(decoded.width(), 40);
  EXPECT_EQ(decoded.mosaic(5, 7), SmallRaw(2).mosaic(5, 7));

  const CapturedFrame nested = camera.Download("/DCIM", "DSC_0001.dng");
  EXPECT_EQ(nested.bytes, ReadFileBytes(folder_ / "DCIM" / "DSC_0001.dng"));

  camera.Delete("/", "frame_01.dng");
  EXPECT_FALSE(std::filesystem::exists(folder_ / "frame_01.dng"));
  EXPECT_THAT(camera.ListFiles("/"), ElementsAre("frame_02.DNG"));
}

TEST_F(DirectoryBrowse, MissingFileErrorNamesThePath) {
  GPhotoCamera camera(options_);
  try {
    camera.Download("/DCIM", "DSC_0042.NEF");
    FAIL() << "expected a CameraError";
  } catch (const CameraError& error) {
    EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound);
    EXPECT_THAT(error.what(), AllOf(StartsWith(camera.description() + ": download /DCIM/DSC_0042.NEF failed"),
                                    HasSubstr("no such file")));
  }
}

TEST_F(DirectoryBrowse, NoCaptureNoSettingsNoLiveViewAreClearErrors) {
  GPhotoCamera camera(options_);
  const auto kind_of = [](auto&& call) {
    try {
      call();
    } catch (const CameraError& error) {
      EXPECT_THAT(std::string(error.what()), Not(IsEmpty()));
      return error.kind();
    }
    return CameraErrorKind::kIo;
  };
  EXPECT_EQ(kind_of([&] { camera.Capture(); }), CameraErrorKind::kNotSupported);
  EXPECT_EQ(kind_of([&] { camera.CapturePreview(); }), CameraErrorKind::kNotSupported);
  EXPECT_EQ(kind_of([&] { camera.GetSetting(CameraSetting::kIso); }), CameraErrorKind::kNotSupported);
  EXPECT_EQ(kind_of([&] { camera.SetIso(100); }), CameraErrorKind::kNotSupported);
  EXPECT_THAT(camera.CheckReady(), ElementsAre(HasSubstr("cannot capture remotely")));
  EXPECT_THAT(camera.DrainEvents(std::chrono::milliseconds(10)), IsEmpty());  // the driver has no events
  const ExposureSettings exposure = camera.CurrentExposure();  // unknown, not an error
  EXPECT_EQ(exposure.iso, 0);
  EXPECT_THAT(camera.DescribeConfiguration(), ElementsAre(HasSubstr("no configuration")));
  camera.StopPreview();
  camera.Reconnect();
  EXPECT_THAT(camera.ListFiles("/"), ElementsAre("frame_01.dng", "frame_02.DNG"));
}

TEST_F(DirectoryBrowse, DirectoryBrowseNeedsItsPort) {
  GPhotoCameraOptions options;
  options.model = "Directory Browse";
  const CameraError error = OpenError(options);
  EXPECT_EQ(error.kind(), CameraErrorKind::kNotFound);
  EXPECT_THAT(error.what(), HasSubstr("disk:/folder"));
}

}  // namespace
}  // namespace scanbench
