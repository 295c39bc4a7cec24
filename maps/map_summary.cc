#include "maps/map_summary.h"

namespace scanbench {

const char* MapTerminationName(MapTermination termination) {
  switch (termination) {
    case MapTermination::kSuccess: return "success";
    case MapTermination::kCancelled: return "cancelled";
    case MapTermination::kFailure: return "failure";
  }
  return "unknown";
}

}  // namespace scanbench
