// The one shape every algorithm's summary shares (after Ceres' Solver::Summary):
// how the call ended, why, whether its result may be used, and a one-line
// report. A Summary type derives from AlgorithmSummary, adds its figures and
// defines `std::string BriefReport() const`.
#pragma once

#include <string>

namespace scanbench {

enum class Termination {
  kSuccess,    // the outputs hold the result
  kFailure,    // the inputs could not give a result; `message` says why
  kCancelled,  // the progress callback asked to stop; outputs are partial
};
// "success", "failure", "cancelled".
const char* TerminationName(Termination termination);

struct AlgorithmSummary {
  Termination termination = Termination::kFailure;
  // Why it failed or was cancelled; on success empty or a note.
  std::string message;

  // Success by default; a summary whose result also has to pass quality
  // rules hides this with its own.
  bool IsUsable() const { return termination == Termination::kSuccess; }
  bool IsCancelled() const { return termination == Termination::kCancelled; }

  void SetCancelled(std::string why = "cancelled") {
    termination = Termination::kCancelled;
    message = std::move(why);
  }
  void SetFailure(std::string why) {
    termination = Termination::kFailure;
    message = std::move(why);
  }
};

// For callers that cannot go on without the result (controllers): throws
// Cancelled for a cancelled summary and std::runtime_error("<what>: <message>")
// for a failed one; returns for a success.
void RequireSuccess(const AlgorithmSummary& summary, const std::string& what);

}  // namespace scanbench
