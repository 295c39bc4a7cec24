// calibrate camera|white|lights, describe (real-bench captures as target
// sessions), and on the simulated rig: simulate-targets,
// edge-error and demo (targets -> calibration set -> a scan solved with it).
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <numbers>
#include <sstream>
#include <vector>

#include "core/format.h"
#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/calibration_controllers.h"
#include "app/controllers/edge_error_controller.h"
#include "app/controllers/simulate_controller.h"
#include "app/controllers/simulate_targets_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"
#include "app/session/color_staleness.h"
#include "calibration/camera_model.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------
// Reports

void PrintCamera(const CameraCalibrationSummary& s, const fs::path& set) {
  std::cout << s.BriefReport() << "\n";
  for (const CalibrationViewReport& v : s.views) {
    std::cout << "  " << v.name << ": "
              << (v.used ? "used, RMS " + Fixed(v.rms_px, 3) + " px" : "REJECTED: " + v.reason)
              << (v.on_table ? " (on the table)" : "") << ", edge width " << Fixed(v.edge_width_px, 2) << " px\n";
  }
  const Eigen::Vector3d centre = CameraCentreInTable(s.camera);
  std::cout << "  camera centre in the table frame: (" << Fixed(centre.x(), 1) << ", " << Fixed(centre.y(), 1) << ", "
            << Fixed(centre.z(), 1) << ") mm\n"
            << "Calibration set written to " << fs::absolute(set).string() << "\n";
}

void PrintLights(const LightCalibrationSummary& s, const fs::path& set) {
  std::cout << s.BriefReport() << "\nLights written into the calibration set " << fs::absolute(set).string() << "\n";
}

// ---------------------------------------------------------------------------
// Commands

struct CameraState {
  std::vector<fs::path> sessions;
  fs::path output;
  CameraCalibrationJobOptions options;
};

int CalibrateCameraCommand(const CameraState& state) {
  CameraCalibrationController controller(state.sessions, state.output, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) PrintCamera(controller.summary(), state.output);
  return code;
}

struct WhiteState {
  fs::path session;
  fs::path calibration;
  WhiteBalanceJobOptions options;
};

// Issue #36 item 14: a colour section measured through the light field that
// this run replaced is marked stale, not refitted; say so where it happened.
void PrintColorStaleness(const fs::path& calibration) {
  try {
    const CalibrationSet set = LoadCalibrationSet(calibration, CalibrationLoadOptions{.verify_checksums = false});
    if (const auto stale = StaleColorReason(set, calibration)) std::cout << "warning: " << *stale << "\n";
  } catch (const std::exception& error) {
    std::cout << "warning: " << error.what() << "\n";
  }
}

int CalibrateWhiteCommand(const WhiteState& state) {
  WhiteBalanceController controller(state.session, state.calibration, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) {
    std::cout << controller.summary().BriefReport() << "\nWhite balance written into the calibration set "
              << fs::absolute(state.calibration).string() << "\n";
    PrintColorStaleness(state.calibration);
  }
  return code;
}

struct LightsState {
  std::vector<fs::path> sessions;
  fs::path calibration;
  LightCalibrationJobOptions options;
};

int CalibrateLightsCommand(const LightsState& state) {
  LightCalibrationController controller(state.sessions, state.calibration, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) {
    PrintLights(controller.summary(), state.calibration);
    PrintColorStaleness(state.calibration);
  }
  return code;
}

struct ColorState {
  std::vector<fs::path> targets;
  fs::path calibration;
  ColorCalibrationJobOptions options;
  std::vector<double> corners;  // x0 y0 ... x3 y3, or empty
};

int CalibrateColorCommand(ColorState& state) {
  if (!state.corners.empty()) {
    ColorChartQuad quad;
    for (int i = 0; i < 4; ++i) quad.corners_px[i] = Eigen::Vector2d(state.corners[2 * i], state.corners[2 * i + 1]);
    state.options.detection.corners = quad;
  }
  ColorCalibrationController controller(state.targets, state.calibration, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) {
    std::cout << controller.summary().FullReport() << "Colour calibration written into the calibration set "
              << fs::absolute(state.calibration).string() << "\n";
  }
  return code;
}

struct DescribeState {
  std::vector<fs::path> sessions;
  std::string kind;
  DescribeTargetsOptions options;
};

