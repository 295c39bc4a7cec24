// solve-dataset: public photometric-stereo datasets (DiLiGenT, LUCES-style).
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/dataset_controller.h"
#include "app/controllers/simulate_dataset_controller.h"
#include "app/controllers/solver_report_controller.h"
#include "app/controllers/training_set_controller.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

struct SolveDatasetState {
  fs::path dataset_dir;
  DatasetSolveOptions options;
  bool lsq_baseline = false;
};

int SolveDatasetCommand(SolveDatasetState state) {
  if (state.lsq_baseline) {
    // The benchmark's least-squares baseline: every sample, plain pseudo-inverse.
    state.options.solver.method = PhotometricSolverOptions::Method::kJacobiSvd;
    state.options.solver.min_sample_value = 0;
  }
  if (state.options.output_dir.empty()) {
    state.options.output_dir =
        DefaultDatasetOutputFolder("scanbench-datasets", state.dataset_dir, state.options.solver.method);
    fs::create_directories(state.options.output_dir.parent_path());
  }
  DatasetController controller(state.dataset_dir, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) std::cout << controller.summary().FullReport();
  return code;
}

struct SimulateDatasetState {
  fs::path folder;
  SimulateDatasetOptions options;
};

int SimulateDatasetCommand(const SimulateDatasetState& state) {
  SimulateDatasetController controller(state.folder, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) std::cout << controller.summary().BriefReport() << "\n";
  return code;
}

int SolverReportCommand(const SolverReportOptions& options) {
  SolverReportController controller(options);
  const int code = RunController(controller);
  if (code == kExitSuccess) {
    std::cout << controller.summary().MarkdownTable() << "\nWritten: "
              << (options.output_dir / "report.md").string() << ", report.csv, error_vs_time.svg\n";
  }
  return code;
}

struct TrainingSetState {
  fs::path output;
  ObservationSetOptions options;
};

int TrainingSetCommand(const TrainingSetState& state) {
  TrainingSetController controller(state.output, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) std::cout << controller.summary().BriefReport() << "\nWritten: " << state.output.string() << "\n";
  return code;
}

}  // namespace

