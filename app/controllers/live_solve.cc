#include "app/controllers/live_solve.h"

#include <sys/resource.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <sstream>

#include "app/io/file_util.h"
#include "app/session/session.h"
#include "core/bounded_worker.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// User + system CPU seconds of the whole process so far.
double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// Decodes journalled frames on its own thread (a BoundedWorker) in the order
// they come, into a SolvePreparation made at the first frame. At most
// `capacity` frames wait; Push blocks beyond that. A frame or a preparation
// the worker cannot make is noted and left to the solve, which then fails (or
// succeeds) exactly as `scanbench solve` would.
class LiveDecoder {
 public:
  LiveDecoder(fs::path session_dir, const SolveOptions& options, int capacity, bool develop_ahead)
      : session_dir_(std::move(session_dir)), options_(options), develop_ahead_(develop_ahead),
        worker_([this](FrameRecord& record) { DecodeOne(record); }, capacity, [] {
          // Below the capture's threads (Linux nice is per thread): the camera and
          // the LED board's timing come first, the decoder has until the last frame.
          setpriority(PRIO_PROCESS, static_cast<id_t>(gettid()), 10);
        }) {}

  // Destroying it drops what still waits; a frame being decoded is finished first.

  void Push(const FrameRecord& record) { worker_.Push(record); }

  // Waits for every pushed frame; the preparation, if it could be made.
  // `verified`: frames whose file was hashed against its record.
  std::optional<SolvePreparation> Finish(std::vector<std::string>* problems, int* verified) {
    worker_.Finish();  // from here on the solve waits: only decode (finishing())
    *problems = problems_;
    *verified = verified_;
    return std::move(preparation_);
  }

 private:
  // Whether to do more than decode the frame: not once the capture is done
  // or while more frames wait. What this thread would do alone after the
  // last frame the solve does faster on every thread (the points on request,
  // the development band by band); a loaded machine leaves this niced thread
  // behind the capture.
  bool AheadOfTheCapture() const { return !worker_.finishing() && worker_.waiting() == 0; }

  void DecodeOne(const FrameRecord& record) {
    if (failed_) return;
    try {
      // session.json as journalled so far: the light field and the size
      // check from exactly what the solve will load (rig, camera).
      SessionLoadOptions load;
      load.verify_checksums = false;
      const Session session = LoadSession(session_dir_, load);
      if (!preparation_) preparation_.emplace(session_dir_, session, options_);
      // The solve's load need not read every frame again after the last one.
      if (options_.verify_checksums && Sha256HexOfFile(session_dir_ / record.file) != record.sha256) {
        throw SessionError(record.file + ": SHA-256 differs from the one session.json records");
      }
      preparation_->AddFrame(record, DecodeSessionFrame(session_dir_, session, record));
      ++verified_;
      // Once, at the first frame however many wait (the capture waits for
      // the queue meanwhile): the table points, 2 s of CPU at 16 MP on this
      // thread alone, while the camera takes the next frames.
      if (!preparation_->holds_surface_points() && !worker_.finishing()) preparation_->HoldSurfacePoints(1);
      // An LED frame demosaiced now, not in the solve (the dark frame comes first).
      if (develop_ahead_ && AheadOfTheCapture()) preparation_->DevelopFrame(session, record);
    } catch (const std::exception& error) {
      problems_.push_back(record.file + ": " + error.what());
      failed_ = !preparation_;  // without a light field there is nothing to add frames to
    }
  }

  const fs::path session_dir_;
  const SolveOptions options_;
  const bool develop_ahead_;
  // The worker's alone until Finish joins it.
  std::optional<SolvePreparation> preparation_;
  std::vector<std::string> problems_;
  bool failed_ = false;
  int verified_ = 0;
  BoundedWorker<FrameRecord> worker_;  // last: its thread starts once everything above exists, and ends first
};

}  // namespace

void LiveSolveOptions::Check() const {
  capture.Check();
  solve.Check();
  SCANBENCH_REQUIRE_GE_LE("LiveSolveOptions", "queue_frames", queue_frames, 1, 64);
}

std::string LiveSolveSummary::BriefReport() const {
  std::ostringstream out;
  out << "Live solve: " << capture.frames_captured << " frames captured, " << capture.frames_resumed
      << " already there; " << frames_decoded_live << " decoded while capturing (" << frames_developed_live << " developed); result "
      << solve.result_dir.string() << " " << Significant(seconds_after_last_frame) << " s after the last frame (" << Significant(cpu_seconds_after_last_frame) << " s of CPU)";
  return out.str();
}

LiveSolveController::LiveSolveController(fs::path session_dir, RigDescription rig, Camera* camera,
                                         LightController* lights, LiveSolveOptions options)
    : session_dir_(std::move(session_dir)), rig_(std::move(rig)), camera_(camera), lights_(lights),
      options_(std::move(options)) {}

ProgressReportCallback LiveSolveController::ForwardTo(BaseController& inner) {
  return [this, &inner](const ProgressReport& report) {
    ReportProgress(report.stage, report.fraction, report.detail);
    if (IsStopRequested()) inner.RequestStop();  // also a stop asked for by our own progress callback
  };
}

void LiveSolveController::Run() {
  options_.Check();
  summary_ = LiveSolveSummary();
  // Declared before the capture: on a throw the capture is gone before the
  // decoder drops its queue.
  LiveDecoder decoder(session_dir_, options_.solve, options_.queue_frames, options_.develop_ahead);
  auto last_frame = std::chrono::steady_clock::now();
  double last_frame_cpu = ProcessCpuSeconds();
  {
    CaptureController capture(session_dir_, rig_, camera_, lights_, options_.capture);
    capture.SetProgressCallback(ForwardTo(capture));
    capture.SetFrameJournalledCallback([&](const Session&, const FrameRecord& record) {
      last_frame = std::chrono::steady_clock::now();
      last_frame_cpu = ProcessCpuSeconds();
      if (IsStopRequested()) capture.RequestStop();
      decoder.Push(record);
    });
    capture.Run();
    summary_.capture = capture.summary();
  }
  // A resume that found every frame there: the wait starts now.
  if (summary_.capture.frames_captured == 0) {
    last_frame = std::chrono::steady_clock::now();
    last_frame_cpu = ProcessCpuSeconds();
  }

  int verified = 0;
  std::optional<SolvePreparation> preparation = decoder.Finish(&summary_.live_problems, &verified);
  ThrowIfStopRequested("solve");
  SolveOptions solve_options = options_.solve;
  // Every frame hashed while capturing: the load only checks the manifest.
  const int num_frames = static_cast<int>(rig_.leds.size()) + 1;
  if (verified == num_frames) solve_options.verify_checksums = false;
  // The first pass's maps written as it is solved, not after the depth
  // refinement's decision (the same files; a draped sample writes again).
  solve_options.stream_first_pass = true;
  SolveController solve(session_dir_, solve_options);
  if (preparation) {
    summary_.frames_decoded_live = preparation->num_frames();
    summary_.frames_developed_live = preparation->num_developed_frames();
    summary_.surface_points_held = preparation->holds_surface_points();
    solve.UsePreparation(std::move(*preparation));
  }
  solve.SetProgressCallback(ForwardTo(solve));
  summary_.seconds_until_solve = SecondsSince(last_frame);
  solve.Run();
  summary_.solve = solve.summary();
  summary_.seconds_after_last_frame = SecondsSince(last_frame);
  summary_.cpu_seconds_after_last_frame = ProcessCpuSeconds() - last_frame_cpu;
}

}  // namespace scanbench
