// A long job (after COLMAP's controllers): Run() does the work as a short list
// of named steps; progress is reported per stage, with an optional detail; a
// stop flag, settable from any thread (Ctrl-C in the CLI, Cancel in the GUI),
// ends it at the next check by throwing Cancelled. The CLI and the GUI drive
// the same controllers.
#pragma once

#include <atomic>
#include <chrono>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/cancellation.h"
#include "core/format.h"
#include "core/progress.h"

namespace scanbench {

// The wall time of one step of a run, as a report's "timings_s" lists it.
struct StageTiming {
  std::string stage;  // "load", "decode": a name for reports, not a progress stage
  double seconds = 0;
};

class BaseController {
 public:
  virtual ~BaseController() = default;

  // Throws on failure with a message naming the file or field at fault, and
  // Cancelled after RequestStop().
  virtual void Run() = 0;

  void RequestStop() { stop_requested_ = true; }
  bool IsStopRequested() const { return stop_requested_.load(); }
  void SetProgressCallback(ProgressReportCallback callback) { progress_ = std::move(callback); }

 protected:
  // stage: short name of what runs now; fraction of that stage done, [0, 1];
  // detail: optional figures for people ("7/19 done, ETA 1:20").
  void ReportProgress(const std::string& stage, double fraction, const std::string& detail = {}) const {
    if (progress_) progress_(ProgressReport{stage, detail, fraction});
  }
  void ThrowIfStopRequested(const std::string& stage) const {
    if (IsStopRequested()) throw Cancelled(stage);
  }
  // Starts a step: reports `stage` at 0 after a stop check. Long steps then
  // hand StageCallback(stage) to their algorithm.
  void BeginStage(const std::string& stage) const {
    ThrowIfStopRequested(stage);
    ReportProgress(stage, 0);
  }
  // A callback for algorithms (core/progress.h): reports the fraction under
  // `stage` and asks them to stop once a stop was requested.
  ProgressCallback StageCallback(const std::string& stage) const {
    return [this, stage](double fraction) {
      ReportProgress(stage, fraction);
      return !IsStopRequested();
    };
  }
  // Runs one step and appends its wall time to `timings` as `timing_name`;
  // returns what step() returns. The step starts with BeginStage(stage), or
  // only a stop check when it reports no progress of its own (stage "").
  template <typename Step>
  auto TimedStage(std::vector<StageTiming>& timings, const std::string& timing_name, const std::string& stage,
                  Step&& step) const {
    if (stage.empty()) {
      ThrowIfStopRequested(timing_name);
    } else {
      BeginStage(stage);
    }
    const auto start = std::chrono::steady_clock::now();
    if constexpr (std::is_void_v<decltype(step())>) {
      step();
      timings.push_back({timing_name, SecondsSince(start)});
    } else {
      auto result = step();
      timings.push_back({timing_name, SecondsSince(start)});
      return result;
    }
  }

 private:
  std::atomic<bool> stop_requested_{false};
  ProgressReportCallback progress_;
};

}  // namespace scanbench
