// Pieces every command group shares.
#pragma once

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "app/cli/option_fields.h"
#include "app/cli/run_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/sim/simulated_rig.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// Runs a command; an error becomes a message (in the command line's words:
// option_fields.h) and an exit code, never an uncaught exception.
template <typename Function>
void Guarded(int* exit_code, Function&& function) {
  try {
    *exit_code = function();
  } catch (const std::exception& error) {
    std::cerr << "scanbench: error: " << CommandLineMessage(error) << "\n";
    *exit_code = kExitFailure;
  }
}

// --method, --threads, --shadow-level and the other solver options, for every
// command that solves.
void AddPhotometricSolverOptions(CLI::App& command, PhotometricSolverOptions& options);

// --depth-iterations, --depth-tolerance, --depth-min-range,
// --depth-anchor-percentile, --depth-shadow-edge and --no-depth-refine (issue
// #15): `solve`, `batch` and `solve-dataset` take the same ones.
void AddDepthRefinementOptions(CLI::App& command, DepthRefinementOptions& depth);

// The solver options plus --label, --demosaic, --no-verify and the
// calibration set: `solve` and `batch` take the same ones.
void AddSolveOptions(CLI::App& command, SolveOptions& options);

// --camera-color d5100|srgb-primaries: the simulated camera's colour model
// (simulate, demo, calibrate simulate-targets, calibrate demo).
void AddCameraColorOption(CLI::App& command, SensorColorModel& color);

// --material lambert|cloth|satin: the simulated textile's material
// (simulate, demo, capture --rig sim; issue #13).
void AddMaterialOption(CLI::App& command, SurfaceMaterial& material);

}  // namespace scanbench
