// The capture sequencer with the firmware running in simavr, the host LED
// controller talking to it over a pty exactly as to a real Uno, and the
// simulated camera rendering whichever LED the simulated pins light.
#include "app/controllers/capture_controller.h"
#include "app/controllers/progress_plans.h"

#include <sys/resource.h>
#include <unistd.h>

#include <csignal>

#include <cmath>
#include <fstream>
#include <functional>
#include <optional>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/devices/camera/simulated_camera.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/simulated_led_board.h"
#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "app/session/session.h"
#include "calibration/raw_develop.h"
#include "tests/util/simulated_bench.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using testing::MakeSimulatedBench;
using testing::SimulatedBench;
using testing::TemporaryFolder;

constexpr int kWidth = 320;
constexpr int kHeight = 212;

// Forwards to a real camera; `before_capture(n)` runs before capture n (from
// 0) and may throw or stall, as a real camera or cable would.
class FaultyCamera : public Camera {
 public:
  FaultyCamera(Camera* inner, std::function<void(int)> before_capture)
      : inner_(inner), before_capture_(std::move(before_capture)) {}
  std::string description() const override { return inner_->description(); }
  CameraDeviceInfo Info() override { return inner_->Info(); }
  CameraSettingState GetSetting(CameraSetting setting) override { return inner_->GetSetting(setting); }
  void SetSetting(CameraSetting setting, const std::string& value) override { inner_->SetSetting(setting, value); }
  std::vector<std::string> CheckReady() override { return inner_->CheckReady(); }
  CapturedFrame Capture() override {
    before_capture_(captures_++);
    return inner_->Capture();
  }
  PreviewFrame CapturePreview() override { return inner_->CapturePreview(); }
  void StopPreview() override { inner_->StopPreview(); }
  std::vector<CameraEvent> DrainEvents(std::chrono::milliseconds wait) override { return inner_->DrainEvents(wait); }
  void Reconnect() override { inner_->Reconnect(); }

 private:
  Camera* inner_;
  std::function<void(int)> before_capture_;
  int captures_ = 0;
};

class CaptureControllerTest : public ::testing::Test {
 protected:
  CaptureOptions Options() const {
    CaptureOptions options;
    options.sample_name = "sim twill";
    options.check_exposure = false;
    options.led_settle = std::chrono::milliseconds(0);
    return options;
  }
  CaptureOptions Resume(CaptureOptions options) const {
    options.resume = true;
    return options;
  }

  CaptureController Controller(Camera* camera, CaptureOptions options) {
    return CaptureController(session_dir(), bench_.rig->rig(), camera, bench_.lights.get(), std::move(options));
  }

  fs::path session_dir() const { return folder_ / "session"; }

  // Which LED lit a frame, judged from its pixels alone: the noise-free
  // rendering of each LED is correlated with the dark-subtracted frame.
  std::optional<int> LedSeenInFrame(const Session& session, const FrameRecord& record) const {
    const RawImage dark = DecodeRawFile(session_dir() / FindDarkFrame(session)->file);
    const RawImage raw = DecodeRawFile(session_dir() / record.file);
    const ImageF developed = DevelopRaw(raw, &dark, RawDevelopOptions()).rgb;
    double brightest = 0;
    for (size_t i = 1; i < developed.size(); i += 3) brightest = std::max(brightest, double(developed.data()[i]));
    if (brightest < 0.02) return std::nullopt;  // dark: nothing lit
    const ImageF ambient = bench_.rig->RenderLinear(std::nullopt);
    std::optional<int> best;
    double best_score = -2;
    for (int k = 0; k < bench_.rig->num_leds(); ++k) {
      const ImageF expected = bench_.rig->RenderLinear(k);
      double sum_xy = 0, sum_xx = 0, sum_yy = 0;
      for (size_t i = 1; i < expected.size(); i += 3 * 5) {  // green, every fifth pixel
        const double x = expected.data()[i] - ambient.data()[i];
        const double y = developed.data()[i];
        sum_xy += x * y;
        sum_xx += x * x;
        sum_yy += y * y;
      }
      const double score = sum_xy / std::sqrt(sum_xx * sum_yy);
      if (score > best_score) {
        best_score = score;
        best = k;
      }
    }
    return best;
  }

