// The stages a job reports, in order, with their rough share of its wall
// time: what JobProgress (core/job_progress.h) needs to show a capture, a
// solve or a capture with solve-while-capturing as one bar (issue #36 item 8).
#pragma once

#include <vector>

#include "app/controllers/capture_controller.h"
#include "core/job_progress.h"

namespace scanbench {

// "exposure check" (when asked for: not on a resume), then "capture", each by its frames.
std::vector<ProgressStagePlan> CaptureProgressPlan(const CaptureOptions& options, int num_leds);
// SolveController's stages: "load session", "decode RAW", "solve", "depth refine", "write maps".
std::vector<ProgressStagePlan> SolveProgressPlan();
// LiveSolveController: the capture's, then the solve's (decoding runs beside the capture).
std::vector<ProgressStagePlan> LiveSolveProgressPlan(const CaptureOptions& capture, int num_leds);

}  // namespace scanbench
