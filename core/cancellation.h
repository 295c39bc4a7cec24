// The one way a job says it was stopped. Algorithms return
// Termination::kCancelled in their summary when their progress callback
// returns false; code that cannot return a summary (controllers' Run(), the
// simulator's renders) throws Cancelled. RequireSuccess turns the first into
// the second.
#pragma once

#include <stdexcept>
#include <string>

namespace scanbench {

class Cancelled : public std::runtime_error {
 public:
  // where: the stage or step that noticed the stop ("solve", "render frame").
  explicit Cancelled(const std::string& where) : std::runtime_error("cancelled during " + where) {}
};

}  // namespace scanbench
