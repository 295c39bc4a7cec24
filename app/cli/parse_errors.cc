#include "app/cli/parse_errors.h"

#include <algorithm>
#include <ostream>

#include "app/cli/option_fields.h"
#include "app/cli/run_controller.h"

namespace scanbench {
namespace {

// Every name of the options of `command` and its option groups, as typed: "--width", "-j".
std::vector<std::string> OptionNames(const CLI::App& command) {
  std::vector<std::string> names;
  for (const CLI::Option* option : OptionsOf({&command})) {
    for (const std::string& name : option->get_lnames()) names.push_back("--" + name);
    for (const std::string& name : option->get_snames()) names.push_back("-" + name);
  }
  return names;
}

std::vector<std::string> SubcommandNames(const CLI::App& command) {
  std::vector<std::string> names;
  for (const CLI::App* sub : command.get_subcommands([](const CLI::App* sub) { return !sub->get_name().empty(); })) {
    names.push_back(sub->get_name());
  }
  return names;
}

// "scanbench calibrate lights": the commands as typed.
std::string CommandPath(const std::vector<const CLI::App*>& commands) {
  std::string path = "scanbench";
  for (size_t i = 1; i < commands.size(); ++i) path += " " + commands[i]->get_name();
  return path;
}

std::string JoinedAlternatives(const std::vector<std::string>& names) {
  std::string text;
  for (size_t i = 0; i < names.size(); ++i) text += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  return text;
}

}  // namespace

size_t EditDistance(const std::string& a, const std::string& b) {
  // Optimal string alignment: Levenshtein plus the swap of two neighbours ("widht").
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

std::vector<std::string> ClosestNames(const std::string& typed, const std::vector<std::string>& candidates) {
  // Dashes are not letters the user misspelt: "--widht" against "--width" compares "widht" and "width".
  const auto bare = [](const std::string& name) {
    return name.substr(std::min(name.find_first_not_of('-'), name.size()));
  };
  const std::string word = bare(typed);
  if (word.empty()) return {};
  std::vector<std::string> closest;
  size_t best = std::string::npos;
  for (const std::string& candidate : candidates) {
    const std::string name = bare(candidate);
    size_t distance = EditDistance(word, name);
    if (distance > 2 || 2 * distance >= word.size()) {
      if (word.size() >= 3 && name.compare(0, word.size(), word) == 0) {
        distance = 3;  // a start of the name: a suggestion, after the typos
      } else {
        continue;
      }
    }
    if (distance < best) {
      best = distance;
      closest.clear();
    }
    if (distance == best && std::find(closest.begin(), closest.end(), candidate) == closest.end()) {
      closest.push_back(candidate);
    }
  }
  return closest;
}

std::vector<std::string> Suggestions(const CLI::App& root) {
  const std::vector<const CLI::App*> commands = ParsedCommands(&root);
  const CLI::App& command = *commands.back();
  const std::vector<std::string> options = OptionNames(command);
  const std::vector<std::string> subcommands = SubcommandNames(command);
  const std::string path = CommandPath(commands);
  std::vector<std::string> lines;
  for (const std::string& argument : root.remaining(true)) {
    if (argument.size() > 1 && argument[0] == '-') {
      const std::string typed = argument.substr(0, argument.find('='));  // --widht=5
      const std::vector<std::string> closest = ClosestNames(typed, options);
      if (!closest.empty()) {
        lines.push_back(typed + ": no such option of `" + path + "`; did you mean " + JoinedAlternatives(closest) +
                        "?");
      } else {
        lines.push_back(typed + ": no such option of `" + path + "` (`" + path + " --help` lists them)");
      }
    } else if (!subcommands.empty()) {
      const std::vector<std::string> closest = ClosestNames(argument, subcommands);
      if (!closest.empty()) {
        lines.push_back(argument + ": no such command; did you mean `" + path + " " + JoinedAlternatives(closest) +
                        "`?");
      }
    }
  }
  return lines;
}

int ExitOnParseError(const CLI::App& root, const CLI::ParseError& error, std::ostream& out, std::ostream& err) {
  if (error.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) {
    // --help, --help-all, --version: CLI11 throws them as "errors" with exit code 0.
    return root.exit(error, out, err) == 0 ? kExitSuccess : kExitFailure;
  }
  if (error.get_name() == "RuntimeError") return error.get_exit_code();  // a command's own exit, not a parse error
  const std::vector<const CLI::App*> commands = ParsedCommands(&root);
  const std::string path = CommandPath(commands);
  err << "scanbench: error: " << error.what() << "\n";
  for (const std::string& line : Suggestions(root)) err << "  " << line << "\n";
  err << "Run `" << path << " --help` for its options.\n";
  return kExitFailure;
}

}  // namespace scanbench
