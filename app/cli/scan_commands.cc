// demo, simulate and solve: the simulated scan end to end and its parts.
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/export_controller.h"
#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

void AddSimulateOptions(CLI::App& command, SimulateOptions& options) {
  SetsField(command.add_option("--width", options.rig.width, "Image width in pixels (4928 = full Nikon D5100)"),
            {"SimulatedRigOptions.width", "MakeDefaultSimulatedRig.width"})
      ->capture_default_str();
  SetsField(command.add_option("--height", options.rig.height, "Image height in pixels (3264 = full Nikon D5100)"),
            {"SimulatedRigOptions.height", "MakeDefaultSimulatedRig.height"})
      ->capture_default_str();
  command.add_option("--seed", options.rig.seed, "Sensor noise seed")->capture_default_str();
  command.add_option("--scene-seed", options.scene.seed, "Textile variation seed")->capture_default_str();
  SetsField(command.add_option("--warp-pitch", options.scene.warp_pitch_mm, "Warp thread spacing, mm"),
            "TextileSceneOptions.warp_pitch_mm")
      ->capture_default_str();
  SetsField(command.add_option("--weft-pitch", options.scene.weft_pitch_mm, "Weft thread spacing, mm"),
            "TextileSceneOptions.weft_pitch_mm")
      ->capture_default_str();
  SetsField(command.add_option(
                "--fold-amplitude", options.scene.fold_amplitude_mm,
                "Fold amplitude, mm: the folds lift the cloth by 0 .. 2x this (the default 2.5 = +-2.5 mm about "
                "their mean; 25 = a draped sample, +-25 mm)"),
            "TextileSceneOptions.fold_amplitude_mm")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  SetsField(command.add_option("--sample-name", options.sample_name, "Sample name recorded in session.json"),
            "SimulateOptions.sample_name")
      ->capture_default_str();
  command.add_flag("--no-noise", [&options](std::int64_t) { options.rig.add_noise = false; },
                   "Render without sensor noise");
  command.add_flag("--no-shadows", [&options](std::int64_t) { options.rig.cast_shadows = false; },
                   "Render without cast shadows");
  SetsField(command.add_option("--render-threads", options.rig.num_threads, "Render threads (0 = all cores)"),
            "SimulatedRigOptions.num_threads")
      ->capture_default_str();
  command
      .add_option_function<std::string>(
          "--rig-description",
          [&options](const std::string& kind) {
            options.rig_description = kind == "measured" ? SimulateOptions::RigDescriptionKind::kMeasured
                                                         : SimulateOptions::RigDescriptionKind::kTrue;
          },
          "Rig description written into session.json: true (the simulator's, default) or measured (LED positions "
          "a few mm off, nominal LEDs and camera: solve it with --calibration)")
      ->check(CLI::IsMember({"true", "measured"}));
  command
      .add_option_function<std::string>(
          "--sample",
          [&options](const std::string& kind) {
            options.scene.sample = kind == "colorchecker" ? SampleKind::kColorChecker : SampleKind::kTextile;
          },
          "What lies on the table: twill (the textile, default) or colorchecker (a ColorChecker Classic card, 16 mm "
          "patches on a 20 mm pitch, rendered from its measured spectra; ground truth = each patch's linear Rec.709)")
      ->check(CLI::IsMember({"twill", "colorchecker"}));
  AddCameraColorOption(command, options.rig.color);
  AddMaterialOption(command, options.scene.material);  // issue #13
}

// The default sample name follows the sample unless one was given.
SimulateOptions WithSampleName(SimulateOptions options) {
  if (options.scene.sample == SampleKind::kColorChecker && options.sample_name == SimulateOptions().sample_name) {
    options.sample_name = "simulated ColorChecker Classic";
  } else if (options.scene.material != SurfaceMaterial::kLambert && options.sample_name == SimulateOptions().sample_name) {
    options.sample_name = std::string("simulated ") + SurfaceMaterialName(options.scene.material) + " twill";
  }
  return options;
}

int Solve(const fs::path& session_dir, const SolveOptions& options) {
  SolveController solve(session_dir, options);
  const int code = RunController(solve);
  if (code == kExitSuccess) std::cout << solve.summary().FullReport();
  return code;
}