int DescribeCommand(DescribeState& state) {
  state.options.kind = *CalibrationTargetKindFromName(state.kind);  // CLI11 checked the name
  const std::vector<DescribedTargetSession> described = DescribeTargetSessions(state.options, state.sessions);
  for (const DescribedTargetSession& d : described) {
    std::cout << "  " << d.session.string() << ": "
              << (d.written ? "target.json written: " + d.what
                            : "kept its target.json (delete it by hand to describe again)")
              << "\n";
  }
  return kExitSuccess;
}

struct TargetsState {
  fs::path output;
  SimulateTargetsOptions options;
};

int SimulateTargetsCommand(const TargetsState& state) {
  SimulateTargetsController controller(state.output, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) {
    const SimulateTargetsSummary& s = controller.summary();
    std::cout << "Target sessions in " << fs::absolute(state.output).string() << " (" << s.sessions_written
              << " written, " << s.sessions_skipped << " already there)\n";
  }
  return code;
}

struct EdgeState {
  fs::path session;
  EdgeErrorOptions options;
};

int EdgeErrorCommand(const EdgeState& state) {
  EdgeErrorController controller(state.session, state.options);
  const int code = RunController(controller);
  if (code == kExitSuccess) std::cout << controller.summary().FullReport();
  return code;
}

struct DemoState {
  fs::path output = "scanbench-calibration-demo";
  int width = kD5100Width / 4;
  int height = kD5100Height / 4;
  uint64_t seed = SimulatedRigOptions().seed;
  SensorColorModel color = SimulatedRigOptions().color;
  int threads = 0;
};

// Every step a user would run, in order, on the simulated rig.
int CalibrationDemo(const DemoState& state) {
  SimulatedRigOptions sensor;
  sensor.width = state.width;
  sensor.height = state.height;
  sensor.seed = state.seed;
  sensor.color = state.color;
  const fs::path targets = state.output / "targets";
  const fs::path calibration = state.output / "calibration";
  const fs::path scan = state.output / "scan";

  std::cout << "1/8 Rendering the calibration targets into " << targets.string() << "\n";
  SimulateTargetsOptions target_options;
  target_options.rig = sensor;
  if (int code = SimulateTargetsCommand({targets, target_options}); code != kExitSuccess) return code;

  std::cout << "2/8 Camera calibration\n";
  std::vector<fs::path> boards;
  for (int i = 0; i < target_options.num_board_poses; ++i) boards.push_back(targets / ("checkerboard_" + std::to_string(i)));
  CameraState camera{boards, calibration, {}};
  camera.options.replace = true;
  if (int code = CalibrateCameraCommand(camera); code != kExitSuccess) return code;

  std::cout << "3/8 White balance and linearity (gray chart)\n";
  if (int code = CalibrateWhiteCommand({targets / "gray_chart", calibration, {}}); code != kExitSuccess) return code;

  std::cout << "4/8 Light calibration (white sheet on the table and on a spacer)\n";
  if (int code = CalibrateLightsCommand(
          {{targets / "white_sheet_table", targets / "white_sheet_spacer"}, calibration, {}});
      code != kExitSuccess) {
    return code;
  }

  std::cout << "5/8 Colour calibration (ColorChecker target, through the light calibration)\n";
  ColorState color{{targets / "color_chart"}, calibration, {}, {}};
  if (int code = CalibrateColorCommand(color); code != kExitSuccess) return code;

  // Scans whose sessions record the measured (uncalibrated) rig, solved with the calibration.
  auto scan_and_solve = [&](const fs::path& dir, SampleKind sample, const std::string& name) {
    if (!fs::exists(dir / "session.json") || !LoadSession(dir).capture_complete) {
      SimulateOptions simulate;
      simulate.rig = sensor;
      simulate.rig_description = SimulateOptions::RigDescriptionKind::kMeasured;
      simulate.scene.sample = sample;
      simulate.sample_name = name;
      SimulateController controller(dir, simulate);
      if (int code = RunController(controller); code != kExitSuccess) return code;
    }
    SolveOptions solve;
    solve.solver.num_threads = state.threads;
    solve.calibration_dir = calibration;
    solve.run_label = "calibrated";
    SolveController solver(dir, solve);
    const int code = RunController(solver);
    if (code == kExitSuccess) std::cout << solver.summary().FullReport();
    return code;
  };
  std::cout << "6/8 A twill scan, solved with the calibration\n";
  if (int code = scan_and_solve(scan, SampleKind::kTextile, "simulated twill"); code != kExitSuccess) return code;
  std::cout << "7/8 A ColorChecker scan (other captures than the colour target), solved with the calibration\n";
  if (int code = scan_and_solve(state.output / "colorchecker_scan", SampleKind::kColorChecker,
                                "simulated ColorChecker Classic");
      code != kExitSuccess) {
    return code;
  }

  std::cout << "8/8 Edge error: distant uniform lights against the calibration\n";
  EdgeErrorOptions edge;
  edge.solver.num_threads = state.threads;
  edge.calibration_dir = calibration;
  edge.output_dir = state.output / "edge_error";
  return EdgeErrorCommand({scan, edge});
}

