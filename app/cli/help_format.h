// --help as an operator reads it (issue #36): every description wrapped to the
// terminal's width, flags shown by their names alone.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace scanbench {

// The width --help wraps to: $COLUMNS when set to a number, else the width of
// the terminal on stdout (ioctl TIOCGWINSZ), else 100; at least 40.
size_t HelpColumns();

// `text` wrapped at spaces into lines of at most `width` characters (a longer
// word keeps a line of its own). Each line break of `text` is kept; a line that
// starts a table row ("name   description", two or more spaces after its first
// word) continues under its description, an indented line under its indent.
std::vector<std::string> WrapText(const std::string& text, size_t width);

// CLI11's formatter with descriptions wrapped to `columns`, and flag names
// without CLI11's "{false}" value marks (the description says what each does).
class WrappingFormatter : public CLI::Formatter {
 public:
  explicit WrappingFormatter(size_t columns);

  std::string make_option(const CLI::Option* option, bool is_positional) const override;
  std::string make_option_name(const CLI::Option* option, bool is_positional) const override;
  std::string make_description(const CLI::App* app) const override;
  std::string make_subcommand(const CLI::App* sub) const override;
  std::string make_footer(const CLI::App* app) const override;
  // An option group (capture's "solve" options): CLI11 indents it by 2, so its lines wrap 2 earlier.
  std::string make_expanded(const CLI::App* sub) const override;

 private:
  // name in the left column, description wrapped beside it.
  std::string TwoColumns(const std::string& name, const std::string& description) const;

  // The width left for the text being made: columns_ less the indent of the groups it is in.
  size_t Width() const { return columns_ - std::min(columns_ / 2, 2 * nesting_); }

  size_t columns_;
  mutable size_t nesting_ = 0;  // option groups being expanded (help is made on one thread)
};

}  // namespace scanbench
