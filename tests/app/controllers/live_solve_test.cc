// Solve while capturing (issue #14 item 2) on the simulated bench: the LED
// firmware in simavr, the simulated camera, a small sensor. The live result
// must be bit-equal to a solve of the finished session, also after an
// interrupted capture that resumes.
#include "app/controllers/live_solve.h"

#include <mutex>

#include "app/controllers/progress_plans.h"

#include <cstring>
#include <fstream>
#include <iterator>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/devices/camera/simulated_camera.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/simulated_led_board.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "core/field_error.h"
#include "tests/util/simulated_bench.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::MakeSimulatedBench;
using testing::SimulatedBench;
using testing::TemporaryFolder;

constexpr int kWidth = 320;
constexpr int kHeight = 212;

class LiveSolveTest : public ::testing::Test {
 protected:
  LiveSolveOptions Options() const {
    LiveSolveOptions options;
    options.capture.sample_name = "sim twill";
    options.capture.check_exposure = false;
    options.capture.led_settle = std::chrono::milliseconds(0);
    options.queue_frames = 2;
    options.solve.run_label = "live";
    return options;
  }

  LiveSolveController Controller(LiveSolveOptions options) {
    return LiveSolveController(session_dir(), bench_.rig->rig(), bench_.camera.get(), bench_.lights.get(), std::move(options));
  }

  fs::path session_dir() const { return folder_ / "session"; }

  // `scanbench solve` of the finished session, beside the live result.
  fs::path SolveAfterwards() const {
    SolveOptions options;
    options.run_label = "after";
    SolveController solve(session_dir(), options);
    solve.Run();
    return solve.summary().result_dir;
  }

  static void ExpectBitEqualMaps(const fs::path& live, const fs::path& after) {
    for (const char* name : {"normal.exr", "albedo.exr", "confidence.exr", "specular.exr"}) {
      const ImageF a = ReadImageFloat(live / name);
      const ImageF b = ReadImageFloat(after / name);
      ASSERT_EQ(a.width(), b.width()) << name;
      ASSERT_EQ(a.height(), b.height()) << name;
      ASSERT_EQ(a.channels(), b.channels()) << name;
      EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(float)), 0) << name << " differs";
    }
    // The PNGs byte for byte (the live solve writes them on its own thread beside the solve).
    const auto bytes = [](const fs::path& path) {
      std::ifstream in(path, std::ios::binary);
      return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    };
    for (const char* name : {"normal.png", "albedo_srgb.png", "status.png", "solved_mask.png"}) {
      ASSERT_TRUE(fs::exists(live / name)) << name;
      EXPECT_TRUE(bytes(live / name) == bytes(after / name)) << name << " differs";
    }
  }

  TemporaryFolder folder_;
  SimulatedBench bench_ = MakeSimulatedBench(kWidth, kHeight);
};

TEST_F(LiveSolveTest, ResultIsBitEqualToASolveOfTheFinishedSession) {
  LiveSolveOptions options = Options();
  options.develop_ahead = true;  // off by default; the resume test below runs without it
  LiveSolveController live = Controller(options);
  // Issue #36 item 8: every stage the run reports is one of its plan's, and
  // the job's bar over them only moves forward (reports come from the
  // capture's thread and the solve's writers: serialised here as the GUI does).
  JobProgress job(LiveSolveProgressPlan(options.capture, static_cast<int>(bench_.rig->rig().leds.size())));
  std::mutex job_mutex;
  std::vector<std::string> unplanned;
  int backwards = 0;
  live.SetProgressCallback([&](const ProgressReport& report) {
    const std::lock_guard lock(job_mutex);
    const double before = job.fraction();
    job.Update(report);
    backwards += job.fraction() < before;
    if (job.stage_number() == 0) unplanned.push_back(report.stage);
  });
  live.Run();
  EXPECT_THAT(unplanned, ::testing::IsEmpty());
  EXPECT_EQ(backwards, 0);
  EXPECT_NEAR(job.fraction(), 1.0, 1e-9) << "write maps 100 % is the plan's end";
  const LiveSolveSummary& summary = live.summary();
  EXPECT_EQ(summary.capture.frames_captured, 11);
  EXPECT_EQ(summary.frames_decoded_live, 11) << "every frame decoded while capturing";
  // As many as the decoder got to ahead of the capture (on a loaded machine
  // fewer); the result is the same either way.
  EXPECT_LE(summary.frames_developed_live, 10);
  EXPECT_GE(summary.cpu_seconds_after_last_frame, 0);
  EXPECT_TRUE(summary.live_problems.empty());
  EXPECT_TRUE(LoadSession(session_dir()).capture_complete);
  ASSERT_TRUE(fs::exists(summary.solve.result_dir / "report.json"));
  EXPECT_GT(summary.solve.solver.pixels_by_status[static_cast<int>(PixelStatus::kSolved)], kWidth * kHeight / 2);
  EXPECT_GT(summary.seconds_after_last_frame, 0);
  EXPECT_THAT(summary.BriefReport(), HasSubstr("11 decoded while capturing"));

  const fs::path after = SolveAfterwards();
  ExpectBitEqualMaps(summary.solve.result_dir, after);
}