void AddVerifyFlag(CLI::App& command, bool& verify) {
  command.add_flag("--no-verify", [&verify](std::int64_t) { verify = false; },
                   "Skip re-hashing the frames against session.json");
}

void AddCalibrationOption(CLI::App& command, fs::path& calibration) {
  command.add_option("--calibration,-c", calibration, "Calibration set (made by calibrate camera)")
      ->required()
      ->check(CLI::ExistingDirectory);
}

// ---------------------------------------------------------------------------
// Subcommands

void AddCameraCommand(CLI::App& calibrate, int* exit_code) {
  auto camera = std::make_shared<CameraState>();
  CLI::App* command = calibrate.add_subcommand(
      "camera", "Intrinsics, distortion and table pose from checkerboard sessions (one must have the board flat on "
                "the table); starts a new calibration set");
  command->add_option("sessions", camera->sessions, "Checkerboard target sessions")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--output,-o", camera->output, "Calibration set folder to create")->required();
  command->add_flag("--replace", camera->options.replace, "Overwrite an existing calibration set there");
  SetsField(command->add_option("--radial-terms", camera->options.calibration.radial_terms,
                                "Radial distortion terms to fit: 1 (k1), 2 (k1 k2) or 3"),
            "CameraCalibrationOptions.radial_terms")
      ->capture_default_str();
  command->add_flag("--fix-tangential", camera->options.calibration.fix_tangential,
                    "Keep the tangential distortion p1, p2 at 0");
  SetsField(command->add_option("--max-edge-width", camera->options.calibration.detection.max_edge_width_px,
                                "Reject views whose square edges rise over more pixels than this (blur)"),
            "CheckerboardDetectionOptions.max_edge_width_px")
      ->capture_default_str();
  AddVerifyFlag(*command, camera->options.verify_checksums);
  command->callback([camera, exit_code] { Guarded(exit_code, [&] { return CalibrateCameraCommand(*camera); }); });
}

void AddWhiteCommand(CLI::App& calibrate, int* exit_code) {
  auto white = std::make_shared<WhiteState>();
  CLI::App* command = calibrate.add_subcommand(
      "white", "Per-LED white balance and sensor linearity from a gray chart session, into a calibration set");
  command->add_option("session", white->session, "Gray chart target session")
      ->required()
      ->check(CLI::ExistingDirectory);
  AddCalibrationOption(*command, white->calibration);
  SetsField(command->add_option("--linearity-tolerance", white->options.white_balance.linearity_tolerance,
                                "Relative deviation from the linear fit that marks a patch non-linear"),
            "WhiteBalanceOptions.linearity_tolerance")
      ->capture_default_str();
  AddVerifyFlag(*command, white->options.verify_checksums);
  command->callback([white, exit_code] { Guarded(exit_code, [&] { return CalibrateWhiteCommand(*white); }); });
}

void AddLightsCommand(CLI::App& calibrate, int* exit_code) {
  auto lights = std::make_shared<LightsState>();
  CLI::App* command = calibrate.add_subcommand(
      "lights", "Per-pixel light intensity and direction, and the fitted LED model, from white sheet sessions (one on "
                "the table, one on a spacer), into a calibration set");
  command->add_option("sessions", lights->sessions, "White sheet target sessions")
      ->required()
      ->check(CLI::ExistingDirectory);
  AddCalibrationOption(*command, lights->calibration);
  SetsField(command->add_option("--cell-px", lights->options.lights.cell_px,
                                "Side of the averaging cells in pixels, even (0 = width / 64)"),
            "LightCalibrationOptions.cell_px")
      ->capture_default_str();
  SetsField(command->add_option("--model-noise-factor", lights->options.lights.model_noise_factor,
                                "Use the LED model when its residual is within this many times the noise"),
            "LightCalibrationOptions.model_noise_factor")
      ->capture_default_str();
  AddVerifyFlag(*command, lights->options.verify_checksums);
  command->callback([lights, exit_code] { Guarded(exit_code, [&] { return CalibrateLightsCommand(*lights); }); });
}