  void ExpectEveryFrameShowsItsLed() const {
    const Session session = LoadSession(session_dir());
    ASSERT_TRUE(session.capture_complete);
    ASSERT_EQ(session.frames.size(), 11u);
    for (const FrameRecord& record : session.frames) {
      const std::optional<int> expected =
          record.kind == FrameKind::kLed ? std::optional<int>(record.led_index) : std::nullopt;
      EXPECT_EQ(LedSeenInFrame(session, record), expected) << record.file;
    }
  }

  TemporaryFolder folder_;
  // A frame that sees two LEDs is a failure of the capture's one-at-a-time switching.
  SimulatedBench bench_ = MakeSimulatedBench(kWidth, kHeight, [](const SimulatedLedBoard& board) -> std::optional<int> {
    const std::vector<int> lit = board.LitLedIndices();
    if (lit.size() > 1) ADD_FAILURE() << "two LEDs lit at once";
    return lit.empty() ? std::nullopt : std::optional<int>(lit.front());
  });
};

TEST_F(CaptureControllerTest, FullCaptureWithFirmwareInTheLoop) {
  CaptureOptions options = Options();
  options.check_exposure = true;
  CaptureController capture = Controller(bench_.camera.get(), options);
  // Issue #36 item 8: the plan names every stage reported; one bar, forward only.
  JobProgress job(CaptureProgressPlan(options, 10));
  std::vector<std::string> unplanned;
  int backwards = 0;
  capture.SetProgressCallback([&](const ProgressReport& report) {
    const double before = job.fraction();
    job.Update(report);
    backwards += job.fraction() < before;
    if (job.stage_number() == 0) unplanned.push_back(report.stage);
  });
  capture.Run();
  EXPECT_THAT(unplanned, ::testing::IsEmpty());
  EXPECT_EQ(backwards, 0);
  EXPECT_NEAR(job.fraction(), 1.0, 1e-9);
  EXPECT_EQ(CaptureProgressPlan(options, 10).size(), 2u);
  options.resume = true;  // a resume checks no exposure
  EXPECT_EQ(CaptureProgressPlan(options, 10).front().stage, "capture");
  EXPECT_EQ(capture.summary().frames_captured, 11);
  EXPECT_EQ(capture.summary().retries, 0);
  ASSERT_EQ(capture.summary().exposure_check.size(), 10u);
  for (const FrameExposure& exposure : capture.summary().exposure_check) {
    EXPECT_EQ(exposure.clipped_fraction, 0.0) << exposure.frame;
    EXPECT_GT(exposure.signal_p99, 0.05) << exposure.frame;
  }
  ExpectEveryFrameShowsItsLed();
  EXPECT_EQ(bench_.board->lit_leds(), 0u) << "all LEDs off at the end";
  EXPECT_EQ(bench_.board->max_lit_at_once(), 1);
}

TEST_F(CaptureControllerTest, CameraErrorMidCaptureStopsDarkAndResumes) {
  FaultyCamera unplugged(bench_.camera.get(), [](int capture) {
    if (capture == 5) throw CameraError(CameraErrorKind::kClaimed, "camera", "USB interface claimed by gvfs");
  });
  CaptureController first = Controller(&unplugged, Options());
  EXPECT_THAT([&] { first.Run(); }, ::testing::ThrowsMessage<CameraError>(HasSubstr("claimed")));
  EXPECT_EQ(bench_.board->lit_leds(), 0u) << "all LEDs off on failure";
  const Session partial = LoadSession(session_dir());
  EXPECT_FALSE(partial.capture_complete);
  EXPECT_EQ(partial.frames.size(), 5u);

  CaptureController second = Controller(bench_.camera.get(), Resume(Options()));
  second.Run();
  EXPECT_EQ(second.summary().frames_resumed, 5);
  EXPECT_EQ(second.summary().frames_captured, 6);
  ExpectEveryFrameShowsItsLed();
}

