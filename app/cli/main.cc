// scanbench: the command line. Every command drives the same controllers the
// GUI uses.
#include <CLI/CLI.hpp>

#include "app/cli/commands.h"
#include "app/cli/run_controller.h"

#if defined(__GLIBC__)
#include <malloc.h>  // mallopt
#endif

int main(int argc, char** argv) {
#if defined(__GLIBC__)
  // Full-size images (16-200 MB each at 16 MP) come and go stage by stage.
  // After the first large free glibc raises its mmap threshold to 32 MB and
  // serves smaller ones from its heaps, whose freed pages it keeps: a fixed
  // 1 MiB threshold maps each image on its own and returns it whole when
  // freed (solve at 16 MP: peak RSS 2.47 -> 2.02 GB, docs/solver.md "Memory").
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
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
