// A long job (after COLMAP's controllers): Run() does the work as a short list
// of named steps; progress is reported per stage, with an optional detail; a
// stop flag, settable from any thread (Ctrl-C in the CLI, Cancel in the GUI),
// ends it at the next check by throwing Cancelled. The CLI and the GUI drive
// the same controllers.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
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

// The wall time of a run's stages, from one clock, each stage's own: a step
// timed inside another on the same thread counts for its stage only (a solve
// whose sink colours, evaluates and writes each band on the solve's thread:
// that time is the colour's, the evaluation's and the writing's, not the
// solve's too). A step timed on a thread of its own (a band writer beside the
// solve) adds to its stage and takes nothing from what runs meanwhile on
// other threads. A stage timed more than once adds up. Thread-safe.
class StageTimes {
 public:
  // The stages, in the order List gives them.
  explicit StageTimes(std::vector<std::string> stages)
      : stages_(std::move(stages)), seconds_(stages_.size()), timed_(stages_.size(), false) {}

  // Runs step() and adds its wall time, less that of the steps timed inside
  // it on this thread, to `stage`; returns what step() returns. A step that
  // throws adds nothing.
  template <typename Step>
  auto Time(const std::string& stage, Step&& step) {
    const size_t index = IndexOf(stage);
    Open(index);
    struct Closer {  // pops the step's record also when it throws
      StageTimes* times;
      std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
      bool finished = false;
      ~Closer() { times->Close(SecondsSince(start), finished); }
    } closer{this};
    if constexpr (std::is_void_v<decltype(step())>) {
      step();
      closer.finished = true;
    } else {
      auto result = step();
      closer.finished = true;
      return result;
    }
  }
  // Adds `seconds` the caller measured (a part of its step that ran beside
  // the step's own work, e.g. the evaluation among the map encodings) to
  // `stage`, taking them from the step this thread is timing.
  void Add(const std::string& stage, double seconds) {
    const size_t index = IndexOf(stage);
    std::lock_guard<std::mutex> lock(mutex_);
    seconds_[index] += seconds;
    timed_[index] = true;
    if (OpenStep* innermost = InnermostOfThisThread()) innermost->nested_seconds += seconds;
  }
  // The stages timed or added to, in the constructor's order.
  std::vector<StageTiming> List() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<StageTiming> list;
    for (size_t i = 0; i < stages_.size(); ++i) {
      if (timed_[i]) list.push_back({stages_[i], seconds_[i]});
    }
    return list;
  }

 private:
  struct OpenStep {
    std::thread::id thread;
    size_t stage;
    double nested_seconds = 0;  // of the steps timed inside it, and Add's
  };
  size_t IndexOf(const std::string& stage) const {
    const auto found = std::find(stages_.begin(), stages_.end(), stage);
    if (found == stages_.end()) throw std::logic_error("StageTimes: no stage named '" + stage + "'");
    return static_cast<size_t>(found - stages_.begin());
  }
  OpenStep* InnermostOfThisThread() {  // under mutex_
    const auto found = std::find_if(open_.rbegin(), open_.rend(),
                                    [](const OpenStep& step) { return step.thread == std::this_thread::get_id(); });
    return found == open_.rend() ? nullptr : &*found;
  }
  void Open(size_t stage) {
    std::lock_guard<std::mutex> lock(mutex_);
    open_.push_back({std::this_thread::get_id(), stage});
  }
  void Close(double elapsed, bool finished) {
    std::lock_guard<std::mutex> lock(mutex_);
    OpenStep* step = InnermostOfThisThread();
    const OpenStep closed = *step;
    open_.erase(open_.begin() + (step - open_.data()));
    if (!finished) return;
    seconds_[closed.stage] += elapsed - closed.nested_seconds;
    timed_[closed.stage] = true;
    if (OpenStep* outer = InnermostOfThisThread()) outer->nested_seconds += elapsed;
  }

  const std::vector<std::string> stages_;
  mutable std::mutex mutex_;
  std::vector<double> seconds_;  // under mutex_, per stage
  std::vector<bool> timed_;      // under mutex_, per stage
  std::vector<OpenStep> open_;   // under mutex_: the steps being timed, in the order they started
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
  // The same, its time added to `times` (StageTimes: the step's own time,
  // without that of the steps timed inside it).
  template <typename Step>
  auto TimedStage(StageTimes& times, const std::string& timing_name, const std::string& stage, Step&& step) const {
    if (stage.empty()) {
      ThrowIfStopRequested(timing_name);
    } else {
      BeginStage(stage);
    }
    return times.Time(timing_name, std::forward<Step>(step));
  }

 private:
  std::atomic<bool> stop_requested_{false};
  ProgressReportCallback progress_;
};

}  // namespace scanbench
