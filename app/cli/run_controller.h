// Runs a controller for the command line: progress bar on stderr, Ctrl-C
// turns into RequestStop(), failures into a message and an exit code.
#pragma once

#include "app/controllers/base_controller.h"

namespace scanbench {

inline constexpr int kExitSuccess = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitCancelled = 130;

// `observer`, when set, sees every progress report too (after the bar), e.g.
// to time the moment a stage ends.
int RunController(BaseController& controller, const ProgressReportCallback& observer = {});

}  // namespace scanbench
