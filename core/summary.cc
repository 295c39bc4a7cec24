#include "core/summary.h"

#include <stdexcept>

#include "core/cancellation.h"

namespace scanbench {

const char* TerminationName(Termination termination) {
  switch (termination) {
    case Termination::kSuccess: return "success";
    case Termination::kFailure: return "failure";
    case Termination::kCancelled: return "cancelled";
  }
  return "unknown";
}

void RequireSuccess(const AlgorithmSummary& summary, const std::string& what) {
  switch (summary.termination) {
    case Termination::kSuccess: return;
    case Termination::kCancelled: throw Cancelled(what);
    case Termination::kFailure: throw std::runtime_error(what + ": " + summary.message);
  }
}

}  // namespace scanbench
