// scanbench: the command line. Every command drives the same controllers the
// GUI uses.
#include <CLI/CLI.hpp>

#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "core/memory.h"

int main(int argc, char** argv) {
  scanbench::ReturnFreedImagesToTheSystem();
  CLI::App app{"scanbench: photometric-stereo textile scanner (albedo and normal maps)"};
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
  CLI11_PARSE(app, argc, argv);
  return exit_code;
}
