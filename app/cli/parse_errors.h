// What the command line says when it cannot parse what the user typed (issue
// #36): CLI11's message, a "did you mean" for a misspelt option or
// subcommand, and exit code 1 for every parse error (README: errors exit 1);
// --help and --version exit 0.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace scanbench {

// Edits (insert, delete, substitute, swap two neighbours) from `a` to `b`.
size_t EditDistance(const std::string& a, const std::string& b);

// The candidates closest to `typed` (ties all), if close enough to be a
// likely typo: at most 2 edits and fewer than half of its characters, or
// `typed` the start of one (at least 3 characters); else none.
std::vector<std::string> ClosestNames(const std::string& typed, const std::vector<std::string>& candidates);

// "did you mean ..." lines for the arguments `root`'s parse left over: an
// option among those of the command given (its own and its option groups',
// "--widht" -> "--width"), a word among its subcommands.
std::vector<std::string> Suggestions(const CLI::App& root);

// Prints `error` as CLI11 does (help and version on stdout, errors on stderr
// with the suggestions) and returns the exit code: 0 for --help and
// --version, 1 for every error.
int ExitOnParseError(const CLI::App& root, const CLI::ParseError& error, std::ostream& out, std::ostream& err);

}  // namespace scanbench
