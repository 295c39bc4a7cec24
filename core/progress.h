// Progress as algorithms and controllers report it.
#pragma once

#include <functional>
#include <string>

namespace scanbench {

// What an algorithm reports: the fraction done in [0, 1]. Returning false asks
// it to stop; it then ends with Termination::kCancelled (or throws Cancelled
// where it has no summary).
using ProgressCallback = std::function<bool(double fraction_done)>;

// The callback for a sub-step that runs over [begin, end] of the caller's
// range; empty when `progress` is.
ProgressCallback SubRange(const ProgressCallback& progress, double begin, double end);

// What a controller reports: the stage that runs now ("decode", "solve
// sessions"), an optional detail ("7/19 done, ETA 1:20") and the fraction of
// that stage done, [0, 1].
struct ProgressReport {
  std::string stage;
  std::string detail;
  double fraction = 0;
};
using ProgressReportCallback = std::function<void(const ProgressReport& report)>;

}  // namespace scanbench