void RegisterDatasetCommands(CLI::App& app, int* exit_code) {
  auto state = std::make_shared<SolveDatasetState>();
  CLI::App* command = app.add_subcommand(
      "solve-dataset",
      "Solve a DiLiGenT-format or LUCES-style near-field dataset folder: normals (EXR + 16-bit PNG), albedo, "
      "confidence and, with Normal_gt.mat, the angular error over the mask");
  command->add_option("dataset", state->dataset_dir, "Dataset folder")->required()->check(CLI::ExistingDirectory);
  command->add_option("--output", state->options.output_dir,
                      "Output folder (default scanbench-datasets/<name>-<method>, or -2, -3, ... beside an earlier one)");
  command->add_flag("--overwrite", state->options.overwrite, "Replace an existing output folder");
  command->add_flag("--lsq-baseline", state->lsq_baseline,
                    "The benchmark's least-squares baseline (jacobi_svd, every sample kept)");
  SetsField(command->add_option("--ring-lights", state->options.ring_lights,
                                "Solve with only this many lights, chosen like the scanner's two LED rings (0 = all)"),
            "DatasetSolveOptions.ring_lights")
      ->capture_default_str();
  AddPhotometricSolverOptions(*command, state->options.solver);
  AddDepthRefinementOptions(*command, state->options.depth);  // near-field folders (issue #33)
  // Issue #34: the cloth material and its relighting check.
  command->add_flag("--material", state->options.material,
                    "Fit the cloth material (base colour, sheen, specular) at the solved normals, write its maps and "
                    "predict each light from the others (leave one light out)");
  SetsField(command->add_option("--fit-lights", state->options.fit_lights,
                                "Solve and fit from these lights only (numbers, 1 = the first image, e.g. 1,5,9,...; "
                                "at least 6) and score the prediction of every other light against its photo")
                ->delimiter(','),
            "DatasetSolveOptions.fit_lights");
  SetsField(command->add_option("--predict-dir", state->options.predict_dir,
                                "With --fit-lights: write the predicted photo of every other light here, under its "
                                "file name and bit depth (a new folder)"),
            "DatasetSolveOptions.predict_dir");
  command->add_flag(
      "--no-depth-anchor-fit", [state](std::int64_t) { state->options.depth.anchor_by_residual = false; },
      "Depth refinement: put the --depth-anchor-percentile of the integrated height on the plane at "
      "mean_distance.txt instead of choosing the distance by the Lambertian fits' residual");
  command->callback([state, exit_code] { Guarded(exit_code, [&] { return SolveDatasetCommand(*state); }); });

  auto simulate = std::make_shared<SimulateDatasetState>();
  CLI::App* simulate_command = app.add_subcommand(
      "simulate-dataset",
      "Render a LUCES-style near-field folder on the simulated rig (no lens distortion): a textile on the table, "
      "by default a Lambertian twill, lit by the rig's point LEDs with cast shadows; 16-bit PNGs developed from "
      "RAW frames, the LEDs, K.txt, mean_distance.txt, mask.png and Normal_gt.mat, for solve-dataset");
  simulate_command->add_option("folder", simulate->folder, "Folder to write (must not exist unless --overwrite)")
      ->required();
  SimulateDatasetOptions& options = simulate->options;
  SetsField(simulate_command->add_option("--width", options.rig.width, "Image width in pixels"),
            "SimulatedRigOptions.width")
      ->capture_default_str();
  SetsField(simulate_command->add_option("--height", options.rig.height, "Image height in pixels"),
            "SimulatedRigOptions.height")
      ->capture_default_str();
  simulate_command->add_option("--seed", options.rig.seed, "Sensor noise seed")->capture_default_str();
  simulate_command->add_option("--scene-seed", options.scene.seed, "Textile variation and folds seed")
      ->capture_default_str();
  SetsField(simulate_command->add_option("--warp-pitch", options.scene.warp_pitch_mm, "Warp thread spacing, mm"),
            "TextileSceneOptions.warp_pitch_mm")
      ->capture_default_str();
  SetsField(simulate_command->add_option("--weft-pitch", options.scene.weft_pitch_mm, "Weft thread spacing, mm"),
            "TextileSceneOptions.weft_pitch_mm")
      ->capture_default_str();
  SetsField(simulate_command->add_option(
                "--fold-amplitude", options.scene.fold_amplitude_mm,
                "Fold amplitude, mm: the folds lift the cloth by 0 .. 2x this (+-this about their mean)"),
            "TextileSceneOptions.fold_amplitude_mm")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  simulate_command->add_flag("--no-noise", [&options](std::int64_t) { options.rig.add_noise = false; },
                             "Render without sensor noise");
  simulate_command->add_flag("--no-shadows", [&options](std::int64_t) { options.rig.cast_shadows = false; },
                             "Render without cast shadows");
  simulate_command->add_flag("--linear", [&options](std::int64_t) { options.raw_path = false; },
                             "Noise-free linear renders of every colour at every pixel instead of developed RAW "
                             "frames (no noise, no demosaicing)");
  SetsField(simulate_command->add_option("--render-threads", options.rig.num_threads, "Render threads (0 = all cores)"),
            "SimulatedRigOptions.num_threads")
      ->capture_default_str();
  simulate_command->add_flag("--overwrite", options.overwrite, "Replace an existing folder");
  AddCameraColorOption(*simulate_command, options.rig.color);
  AddMaterialOption(*simulate_command, options.scene.material);
  simulate_command->callback(
      [simulate, exit_code] { Guarded(exit_code, [&] { return SimulateDatasetCommand(*simulate); }); });

  auto report = std::make_shared<SolverReportOptions>();
  report->output_dir = "docs/solver-report";
  report->diligent_dir = "../shared/data/diligent";
  CLI::App* report_command = app.add_subcommand(
      "solver-report",
      "Run every solver method on simulated scenes (Lambertian, cast shadows, specular sheen, noise levels, the "
      "RAW path, cloth and satin, 16 MP with 10 lights) and the DiLiGenT objects with all and with 10 ring lights; write the error-against-run-time table "
      "(report.md, report.csv) and plot (error_vs_time.svg)");
  report_command->add_option("--output", report->output_dir, "Folder for report.md, report.csv, error_vs_time.svg")
      ->capture_default_str();
  report_command->add_option("--diligent", report->diligent_dir, "Folder holding ballPNG and bearPNG")
      ->capture_default_str();
  report->diligent_crop8_dir = "../shared/data/diligent_crop8";
  report_command->add_option("--diligent-crop8", report->diligent_crop8_dir,
                             "Folder holding the 8-bit crops buddhaPNG, gobletPNG and pot1PNG")
      ->capture_default_str();
  SetsField(report_command->add_option("--threads", report->num_threads, "Solver threads (0 = all cores)"),
            "SolverReportOptions.num_threads")
      ->capture_default_str();
  SetsField(report_command->add_option("--analytic-size", report->analytic_size,
                                       "Side of the analytic sphere scenes, pixels"),
            "SolverReportOptions.analytic_size")
      ->capture_default_str();
  report_command->add_flag("--no-16mp", [report](std::int64_t) { report->include_16mp = false; },
                           "Leave out the 16 MP scene (minutes, about 2 GB)");
  report_command->callback([report, exit_code] { Guarded(exit_code, [&] { return SolverReportCommand(*report); }); });

  auto training = std::make_shared<TrainingSetState>();
  CLI::App* training_command = app.add_subcommand(
      "training-set",
      "Render per-pixel observation sets (normal, material, lights, what the solver reads) from the simulator's "
      "shading models: the learned method's training data (scripts/train/train_normal_net.py)");
  training_command->add_option("output", training->output, "Observation file to write")->required();
  training_command->add_option("--seed", training->options.seed, "Seed: every set is a function of it and its index")
      ->capture_default_str();
  SetsField(training_command->add_option("--sets", training->options.num_sets, "Number of sets"),
            "ObservationSetOptions.num_sets")
      ->capture_default_str();
  SetsField(
      training_command->add_option("--min-lights", training->options.min_lights, "Fewest lights of a distant set"),
      "ObservationSetOptions.min_lights")
      ->capture_default_str();
  SetsField(training_command->add_option("--max-lights", training->options.max_lights, "Most lights of a distant set"),
            "ObservationSetOptions.max_lights")
      ->capture_default_str();
  SetsField(training_command->add_option("--near-field-share", training->options.near_field_share,
                                         "Share of sets lit by the scanner's near-field LEDs"),
            "ObservationSetOptions.near_field_share")
      ->capture_default_str();
  SetsField(training_command->add_option("--threads", training->options.num_threads, "Threads (0 = all cores)"),
            "ObservationSetOptions.num_threads")
      ->capture_default_str();
  training_command->callback(
      [training, exit_code] { Guarded(exit_code, [&] { return TrainingSetCommand(*training); }); });
}

}  // namespace scanbench
