// The command line speaks the user's words (issue #36): a library's options
// error names a field ("SimulatedRigOptions.width = -5 must be > 0",
// core/field_error.h), the command line names the option the user typed
// ("--width -5: must be > 0"). Each option that sets a checked field says so
// where it is declared, with SetsField; the places that turn exceptions into
// messages (Guarded, RunController) print CommandLineMessage.
#pragma once

#include <exception>
#include <initializer_list>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/field_error.h"

namespace scanbench {

// Records that `option` sets `field`, written as the error names it:
// "SimulatedRigOptions.width". Returns `option`, to chain further calls. An
// option may set several fields (SetsField twice), a field be set by
// options of several commands: the command being run decides.
CLI::Option* SetsField(CLI::Option* option, const std::string& field);
CLI::Option* SetsField(CLI::Option* option, std::initializer_list<std::string> fields);

// The program's command tree (main sets it once parsed callbacks may run):
// which (sub)commands the user ran, for CommandLineMessage.
void SetCommandLineRoot(const CLI::App* root);

// error.what(), except that a FieldValueError of a field an option of the
// command being run sets reads "--option value: rule", with the other fields
// the rule names (e.g. "must be <= tile_width (7)") named by their options too.
std::string CommandLineMessage(const std::exception& error);

// The same for the given commands (those being run; their option groups
// count as theirs): for tests.
std::string CommandLineMessage(const std::exception& error, const std::vector<const CLI::App*>& commands);

// The root and the subcommands parsed below it, outermost first.
std::vector<const CLI::App*> ParsedCommands(const CLI::App* root);

// The options of `commands` and of their option groups (capture's "solve" options are capture's).
std::vector<const CLI::Option*> OptionsOf(const std::vector<const CLI::App*>& commands);

}  // namespace scanbench
