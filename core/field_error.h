// The one form of an options error: "where.field = value rule".
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace scanbench {

template <typename T>
std::invalid_argument FieldError(const std::string& where, const std::string& field, const T& value,
                                 const std::string& rule) {
  std::ostringstream text;
  text << where << "." << field << " = " << value << " " << rule;
  return std::invalid_argument(text.str());
}

}  // namespace scanbench
