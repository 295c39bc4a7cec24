// scanbench: the command line. Every command drives the same controllers the
// GUI uses.
#include <CLI/CLI.hpp>
#include <iostream>
#include <memory>

#include "app/cli/commands.h"
#include "app/cli/help_format.h"
#include "app/cli/option_fields.h"
#include "app/cli/parse_errors.h"
#include "app/cli/run_controller.h"
#include "core/memory.h"

int main(int argc, char** argv) {
  scanbench::ReturnFreedImagesToTheSystem();
  // Named, not argv[0]: usage lines read "scanbench solve [OPTIONS] session" wherever the binary lies.
  CLI::App app{"scanbench: photometric-stereo textile scanner (albedo and normal maps)", "scanbench"};
  // Before the commands: each subcommand takes its parent's formatter.
  app.formatter(std::make_shared<scanbench::WrappingFormatter>(scanbench::HelpColumns()));
  app.require_subcommand(1);
  app.set_version_flag("--version", "scanbench " SCANBENCH_VERSION);
  int exit_code = scanbench::kExitSuccess;
  scanbench::RegisterScanCommands(app, &exit_code);
  scanbench::RegisterDeviceCommands(app, &exit_code);
  scanbench::RegisterCaptureCommands(app, &exit_code);
  scanbench::RegisterImportCommands(app, &exit_code);
  scanbench::RegisterDatasetCommands(app, &exit_code);
  scanbench::RegisterBatchCommands(app, &exit_code);
  scanbench::RegisterExportCommands(app, &exit_code);
  scanbench::RegisterCameraCommands(app, &exit_code);
  scanbench::RegisterCalibrateCommands(app, &exit_code);
  scanbench::SetCommandLineRoot(&app);  // option errors name the options of the command run
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return scanbench::ExitOnParseError(app, error, std::cout, std::cerr);
  }
  return exit_code;
}