int Simulate(const fs::path& session_dir, const SimulateOptions& options) {
  SimulateController controller(session_dir, WithSampleName(options));
  const int code = RunController(controller);
  if (code == kExitSuccess) {
    std::cout << "Session written to " << fs::absolute(session_dir).string() << " ("
              << controller.summary().frames_written << " frames rendered, " << controller.summary().frames_resumed
              << " already there)\n";
  }
  return code;
}

struct DemoState {
  fs::path output = "scanbench-demo";
  SimulateOptions simulate;
  SolveOptions solve;
  bool export_maps = true;   // derived maps (issue #7), png16 with OpenGL normals
  ExportOptions export_options;  // the defaults: png16, OpenGL normals, DCT height
};

int Demo(const DemoState& state) {
  // Every option is checked before anything is written: a rejected demo leaves no folder behind.
  WithSampleName(state.simulate).Check();
  state.solve.Check();
  if (state.export_maps) state.export_options.Check();
  const fs::path session_dir = state.output / "session";
  if (fs::exists(session_dir / "session.json") && LoadSession(session_dir).capture_complete) {
    std::cout << "Re-solving the existing demo session " << fs::absolute(session_dir).string()
              << " into a new result folder\n";
  } else {
    fs::create_directories(state.output);
    const int code = Simulate(session_dir, state.simulate);
    if (code != kExitSuccess) return code;
  }
  SolveController solve(session_dir, state.solve);
  int code = RunController(solve);
  if (code != kExitSuccess) return code;
  std::cout << solve.summary().FullReport();
  if (!state.export_maps) return code;
  // The derived maps a material pipeline picks up, beside the result.
  ExportController exporter(solve.summary().result_dir, state.export_options);
  code = RunController(exporter);
  if (code == kExitSuccess) std::cout << exporter.summary().FullReport();
  return code;
}

}  // namespace

void RegisterScanCommands(CLI::App& app, int* exit_code) {
  auto demo = std::make_shared<DemoState>();
  CLI::App* demo_command = app.add_subcommand(
      "demo", "Simulate a capture on the simulated rig, solve it, write maps and a report, and export the derived "
              "maps (height, occlusion, cavity, roughness mips; png16, OpenGL normals) into session/exports/. "
              "Run again to re-solve the same session into a new result and export folder.");
  demo_command->add_option("--output", demo->output, "Folder for the demo session")->capture_default_str();
  AddSimulateOptions(*demo_command, demo->simulate);
  SetsField(demo_command->add_option("--threads", demo->solve.solver.num_threads, "Solver threads (0 = all cores)"),
            "PhotometricSolverOptions.num_threads")
      ->capture_default_str();
  demo_command->add_option("--calibration", demo->solve.calibration_dir,  // issue #4
                           "Calibration set to solve with (scanbench calibrate demo makes one)")
      ->check(CLI::ExistingDirectory);
  demo_command->add_flag("--no-export", [demo](std::int64_t) { demo->export_maps = false; },
                         "Stop after the solve (no derived maps)");
  demo_command->callback([demo, exit_code] { Guarded(exit_code, [&] { return Demo(*demo); }); });

  auto simulate_dir = std::make_shared<fs::path>();
  auto simulate = std::make_shared<SimulateOptions>();
  CLI::App* simulate_command = app.add_subcommand(
      "simulate", "Render a capture session (DNG frames, session.json, ground truth) on the simulated rig. "
                  "An interrupted run resumes when started again with the same options.");
  simulate_command->add_option("session", *simulate_dir, "Session folder to write")->required();
  AddSimulateOptions(*simulate_command, *simulate);
  simulate_command->callback([simulate_dir, simulate, exit_code] {
    Guarded(exit_code, [&] { return Simulate(*simulate_dir, *simulate); });
  });

  auto solve_dir = std::make_shared<fs::path>();
  auto solve = std::make_shared<SolveOptions>();
  CLI::App* solve_command = app.add_subcommand(
      "solve", "Solve a session's normal and albedo maps into a new results/<run-id>/ folder beside earlier ones");
  solve_command->add_option("session", *solve_dir, "Session folder (holding session.json)")
      ->required()
      ->check(CLI::ExistingDirectory);
  AddSolveOptions(*solve_command, *solve);
  solve_command->callback([solve_dir, solve, exit_code] {
    Guarded(exit_code, [&] { return Solve(*solve_dir, *solve); });
  });
}

}  // namespace scanbench
