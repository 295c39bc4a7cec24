// A terminal progress bar for controller stages. On a terminal it redraws one
// line (a new line for each stage not seen before); into a log (CI, pipes) it
// prints a line when a stage reaches a new quarter. A stage reported again
// after another (two of the job's threads report, as `capture --solve` does)
// carries on where it was: no line is repeated, and every line's time is
// since the job's first report, so the times never run backwards.
#pragma once

#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>

#include "core/progress.h"

namespace scanbench {

class ProgressBar {
 public:
  // interactive: redraw one line; by default when `stream` is a terminal.
  explicit ProgressBar(std::FILE* stream = stderr);
  ProgressBar(std::FILE* stream, bool interactive);
  ~ProgressBar();
  // Thread-safe; the report's fraction in [0, 1] of its stage. A detail
  // ("7/19 done, ETA 1:20") is shown after the bar; changing it does not start
  // a new stage.
  void Update(const ProgressReport& report);
  // Ends the current line (before printing anything else); the next report
  // starts a new job.
  void Finish();

 private:
  std::FILE* stream_;
  bool interactive_;
  std::mutex mutex_;
  std::string stage_;                 // drawn last
  std::map<std::string, int> quarters_;  // per stage seen: the last quarter printed (-1: none)
  bool line_open_ = false;
  bool started_ = false;
  std::chrono::steady_clock::time_point last_draw_{};
  std::chrono::steady_clock::time_point job_start_{};
};

}  // namespace scanbench
