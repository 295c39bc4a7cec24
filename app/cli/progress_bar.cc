#include "app/cli/progress_bar.h"

#include <unistd.h>

#include <algorithm>

namespace scanbench {

ProgressBar::ProgressBar(std::FILE* stream) : ProgressBar(stream, ::isatty(::fileno(stream)) != 0) {}

ProgressBar::ProgressBar(std::FILE* stream, bool interactive) : stream_(stream), interactive_(interactive) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(const ProgressReport& report) {
  const std::string& stage = report.stage;
  const std::string detail = report.detail.empty() ? "" : "  " + report.detail;
  std::lock_guard<std::mutex> lock(mutex_);
  const double fraction = std::clamp(report.fraction, 0.0, 1.0);
  const auto now = std::chrono::steady_clock::now();
  if (!started_) {
    started_ = true;
    job_start_ = now;
  }
  const auto [seen, first_report] = quarters_.try_emplace(stage, -1);
  const bool switched = stage != stage_;
  stage_ = stage;
  const double elapsed = std::chrono::duration<double>(now - job_start_).count();
  if (interactive_) {
    // A stage not seen before keeps the previous stage's last line; one that
    // comes back (another thread's) redraws the line in place.
    if (first_report && line_open_) std::fputc('\n', stream_);
    // Redrawing faster than 10 Hz only costs time.
    if (!first_report && !switched && fraction < 1.0 && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth + 0.5);
    // "\033[K" clears what a longer detail left on the line.
    std::fprintf(stream_, "\r%-16s [%s%s] %3d%% %6.1fs%s\033[K", stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, ' ').c_str(), static_cast<int>(fraction * 100 + 0.5), elapsed,
                 detail.c_str());
    line_open_ = true;
  } else {
    // Each stage's quarters once, in order, whatever else reports between them.
    const int quarter = static_cast<int>(fraction * 4);
    if (quarter <= seen->second) return;
    seen->second = quarter;
    std::fprintf(stream_, "%-16s %3d%% %6.1fs%s\n", stage.c_str(), quarter * 25, elapsed, detail.c_str());
  }
  std::fflush(stream_);
}

void ProgressBar::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (line_open_ && interactive_) std::fputc('\n', stream_);
  line_open_ = false;
  stage_.clear();
  quarters_.clear();
  started_ = false;
  std::fflush(stream_);
}

}  // namespace scanbench
