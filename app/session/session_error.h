// The one exception type of app/session. Its message always starts with the
// file it is about, then the field: "<file>: <field>: <value> <rule broken>".
#pragma once

#include <stdexcept>
#include <string>

namespace scanbench {

class SessionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace scanbench