// capture --rig sim records the scene; resuming with another material is
// refused, naming both, and the same scene resumes.
TEST_F(CaptureControllerTest, ResumingASimulatedCaptureWithAnotherMaterialIsRefused) {
  FaultyCamera unplugged(bench_.camera.get(), [](int capture) {
    if (capture == 5) throw CameraError(CameraErrorKind::kClaimed, "camera", "USB interface claimed by gvfs");
  });
  CaptureOptions satin = Options();
  satin.simulation = SimulatedSceneRecord{"twill", "satin", "1", 2.4, 3.0, "2", true, true};
  CaptureController first = Controller(&unplugged, satin);
  EXPECT_THROW(first.Run(), CameraError);
  ASSERT_TRUE(LoadSession(session_dir()).simulation.has_value());
  EXPECT_EQ(LoadSession(session_dir()).simulation->material, "satin");

  CaptureOptions cloth = Resume(satin);
  cloth.simulation->material = "cloth";
  CaptureController refused = Controller(bench_.camera.get(), cloth);
  EXPECT_THAT([&] { refused.Run(); },
              ::testing::ThrowsMessage<SessionError>(AllOf(HasSubstr("simulation.material"), HasSubstr("'satin'"),
                                                           HasSubstr("'cloth'"))));
  CaptureController second = Controller(bench_.camera.get(), Resume(satin));
  second.Run();
  EXPECT_EQ(second.summary().frames_resumed, 5);
}

TEST_F(CaptureControllerTest, TransientCameraErrorIsRetried) {
  FaultyCamera busy(bench_.camera.get(), [](int capture) {
    if (capture == 2) throw CameraError(CameraErrorKind::kBusy, "camera", "busy writing to the card");
  });
  CaptureController capture = Controller(&busy, Options());
  capture.Run();
  EXPECT_EQ(capture.summary().retries, 1);
  EXPECT_THAT(capture.summary().retry_reasons.at(0), HasSubstr("busy"));
  ExpectEveryFrameShowsItsLed();
}

TEST_F(CaptureControllerTest, FirmwareResetMidCaptureIsCaughtAndTheFrameRetaken) {
  FaultyCamera resetting(bench_.camera.get(), [this](int capture) {
    if (capture == 4) bench_.board->Reset();  // e.g. a brown-out during the exposure
  });
  CaptureController capture = Controller(&resetting, Options());
  capture.Run();
  EXPECT_GE(capture.summary().retries, 1);
  EXPECT_THAT(capture.summary().retry_reasons.at(0), HasSubstr("led_03"));
  ExpectEveryFrameShowsItsLed();
}

TEST_F(CaptureControllerTest, WatchdogDuringALongExposureSpoilsOnlyThatAttempt) {
  // The watchdog leaves ample margin for ordinary captures on a loaded
  // machine; only the stalled exposure of led_02 outlasts it.
  CaptureOptions options = Options();
  options.watchdog_ms = 1000;
  FaultyCamera slow(bench_.camera.get(), [](int capture) {
    if (capture == 3) std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  });
  CaptureController capture = Controller(&slow, options);
  capture.Run();
  ASSERT_GE(capture.summary().retries, 1);
  EXPECT_THAT(capture.summary().retry_reasons,
              ::testing::Contains(AllOf(HasSubstr("led_02"), HasSubstr("after the exposure"))));
  ExpectEveryFrameShowsItsLed();
}

TEST_F(CaptureControllerTest, SerialGarbageMidCaptureDoesNotLoseSync) {
  FaultyCamera noisy(bench_.camera.get(), [this](int capture) {
    if (capture == 2) bench_.board->InjectNoiseToHost("\x01\x7f garbage \r\nOK ON 9\r\n");
  });
  CaptureController capture = Controller(&noisy, Options());
  capture.Run();
  ExpectEveryFrameShowsItsLed();
}

