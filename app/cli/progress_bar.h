// A terminal progress bar for controller stages. On a terminal it redraws one
// line; into a log (CI, pipes) it prints a line per stage and quarter.
#pragma once

#include <chrono>
#include <cstdio>
#include <mutex>
#include <string>

#include "core/progress.h"

namespace scanbench {

class ProgressBar {
 public:
  explicit ProgressBar(std::FILE* stream = stderr);
  ~ProgressBar();
  // Thread-safe; the report's fraction in [0, 1] of its stage. A detail
  // ("7/19 done, ETA 1:20") is shown after the bar; changing it does not start
  // a new stage.
  void Update(const ProgressReport& report);
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
