// scanbench: the command line. Every command drives the same controllers the
// GUI uses; Ctrl-C asks the running controller to stop.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include <CLI/CLI.hpp>

#include "app/cli/progress_bar.h"
#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/session/session.h"

namespace fs = std::filesystem;
using namespace scanbench;

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitCancelled = 130;

volatile std::sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

// Runs the controller on a worker thread so that Ctrl-C, noticed here, turns
// into RequestStop() and the job ends cleanly at its next check.
int RunController(BaseController& controller) {
  ProgressBar bar;
  controller.SetProgressCallback([&](const std::string& stage, double fraction) { bar.Update(stage, fraction); });
  g_interrupted = 0;
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  std::exception_ptr failure;
  std::atomic<bool> finished{false};
  std::thread worker([&] {
    try {
      controller.Run();
    } catch (...) {
      failure = std::current_exception();
    }
    finished = true;
  });
  while (!finished) {
    if (g_interrupted) controller.RequestStop();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  worker.join();
  bar.Finish();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (failure) {
    try {
      std::rethrow_exception(failure);
    } catch (const JobCancelled& cancelled) {
      std::cerr << "scanbench: " << cancelled.what() << "; nothing was lost (frames and earlier results are intact)\n";
      return kExitCancelled;
    } catch (const std::exception& error) {
      std::cerr << "scanbench: error: " << error.what() << "\n";
      return kExitFailure;
    }
  }
  return 0;
}

void AddSimulateOptions(CLI::App& command, SimulateOptions& options) {
  command.add_option("--width", options.rig.width, "Image width in pixels (4928 = full Nikon D5100)")
      ->capture_default_str();
  command.add_option("--height", options.rig.height, "Image height in pixels (3264 = full Nikon D5100)")
      ->capture_default_str();
  command.add_option("--seed", options.rig.seed, "Sensor noise seed")->capture_default_str();
  command.add_option("--scene-seed", options.scene.seed, "Textile variation seed")->capture_default_str();
  command.add_option("--sample-name", options.sample_name, "Sample name recorded in session.json")
      ->capture_default_str();
  command.add_flag("--no-noise", [&](std::int64_t) { options.rig.add_noise = false; }, "Render without sensor noise");
  command.add_flag("--no-shadows", [&](std::int64_t) { options.rig.cast_shadows = false; },
                   "Render without cast shadows");
  command.add_option("--threads", options.rig.num_threads, "Render threads (0 = all cores)")->capture_default_str();
}

void AddSolveOptions(CLI::App& command, SolveOptions& options) {
  command.add_option("--threads", options.solver.num_threads, "Solver threads (0 = all cores)")
      ->capture_default_str();
  command.add_option("--label", options.run_label, "Label in the result folder name")->capture_default_str();
  command.add_option("--max-condition", options.solver.max_condition_number,
                     "Flag pixels whose light matrix is worse conditioned than this")
      ->capture_default_str();
  command
      .add_option_function<std::string>(
          "--demosaic",
          [&](const std::string& name) {
            options.develop.demosaic =
                name == "bilinear" ? RawDevelopOptions::Demosaic::kBilinear : RawDevelopOptions::Demosaic::kEdgeAware;
          },
          "Bayer interpolation: edge_aware (default) or bilinear")
      ->check(CLI::IsMember({"edge_aware", "bilinear"}));
  command.add_flag("--no-verify", [&](std::int64_t) { options.verify_checksums = false; },
                   "Skip re-hashing the frames against session.json");
}

int Solve(const fs::path& session_dir, const SolveOptions& options) {
  SolveController solve(session_dir, options);
  const int code = RunController(solve);
  if (code != 0) return code;
  std::cout << solve.summary().FullReport();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"scanbench: photometric-stereo textile scanner (albedo and normal maps)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "scanbench " SCANBENCH_VERSION);

  // demo: the main job, on the simulated rig.
  fs::path demo_dir = "scanbench-demo";
  SimulateOptions demo_simulate;
  SolveOptions demo_solve;
  CLI::App* demo = app.add_subcommand(
      "demo", "Simulate a capture on the simulated rig, solve it and write maps and a report. "
              "Run again to re-solve the same session into a new result folder.");
  demo->add_option("--output", demo_dir, "Folder for the demo session")->capture_default_str();
  AddSimulateOptions(*demo, demo_simulate);
  demo->add_option("--solver-threads", demo_solve.solver.num_threads, "Solver threads (0 = all cores)");

  fs::path simulate_dir;
  SimulateOptions simulate_options;
  CLI::App* simulate = app.add_subcommand(
      "simulate", "Render a capture session (DNG frames, session.json, ground truth) on the simulated rig. "
                  "An interrupted run resumes when started again with the same options.");
  simulate->add_option("session", simulate_dir, "Session folder to write")->required();
  AddSimulateOptions(*simulate, simulate_options);

  fs::path solve_dir;
  SolveOptions solve_options;
  CLI::App* solve = app.add_subcommand(
      "solve", "Solve a session's normal and albedo maps into a new results/<run-id>/ folder");
  solve->add_option("session", solve_dir, "Session folder (holding session.json)")->required()->check(
      CLI::ExistingDirectory);
  AddSolveOptions(*solve, solve_options);

  CLI11_PARSE(app, argc, argv);

  try {
    if (*simulate) {
      SimulateController controller(simulate_dir, simulate_options);
      const int code = RunController(controller);
      if (code != 0) return code;
      std::cout << "Session written to " << fs::absolute(simulate_dir).string() << " ("
                << controller.summary().frames_written << " frames rendered, " << controller.summary().frames_resumed
                << " already there)\n";
      return 0;
    }
    if (*solve) return Solve(solve_dir, solve_options);
    if (*demo) {
      const fs::path session_dir = demo_dir / "session";
      bool complete = false;
      if (fs::exists(session_dir / "session.json")) complete = LoadSession(session_dir).capture_complete;
      if (complete) {
        std::cout << "Re-solving the existing demo session " << fs::absolute(session_dir).string() << "\n";
      } else {
        fs::create_directories(demo_dir);
        SimulateController controller(session_dir, demo_simulate);
        const int code = RunController(controller);
        if (code != 0) return code;
      }
      return Solve(session_dir, demo_solve);
    }
  } catch (const std::exception& error) {
    std::cerr << "scanbench: error: " << error.what() << "\n";
    return kExitFailure;
  }
  return 0;
}