TEST_F(CaptureControllerTest, DiskWriteFailureIsReportedAndNothingIsLost) {
  // A full disk, as the writer sees it: from the fifth frame on, any file
  // larger than 64 KiB fails to write (EFBIG instead of ENOSPC).
  rlimit original{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &original), 0);
  std::signal(SIGXFSZ, SIG_IGN);
  FaultyCamera full_disk(bench_.camera.get(), [&](int capture) {
    if (capture == 4) {
      rlimit limited = original;
      limited.rlim_cur = 64 * 1024;
      ::setrlimit(RLIMIT_FSIZE, &limited);
    }
  });
  CaptureController first = Controller(&full_disk, Options());
  EXPECT_THAT([&] { first.Run(); },
              ::testing::ThrowsMessage<SessionError>(AllOf(HasSubstr("led_03.dng"), HasSubstr("write failed"))));
  ::setrlimit(RLIMIT_FSIZE, &original);
  EXPECT_EQ(bench_.board->lit_leds(), 0u);
  const Session partial = LoadSession(session_dir());  // intact: checksums verified
  EXPECT_EQ(partial.frames.size(), 4u);
  for (const auto& entry : fs::directory_iterator(session_dir() / "frames")) {
    EXPECT_THAT(entry.path().filename().string(), ::testing::Not(HasSubstr(".tmp"))) << "no temporary left";
  }

  CaptureController second = Controller(bench_.camera.get(), Resume(Options()));
  second.Run();
  EXPECT_EQ(second.summary().frames_resumed, 4);
  ExpectEveryFrameShowsItsLed();
}

TEST_F(CaptureControllerTest, ExposureCheckRefusesClippedAndDarkFramesBeforeKeepingAny) {
  CaptureOptions too_bright = Options();
  too_bright.check_exposure = true;
  too_bright.exposure.exposure_time_s = 1.0 / 2;  // 30x the simulated rig's reference
  CaptureController bright = Controller(bench_.camera.get(), too_bright);
  EXPECT_THAT([&] { bright.Run(); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("shorten the exposure")));
  EXPECT_FALSE(fs::exists(session_dir() / "session.json"));

  CaptureOptions too_dark = Options();
  too_dark.check_exposure = true;
  too_dark.exposure.exposure_time_s = 1.0 / 4000;
  CaptureController dark = Controller(bench_.camera.get(), too_dark);
  EXPECT_THAT([&] { dark.Run(); }, ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("lengthen the exposure")));
  EXPECT_FALSE(fs::exists(session_dir() / "session.json"));
  EXPECT_EQ(bench_.board->lit_leds(), 0u);
}

TEST_F(CaptureControllerTest, CancelLeavesAResumableSessionAndLedsOff) {
  CaptureController capture = Controller(bench_.camera.get(), Options());
  capture.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "capture" && report.fraction > 0.3) capture.RequestStop();
  });
  EXPECT_THROW(capture.Run(), Cancelled);
  EXPECT_EQ(bench_.board->lit_leds(), 0u);
  EXPECT_FALSE(LoadSession(session_dir()).capture_complete);
  Controller(bench_.camera.get(), Resume(Options())).Run();
  ExpectEveryFrameShowsItsLed();
}

// A second capture into a session the first one is writing is refused before
// it touches the camera or the LEDs, naming the folder and the holder; the
// first carries on, and once it has finished (lock released) the folder is
// free again.
TEST_F(CaptureControllerTest, SecondCaptureIntoAHeldSessionIsRefusedUpFront) {
  std::string refusal;
  long holder_pid = -1;
  FaultyCamera interrupting(bench_.camera.get(), [&](int capture) {
    if (capture != 3) return;
    CaptureController second = Controller(bench_.camera.get(), Options());
    try {
      second.Run();
    } catch (const FolderBusyError& error) {
      refusal = error.what();
      holder_pid = error.holder_pid();
    }
  });
  CaptureController first = Controller(&interrupting, Options());
  first.Run();
  EXPECT_THAT(refusal, AllOf(HasSubstr(session_dir().string() + ": in use by another process"),
                             HasSubstr("(pid " + std::to_string(::getpid()) + ")")));
  EXPECT_EQ(holder_pid, static_cast<long>(::getpid()));
  EXPECT_EQ(first.summary().frames_captured, 11);
  ExpectEveryFrameShowsItsLed();
  FolderLock free_again(session_dir());
}

