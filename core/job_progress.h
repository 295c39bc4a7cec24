// One bar for a whole job (issue #36 item 8), below the GUI and the CLI.
#pragma once

#include <string>
#include <vector>

#include "core/progress.h"

namespace scanbench {

// A stage a job expects to run, with its share of the job (any positive
// number: only the ratios count), as BaseController::ProgressPlan lists them.
struct ProgressStagePlan {
  std::string stage;
  double weight = 1;
};

// One job's progress as one bar (issue #36 item 8): the reports of its
// stages ("capture", then "decode RAW", "solve", ...) combined into a single
// fraction of the whole job that never decreases, with the stage that runs
// now named. Planned stages take their weight's share in plan order; a stage
// the plan does not name (or any stage of a job without a plan) takes half of
// what is left. A stage reported again after a later one (two threads) moves
// nothing back. Not thread-safe: the caller serialises Update.
class JobProgress {
 public:
  explicit JobProgress(std::vector<ProgressStagePlan> plan = {});

  void Update(const ProgressReport& report);
  // The job ended; `succeeded` false for a cancelled or failed one.
  void Finish(bool succeeded);

  double fraction() const { return fraction_; }           // of the whole job, [0, 1], never decreasing
  const std::string& stage() const { return stage_; }     // the latest report's
  const std::string& detail() const { return detail_; }
  double stage_fraction() const { return stage_fraction_; }
  int stage_number() const { return stage_number_; }      // 1-based, in the plan; 0 = not in it
  int stage_count() const { return static_cast<int>(plan_.size()); }
  bool finished() const { return finished_; }
  bool succeeded() const { return succeeded_; }

  // "solve (stage 3 of 5): 7 % — detail" while running (the stage's own
  // percentage); "finished" / "stopped" once Finish was called.
  std::string Text() const;

 private:
  std::vector<ProgressStagePlan> plan_;
  std::vector<double> starts_;  // per planned stage: the job's fraction where it begins
  double total_weight_ = 0;
  double fraction_ = 0;
  std::string stage_;
  std::string detail_;
  double stage_fraction_ = 0;
  int stage_number_ = 0;
  std::string unplanned_stage_;  // the unplanned stage running, and the job's fraction where it began
  double unplanned_start_ = 0;
  bool finished_ = false;
  bool succeeded_ = false;
};

}  // namespace scanbench
