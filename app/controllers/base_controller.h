// A long job: Run() does the work; progress is reported per stage and a stop
// flag, settable from any thread (Ctrl-C in the CLI, Cancel in the GUI),
// ends it at the next check with JobCancelled.
#pragma once

#include <atomic>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>

namespace scanbench {

class JobCancelled : public std::runtime_error {
 public:
  explicit JobCancelled(const std::string& where) : std::runtime_error("cancelled during " + where) {}
};

class BaseController {
 public:
  // stage: short name of what runs now; fraction of that stage done, [0, 1].
  using ProgressCallback = std::function<void(const std::string& stage, double fraction)>;

  virtual ~BaseController() = default;

  // Throws on failure with a message naming the file or field at fault, and
  // JobCancelled after RequestStop().
  virtual void Run() = 0;

  void RequestStop() { stop_requested_ = true; }
  bool IsStopRequested() const { return stop_requested_.load(); }
  void SetProgressCallback(ProgressCallback callback) { progress_ = std::move(callback); }

 protected:
  void ReportProgress(const std::string& stage, double fraction) const {
    if (progress_) progress_(stage, fraction);
  }
  void ThrowIfStopRequested(const std::string& stage) const {
    if (IsStopRequested()) throw JobCancelled(stage);
  }
  // A callback for algorithms that report a fraction and stop when it
  // returns false.
  std::function<bool(double)> StageCallback(const std::string& stage) const {
    return [this, stage](double fraction) {
      ReportProgress(stage, fraction);
      return !IsStopRequested();
    };
  }

 private:
  std::atomic<bool> stop_requested_{false};
  ProgressCallback progress_;
};

}  // namespace scanbench
