// Each group of subcommands registers itself on the CLI11 app. A command's
// callback stores its exit code in *exit_code; its options live in state the
// callback owns.
#pragma once

#include <CLI/CLI.hpp>

namespace scanbench {

// demo, simulate, solve
void RegisterScanCommands(CLI::App& app, int* exit_code);
void RegisterDeviceCommands(CLI::App& app, int* exit_code);  // devices, led
void RegisterCaptureCommands(CLI::App& app, int* exit_code);  // capture
void RegisterImportCommands(CLI::App& app, int* exit_code);  // import, bench init (issue #15)
void RegisterCameraCommands(CLI::App& app, int* exit_code);  // camera list|info|capture|preview
void RegisterDatasetCommands(CLI::App& app, int* exit_code);  // solve-dataset, simulate-dataset, solver-report
void RegisterBatchCommands(CLI::App& app, int* exit_code);  // batch (issue #7)
void RegisterExportCommands(CLI::App& app, int* exit_code);  // export (issue #7)

void RegisterCalibrateCommands(CLI::App& app, int* exit_code);  // calibrate camera|white|lights|simulate-targets|edge-error|demo

}  // namespace scanbench
