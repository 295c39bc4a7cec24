// What every derived-map algorithm shares: how it ended and a progress hook.
// Derived maps are computed from solved maps in memory (no file I/O here).
#pragma once

#include <functional>
#include <string>

namespace scanbench {

enum class MapTermination { kSuccess, kCancelled, kFailure };
const char* MapTerminationName(MapTermination termination);

// Called with the fraction done in [0, 1]; returning false cancels the job.
using MapProgressCallback = std::function<bool(double fraction_done)>;

}  // namespace scanbench
