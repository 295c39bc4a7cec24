// Runs a shell command (the real `scanbench` binary, as a user would) and
// collects its exit code and output, for the CLI tests.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace scanbench {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

inline CommandResult RunShell(const std::string& command) {
  CommandResult result;
  std::FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t read = 0;
  while ((read = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), read);
  const int status = ::pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// Single-quoted for the shell (test paths hold no single quote). Appended
// rather than `"'" + string`, which GCC 12 flags with a false -Wrestrict.
inline std::string Quoted(const std::filesystem::path& path) {
  std::string quoted = "'";
  quoted += path.string();
  quoted += '\'';
  return quoted;
}

#ifdef SCANBENCH_CLI
// The command line that runs the scanbench binary under test with `arguments`.
inline std::string CliCommand(const std::string& arguments) { return Quoted(SCANBENCH_CLI) + " " + arguments; }
inline CommandResult RunScanbench(const std::string& arguments) { return RunShell(CliCommand(arguments)); }
#endif

}  // namespace scanbench
