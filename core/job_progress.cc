#include "core/job_progress.h"

#include <algorithm>
#include <cmath>

namespace scanbench {

JobProgress::JobProgress(std::vector<ProgressStagePlan> plan) : plan_(std::move(plan)) {
  for (const ProgressStagePlan& stage : plan_) total_weight_ += std::max(0.0, stage.weight);
  double start = 0;
  for (const ProgressStagePlan& stage : plan_) {
    starts_.push_back(total_weight_ > 0 ? start / total_weight_ : 0);
    start += std::max(0.0, stage.weight);
  }
}

void JobProgress::Update(const ProgressReport& report) {
  if (finished_) return;
  const double f = std::isfinite(report.fraction) ? std::clamp(report.fraction, 0.0, 1.0) : 0.0;
  stage_ = report.stage;
  detail_ = report.detail;
  stage_fraction_ = f;
  const auto planned = std::find_if(plan_.begin(), plan_.end(),
                                    [&](const ProgressStagePlan& stage) { return stage.stage == report.stage; });
  double overall;
  if (planned != plan_.end() && total_weight_ > 0) {
    const size_t i = static_cast<size_t>(planned - plan_.begin());
    stage_number_ = static_cast<int>(i) + 1;
    overall = starts_[i] + std::max(0.0, planned->weight) / total_weight_ * f;
    unplanned_stage_.clear();
  } else {
    stage_number_ = 0;
    if (report.stage != unplanned_stage_) {
      unplanned_stage_ = report.stage;
      unplanned_start_ = fraction_;
    }
    overall = unplanned_start_ + (1 - unplanned_start_) / 2 * f;
  }
  fraction_ = std::max(fraction_, std::min(1.0, overall));
}

void JobProgress::Finish(bool succeeded) {
  finished_ = true;
  succeeded_ = succeeded;
  if (succeeded) fraction_ = 1;
}

std::string JobProgress::Text() const {
  if (finished_) return succeeded_ ? "finished" : "stopped";
  if (stage_.empty()) return "starting";
  std::string text = stage_;
  if (stage_number_ > 0) {
    text += " (stage " + std::to_string(stage_number_) + " of " + std::to_string(plan_.size()) + ")";
  }
  text += ": " + std::to_string(static_cast<int>(stage_fraction_ * 100)) + " %";
  if (!detail_.empty()) text += " \u2014 " + detail_;
  return text;
}

}  // namespace scanbench