TEST_F(LiveSolveTest, CancelLeavesNoResultAndTheResumeIsBitEqual) {
  LiveSolveController first = Controller(Options());
  int reports = 0;
  first.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "capture" && ++reports == 6) first.RequestStop();  // 5 frames journalled
  });
  EXPECT_THROW(first.Run(), Cancelled);
  const Session partial = LoadSession(session_dir());
  EXPECT_FALSE(partial.capture_complete);
  EXPECT_EQ(partial.frames.size(), 5u);
  std::error_code ignored;
  EXPECT_FALSE(fs::exists(session_dir() / "results", ignored) && !fs::is_empty(session_dir() / "results"))
      << "a cancelled live solve leaves no result folder";
  EXPECT_EQ(bench_.board->lit_leds(), 0u) << "all LEDs off after a cancel";

  LiveSolveOptions resume = Options();
  resume.capture.resume = true;
  LiveSolveController second = Controller(resume);
  second.Run();
  const LiveSolveSummary& summary = second.summary();
  EXPECT_EQ(summary.capture.frames_resumed, 5);
  EXPECT_EQ(summary.capture.frames_captured, 6);
  EXPECT_EQ(summary.frames_decoded_live, 11) << "the earlier run's frames are decoded from disk while capturing";
  EXPECT_EQ(summary.frames_developed_live, 0) << "develop_ahead is off by default";
  ExpectBitEqualMaps(summary.solve.result_dir, SolveAfterwards());
}

// A frame an interrupted run left that no longer matches session.json is
// refused (by the resume's load), and nothing is solved.
TEST_F(LiveSolveTest, AResumedFrameThatChangedOnDiskIsRefused) {
  LiveSolveController first = Controller(Options());
  int reports = 0;
  first.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "capture" && ++reports == 4) first.RequestStop();
  });
  EXPECT_THROW(first.Run(), Cancelled);
  const Session partial = LoadSession(session_dir());
  ASSERT_EQ(partial.frames.size(), 3u);
  {
    std::fstream file(session_dir() / partial.frames[1].file, std::ios::in | std::ios::out | std::ios::binary);
    file.seekg(-1, std::ios::end);
    const char last = static_cast<char>(file.get());
    file.seekp(-1, std::ios::end);
    file.put(static_cast<char>(last ^ 0x5a));  // the last byte of the RAW's data, changed
  }
  LiveSolveOptions resume = Options();
  resume.capture.resume = true;
  LiveSolveController second = Controller(resume);
  EXPECT_THAT([&] { second.Run(); }, ::testing::ThrowsMessage<SessionError>(HasSubstr("mismatch")));
  EXPECT_EQ(LoadSession(session_dir(), SessionLoadOptions{.verify_checksums = false}).frames.size(), 3u);
  std::error_code ignored;
  EXPECT_FALSE(fs::exists(session_dir() / "results", ignored) && !fs::is_empty(session_dir() / "results"));
}

TEST_F(LiveSolveTest, OptionsAreChecked) {
  LiveSolveOptions options = Options();
  options.queue_frames = 0;
  EXPECT_THAT([&] { options.Check(); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("LiveSolveOptions.queue_frames = 0 must lie in [1, 64]")));
  options = Options();
  options.capture.sample_name.clear();
  EXPECT_THROW(options.Check(), std::invalid_argument);
  EXPECT_THROW(Controller(options).Run(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(session_dir())) << "nothing written before the options are checked";
}

}  // namespace
}  // namespace scanbench
