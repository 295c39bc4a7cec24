#include "app/cli/help_format.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <sstream>

namespace scanbench {
namespace {

constexpr size_t kDefaultColumns = 100;
constexpr size_t kMinColumns = 40;

// Where a continuation line of `line` starts: under the description of a
// table row ("adaptive   Per pixel ..."), else under the line's own indent.
size_t HangingIndent(const std::string& line, size_t width) {
  const size_t indent = std::min(line.find_first_not_of(' '), line.size());
  const size_t word_end = line.find(' ', indent);
  if (word_end != std::string::npos && line.compare(word_end, 2, "  ") == 0) {
    const size_t description = line.find_first_not_of(' ', word_end);
    if (description != std::string::npos && description <= width / 2) return description;
  }
  return indent <= width / 2 ? indent : 0;
}

void WrapLine(const std::string& line, size_t width, std::vector<std::string>* lines) {
  if (line.size() <= width) {
    lines->push_back(line);
    return;
  }
  const size_t indent = std::min(line.find_first_not_of(' '), line.size());
  const size_t hanging = HangingIndent(line, width);
  // A table row keeps its name and gap as written; the rest is words.
  const bool table_row = hanging > indent;
  std::string current = line.substr(0, table_row ? hanging : indent);
  bool has_word = table_row;  // a word on `current` that a wrap would keep there
  bool need_space = false;    // `current` ends with a word, not with spaces
  std::istringstream words(line.substr(current.size()));
  std::string word;
  while (words >> word) {
    if (has_word && current.size() + (need_space ? 1 : 0) + word.size() > width) {
      lines->push_back(current);
      current = std::string(hanging, ' ');
      need_space = false;
    }
    current += (need_space ? " " : "") + word;
    has_word = need_space = true;
  }
  lines->push_back(current);
}

}  // namespace

size_t HelpColumns() {
  if (const char* columns = std::getenv("COLUMNS"); columns != nullptr && *columns != '\0') {
    char* end = nullptr;
    const long value = std::strtol(columns, &end, 10);
    if (end != nullptr && *end == '\0' && value > 0) return std::max<size_t>(kMinColumns, static_cast<size_t>(value));
  }
  winsize size{};
  if (::isatty(STDOUT_FILENO) && ::ioctl(STDOUT_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) {
    return std::max<size_t>(kMinColumns, size.ws_col);
  }
  return kDefaultColumns;
}

std::vector<std::string> WrapText(const std::string& text, size_t width) {
  std::vector<std::string> lines;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t end = std::min(text.find('\n', start), text.size());
    std::vector<std::string> wrapped;
    WrapLine(text.substr(start, end - start), std::max<size_t>(width, 1), &wrapped);
    lines.insert(lines.end(), wrapped.begin(), wrapped.end());
    if (end == text.size()) break;
    start = end + 1;
  }
  return lines;
}

WrappingFormatter::WrappingFormatter(size_t columns) : columns_(std::max(columns, kMinColumns)) {
  // Narrow terminals: the option column gives the descriptions room.
  column_width(std::min<size_t>(30, columns_ / 3));
}

std::string WrappingFormatter::TwoColumns(const std::string& name, const std::string& description) const {
  std::ostringstream out;
  std::string left = "  " + name;
  if (left.size() > Width()) {
    // A long name column (an option's Excludes: list) wraps too, its continuation indented under the name.
    const std::vector<std::string> parts = WrapText(name, Width() > 26 ? Width() - 6 : 20);
    left = "  " + parts.front();
    for (size_t i = 1; i < parts.size(); ++i) left += "\n      " + parts[i];
    if (!description.empty()) left += "\n";  // the description starts on a line of its own
    out << left;
    if (description.empty()) {
      out << "\n";
      return out.str();
    }
    const std::vector<std::string> lines =
        WrapText(description, Width() > column_width_ + 20 ? Width() - column_width_ : 20);
    for (const std::string& line : lines) out << std::string(column_width_, ' ') << line << "\n";
    return out.str();
  }
  out << left;
  if (description.empty()) {
    out << "\n";
    return out.str();
  }
  const size_t column = column_width_;
  if (left.size() >= column) {
    out << "\n" << std::string(column, ' ');
  } else {
    out << std::string(column - left.size(), ' ');
  }
  const std::vector<std::string> lines = WrapText(description, Width() > column + 20 ? Width() - column : 20);
  for (size_t i = 0; i < lines.size(); ++i) {
    if (i > 0) out << std::string(column, ' ');
    out << lines[i] << "\n";
  }
  return out.str();
}

std::string WrappingFormatter::make_option(const CLI::Option* option, bool is_positional) const {
  return TwoColumns(make_option_name(option, is_positional) + make_option_opts(option), make_option_desc(option));
}

std::string WrappingFormatter::make_option_name(const CLI::Option* option, bool is_positional) const {
  std::string name = CLI::Formatter::make_option_name(option, is_positional);
  // "--bayer-blend,--no-bayer-blend{false}" -> "--bayer-blend, --no-bayer-blend"
  for (size_t open = name.find('{'); open != std::string::npos; open = name.find('{', open)) {
    const size_t close = name.find('}', open);
    if (close == std::string::npos) break;
    name.erase(open, close - open + 1);
  }
  for (size_t comma = name.find(','); comma != std::string::npos; comma = name.find(',', comma + 2)) {
    if (comma + 1 < name.size() && name[comma + 1] != ' ') name.insert(comma + 1, " ");
  }
  return name;
}

std::string WrappingFormatter::make_description(const CLI::App* app) const {
  const std::string description = CLI::Formatter::make_description(app);
  if (description.empty()) return description;
  std::string out;
  for (const std::string& line : WrapText(description.substr(0, description.size() - 1), Width())) {
    out += line + "\n";
  }
  return out;
}

std::string WrappingFormatter::make_subcommand(const CLI::App* sub) const {
  return TwoColumns(sub->get_display_name(true), sub->get_description());
}

std::string WrappingFormatter::make_footer(const CLI::App* app) const {
  if (app->get_footer().empty()) return {};
  std::string out;
  for (const std::string& line : WrapText(app->get_footer(), Width())) out += line + "\n";
  return out;
}

std::string WrappingFormatter::make_expanded(const CLI::App* sub) const {
  ++nesting_;
  std::string expanded;
  try {
    expanded = CLI::Formatter::make_expanded(sub);
  } catch (...) {
    --nesting_;
    throw;
  }
  --nesting_;
  return expanded;
}

}  // namespace scanbench