void AddColorCommand(CLI::App& calibrate, int* exit_code) {
  auto color = std::make_shared<ColorState>();
  CLI::App* command = calibrate.add_subcommand(
      "color", "Colour correction from a ColorChecker Classic: colour chart target sessions (every LED, measured "
               "through the set's light calibration: absolute) or RAW photos of the chart (balanced on its gray "
               "row: relative), into a calibration set (a photo may start a new one)");
  command->add_option("targets", color->targets, "Colour chart target sessions, or RAW files")
      ->required()
      ->check(CLI::ExistingPath);
  command->add_option("--output,-o", color->calibration, "Calibration set folder")->required();
  command
      ->add_option_function<std::string>(
          "--method",
          [color](const std::string& name) {
            color->options.correction.method = name == "opencv-ccm" ? ColorCorrectionOptions::Method::kOpenCvCcm
                                                                     : ColorCorrectionOptions::Method::kCiede2000Fit;
          },
          "Fit: ciede2000 (weighted fit minimising CIEDE2000, default) or opencv-ccm (OpenCV's ColorCorrectionModel)")
      ->check(CLI::IsMember({"ciede2000", "opencv-ccm"}));
  command->add_option("--corners", color->corners,
                      "The chart's corners in image pixels instead of the detector: x y of dark skin's corner, "
                      "bluish green's, black's, white's (8 numbers)")
      ->expected(8);
  AddVerifyFlag(*command, color->options.verify_checksums);
  command->callback([color, exit_code] { Guarded(exit_code, [&] { return CalibrateColorCommand(*color); }); });
}

void AddDescribeCommand(CLI::App& calibrate, int* exit_code) {
  auto describe = std::make_shared<DescribeState>();
  CLI::App* command = calibrate.add_subcommand(
      "describe",
      "Mark sessions captured of a standard target on the real bench as calibration target sessions: "
      "writes a target.json (what the target is) into each that has none, never replacing one");
  command->add_option("sessions", describe->sessions,
                      "Captured sessions, in order: the first board / sheet without a target.json becomes the table "
                      "view unless one of them already is")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--as", describe->kind, "What they show: checkerboard (9 x 6 inner corners, 9 mm squares), "
                                              "gray_chart (Munsell neutral scale), white_sheet (99 %) or color_chart "
                                              "(ColorChecker Classic, real size: 40 mm pitch)")
      ->required()
      ->check(CLI::IsMember({"checkerboard", "gray_chart", "white_sheet", "color_chart"}));
  SetsField(command->add_option("--spacer-mm", describe->options.spacer_mm,
                                "white_sheet: height of the raised sheet above the table, (0, 200] mm"),
            "DescribeTargetsOptions.spacer_mm")
      ->capture_default_str();
  command->callback([describe, exit_code] { Guarded(exit_code, [&] { return DescribeCommand(*describe); }); });
}

