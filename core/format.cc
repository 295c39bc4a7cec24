#include "core/format.h"

#include <cmath>
#include <algorithm>
#include <iomanip>
#include <sstream>

namespace scanbench {

std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string FormatDuration(double seconds) {
  const long total = std::isfinite(seconds) ? std::lround(std::max(seconds, 0.0)) : 0;
  std::ostringstream out;
  if (total >= 3600) out << total / 3600 << "h";
  out << std::setw(total >= 3600 ? 2 : 1) << std::setfill('0') << (total / 60) % 60 << ":" << std::setw(2)
      << total % 60;
  return out.str();
}

std::string XmlEscaped(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace scanbench
