// A terminal progress bar for controller stages. On a terminal it redraws one
// line; into a log (CI, pipes) it prints a line per stage and quarter.
#pragma once

#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

namespace scanbench {

class ProgressBar {
 public:
  explicit ProgressBar(std::FILE* stream = stderr);
  ~ProgressBar();
  // Thread-safe; fraction in [0, 1] of the named stage. A stage may carry a
  // detail after '|' ("solve sessions|7/19 done, ETA 1:20"): it is shown after
  // the bar and changing it does not start a new stage.
  void Update(const std::string& stage, double fraction);
  // Ends the current line (before printing anything else).
  void Finish();

 private:
  std::FILE* stream_;
  bool interactive_;
  std::mutex mutex_;
  std::string stage_;
  int last_quarter_ = -1;
  bool line_open_ = false;
  std::chrono::steady_clock::time_point last_draw_{};
  std::chrono::steady_clock::time_point stage_start_{};
};

}  // namespace scanbench
