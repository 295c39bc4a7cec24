#include "app/controllers/progress_plans.h"

namespace scanbench {

std::vector<ProgressStagePlan> CaptureProgressPlan(const CaptureOptions& options, int num_leds) {
  std::vector<ProgressStagePlan> plan;
  if (options.check_exposure && !options.resume) plan.push_back({"exposure check", double(num_leds)});
  plan.push_back({"capture", double(num_leds + 1)});
  return plan;
}

// Rough shares of a solve's wall time at 16 MP (docs/solver.md's timings), in
// the units of a captured frame (a few seconds on the bench).
std::vector<ProgressStagePlan> SolveProgressPlan() {
  return {{"load session", 1}, {"decode RAW", 4}, {"solve", 4}, {"depth refine", 2}, {"write maps", 2}};
}

std::vector<ProgressStagePlan> LiveSolveProgressPlan(const CaptureOptions& capture, int num_leds) {
  std::vector<ProgressStagePlan> plan = CaptureProgressPlan(capture, num_leds);
  for (const ProgressStagePlan& stage : SolveProgressPlan()) plan.push_back(stage);
  return plan;
}

}  // namespace scanbench