// Another process holds the session (a FolderLock here): refused before any
// frame or session.json is written.
TEST_F(CaptureControllerTest, CaptureIntoALockedFolderWritesNothing) {
  std::optional<FolderLock> other(std::in_place, session_dir());
  CaptureController refused = Controller(bench_.camera.get(), Options());
  EXPECT_THROW(refused.Run(), FolderBusyError);
  EXPECT_FALSE(fs::exists(session_dir() / "session.json"));
  EXPECT_EQ(bench_.board->max_lit_at_once(), 0) << "no LED was switched";
  other.reset();
  Controller(bench_.camera.get(), Options()).Run();
  ExpectEveryFrameShowsItsLed();
}

// Issue #36 item 3: a new capture into a folder that holds anything (other
// files, an interrupted or a complete session) is refused before any LED is
// switched, naming what is there; the interrupted one resumes only when asked;
// a resume of a folder without a session is refused and makes no folder.
TEST_F(CaptureControllerTest, ANewCaptureNeedsAnEmptyFolderAndAResumeAnInterruptedSession) {
  fs::create_directories(session_dir());
  { std::ofstream(session_dir() / "notes.txt") << "someone's notes"; }
  EXPECT_THAT([&] { Controller(bench_.camera.get(), Options()).Run(); },
              ::testing::ThrowsMessage<SessionError>(
                  AllOf(HasSubstr(session_dir().string() + " is not empty"), HasSubstr("notes.txt"))));
  EXPECT_THAT([&] { Controller(bench_.camera.get(), Resume(Options())).Run(); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("has no session.json to resume")));
  EXPECT_FALSE(fs::exists(session_dir() / "session.json"));
  EXPECT_EQ(bench_.board->max_lit_at_once(), 0) << "no LED was switched";
  fs::remove(session_dir() / "notes.txt");

  // The lock file of the refused tries does not make the folder "not empty".
  FaultyCamera unplugged(bench_.camera.get(), [](int capture) {
    if (capture == 4) throw CameraError(CameraErrorKind::kClaimed, "camera", "USB interface claimed by gvfs");
  });
  EXPECT_THROW(Controller(&unplugged, Options()).Run(), CameraError);
  EXPECT_THAT([&] { Controller(bench_.camera.get(), Options()).Run(); },
              ::testing::ThrowsMessage<SessionError>(AllOf(HasSubstr("holds an interrupted capture of 'sim twill' (4 "
                                                                     "of 11 frames)"),
                                                           HasSubstr("--resume"))));
  CaptureController resumed = Controller(bench_.camera.get(), Resume(Options()));
  resumed.Run();
  EXPECT_EQ(resumed.summary().frames_resumed, 4);
  EXPECT_THAT([&] { Controller(bench_.camera.get(), Resume(Options())).Run(); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("holds a complete session of 'sim twill' (11 of 11")));

  const fs::path missing = session_dir().parent_path() / "never-made";
  CaptureController nothing(missing, bench_.rig->rig(), bench_.camera.get(), bench_.lights.get(), Resume(Options()));
  EXPECT_THAT([&] { nothing.Run(); }, ::testing::ThrowsMessage<SessionError>(HasSubstr("does not exist")));
  EXPECT_FALSE(fs::exists(missing));
}

TEST(CaptureOptionsTest, CheckNamesTheField) {
  CaptureOptions options;
  EXPECT_THAT([&] { options.Check(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("sample_name")));
  options.sample_name = "x";
  options.max_attempts = 0;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("max_attempts = 0")));
}

}  // namespace
}  // namespace scanbench
