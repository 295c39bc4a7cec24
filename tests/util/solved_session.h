// Test helpers for the tests that need a simulated session on disk: one
// solved with the default options, one with folds, and a JSON file read back.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"

namespace scanbench::testing {

// Simulates `session` (width x height, the given sample name, default scene
// and seed), solves it and returns the result folder.
inline std::filesystem::path SimulateAndSolve(const std::filesystem::path& session, int width, int height,
                                              const std::string& sample_name) {
  SimulateOptions simulate;
  simulate.rig.width = width;
  simulate.rig.height = height;
  simulate.sample_name = sample_name;
  SimulateController(session, simulate).Run();
  SolveController solve(session, SolveOptions());
  solve.Run();
  return solve.summary().result_dir;
}

// Simulates `session` (width x height, the default textile scene and seed)
// draped in folds of the given amplitude, and returns its folder.
inline std::filesystem::path SimulateFoldedSession(const std::filesystem::path& session, int width, int height,
                                                   double fold_amplitude_mm) {
  SimulateOptions simulate;
  simulate.rig.width = width;
  simulate.rig.height = height;
  simulate.scene.fold_amplitude_mm = fold_amplitude_mm;
  SimulateController(session, simulate).Run();
  return session;
}

inline nlohmann::json ReadJsonFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

}  // namespace scanbench::testing
