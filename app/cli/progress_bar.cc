#include "app/cli/progress_bar.h"

#include <unistd.h>

#include <algorithm>

namespace scanbench {

ProgressBar::ProgressBar(std::FILE* stream) : stream_(stream), interactive_(::isatty(::fileno(stream)) != 0) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(const ProgressReport& report) {
  const std::string& stage = report.stage;
  const std::string detail = report.detail.empty() ? "" : "  " + report.detail;
  std::lock_guard<std::mutex> lock(mutex_);
  const double fraction = std::clamp(report.fraction, 0.0, 1.0);
  const auto now = std::chrono::steady_clock::now();
  const bool new_stage = stage != stage_;
  if (new_stage) {
    if (line_open_ && interactive_) std::fputc('\n', stream_);
    line_open_ = false;
    stage_ = stage;
    last_quarter_ = -1;
    stage_start_ = now;
  }
  const double elapsed = std::chrono::duration<double>(now - stage_start_).count();
  if (interactive_) {
    // Redrawing faster than 10 Hz only costs time.
    if (!new_stage && fraction < 1.0 && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth + 0.5);
    // "\033[K" clears what a longer detail left on the line.
    std::fprintf(stream_, "\r%-16s [%s%s] %3d%% %6.1fs%s\033[K", stage.c_str(), std::string(filled, '#').c_str(),
                 std::string(kWidth - filled, ' ').c_str(), static_cast<int>(fraction * 100 + 0.5), elapsed,
                 detail.c_str());
    line_open_ = true;
  } else {
    const int quarter = static_cast<int>(fraction * 4);
    if (quarter == last_quarter_) return;
    last_quarter_ = quarter;
    std::fprintf(stream_, "%-16s %3d%% %6.1fs%s\n", stage.c_str(), quarter * 25, elapsed, detail.c_str());
  }
  std::fflush(stream_);
}

void ProgressBar::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (line_open_ && interactive_) std::fputc('\n', stream_);
  line_open_ = false;
  stage_.clear();
  std::fflush(stream_);
}

}  // namespace scanbench