void AddSimulateTargetsCommand(CLI::App& calibrate, int* exit_code) {
  auto targets = std::make_shared<TargetsState>();
  CLI::App* command = calibrate.add_subcommand(
      "simulate-targets", "Render the calibration target sessions (checkerboards, gray chart, white sheets, colour "
                          "chart) on the simulated rig from its true parameters");
  command->add_option("output", targets->output, "Folder for the target sessions")->required();
  SetsField(command->add_option("--width", targets->options.rig.width, "Image width in pixels"),
            "SimulatedRigOptions.width")
      ->capture_default_str();
  SetsField(command->add_option("--height", targets->options.rig.height, "Image height in pixels"),
            "SimulatedRigOptions.height")
      ->capture_default_str();
  command->add_option("--seed", targets->options.rig.seed, "Sensor noise seed (also the camera serial)")
      ->capture_default_str();
  SetsField(command->add_option("--spacer-mm", targets->options.spacer_mm, "Height of the raised white sheet"),
            "SimulateTargetsOptions.spacer_mm")
      ->capture_default_str();
  command->add_option("--led-error-mm", targets->options.measured.led_position_error_mm,
                      "rms error per axis of the measured LED positions written into the sessions")
      ->capture_default_str();
  AddCameraColorOption(*command, targets->options.rig.color);
  SetsField(command->add_option("--chart-patch-mm", targets->options.chart_patch_mm,
                                "ColorChecker patch side of the colour chart"),
            "SimulateTargetsOptions.chart_patch_mm")
      ->capture_default_str();
  SetsField(command->add_option("--chart-pitch-mm", targets->options.chart_pitch_mm, "ColorChecker patch spacing"),
            "SimulateTargetsOptions.chart_pitch_mm")
      ->capture_default_str();
  command->add_flag("--no-color-chart", [targets](std::int64_t) { targets->options.color_chart = false; },
                    "Skip the colour chart session");
  command->callback([targets, exit_code] { Guarded(exit_code, [&] { return SimulateTargetsCommand(*targets); }); });
}

void AddEdgeErrorCommand(CLI::App& calibrate, int* exit_code) {
  auto edge = std::make_shared<EdgeState>();
  CLI::App* command = calibrate.add_subcommand(
      "edge-error",
      "Measure the low-frequency normal tilt toward the borders (the edge error) of a simulated "
      "session: distant uniform lights against a calibration set; writes figures and images");
  command->add_option("session", edge->session, "Session with ground truth")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--calibration,-c", edge->options.calibration_dir, "Calibration set")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--output,-o", edge->options.output_dir, "Folder for the images and edge_error.json")
      ->required();
  SetsField(
      command->add_option("--block-px", edge->options.block_px, "Averaging block side in pixels (0 = width / 40)"),
      "EdgeErrorOptions.block_px")
      ->capture_default_str();
  SetsField(command->add_option("--threads", edge->options.solver.num_threads, "Solver threads (0 = all cores)"),
            "PhotometricSolverOptions.num_threads")
      ->capture_default_str();
  command->callback([edge, exit_code] { Guarded(exit_code, [&] { return EdgeErrorCommand(*edge); }); });
}

void AddDemoCommand(CLI::App& calibrate, int* exit_code) {
  auto demo = std::make_shared<DemoState>();
  CLI::App* command = calibrate.add_subcommand(
      "demo", "On the simulated rig: render the targets, calibrate camera, white balance, lights and colour, scan a twill "
              "and a ColorChecker whose sessions hold only the measured rig, solve them with the calibration and "
              "measure the edge error");
  command->add_option("--output", demo->output, "Folder for everything")->capture_default_str();
  SetsField(command->add_option("--width", demo->width, "Image width in pixels"),
            {"SimulatedRigOptions.width", "MakeDefaultSimulatedRig.width"})
      ->capture_default_str();
  SetsField(command->add_option("--height", demo->height, "Image height in pixels"),
            {"SimulatedRigOptions.height", "MakeDefaultSimulatedRig.height"})
      ->capture_default_str();
  command->add_option("--seed", demo->seed, "Sensor noise seed")->capture_default_str();
  AddCameraColorOption(*command, demo->color);
  SetsField(command->add_option("--threads", demo->threads, "Solver threads (0 = all cores)"),
            "PhotometricSolverOptions.num_threads")
      ->capture_default_str();
  command->callback([demo, exit_code] { Guarded(exit_code, [&] { return CalibrationDemo(*demo); }); });
}

}  // namespace

void RegisterCalibrateCommands(CLI::App& app, int* exit_code) {
  CLI::App* calibrate = app.add_subcommand(
      "calibrate", "Calibrate the camera, the sensor's white balance and the lights from target sessions into a "
                   "calibration set (docs/calibration.md)");
  calibrate->require_subcommand(1);
  AddCameraCommand(*calibrate, exit_code);
  AddWhiteCommand(*calibrate, exit_code);
  AddLightsCommand(*calibrate, exit_code);
  AddColorCommand(*calibrate, exit_code);
  AddDescribeCommand(*calibrate, exit_code);
  AddSimulateTargetsCommand(*calibrate, exit_code);
  AddEdgeErrorCommand(*calibrate, exit_code);
  AddDemoCommand(*calibrate, exit_code);
}

}  // namespace scanbench
