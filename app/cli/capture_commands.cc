// capture: a scan session from the bench, or from the simulated rig with the
// LED firmware running in simavr (the same sequencer either way).
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/capture_controller.h"
#include "app/controllers/live_solve.h"
#include "app/controllers/simulate_controller.h"
#include "app/devices/camera/gphoto2_camera.h"
#include "app/devices/camera/simulated_camera.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/serial_port_list.h"
#include "app/devices/simulated_led_board.h"
#include "app/io/file_util.h"
#include "app/session/capture_folder.h"
#include "app/session/rig_json.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

struct CaptureState {
  fs::path session_dir;
  std::string rig_kind = "sim";
  // sim
  int width = 1232;
  int height = 816;
  SurfaceMaterial material = SurfaceMaterial::kLambert;
  double fold_amplitude_mm = TextileSceneOptions().fold_amplitude_mm;  // issue #15
  // hardware
  std::string port;
  fs::path rig_file;
  std::string camera_model;
  std::string camera_port;
  CaptureOptions options;
  // --solve: solve while capturing (LiveSolveController) with these options.
  bool solve = false;
  SolveOptions solve_options;
  int solve_queue = LiveSolveOptions().queue_frames;
  bool solve_develop_ahead = LiveSolveOptions().develop_ahead;
};

void PrintCaptureSummary(const fs::path& session_dir, const CaptureSummary& summary) {
  std::cout << "Session " << fs::absolute(session_dir).string() << ": " << summary.frames_captured
            << " frames captured, " << summary.frames_resumed << " already there, " << summary.retries
            << " retried, in " << Significant(summary.seconds) << " s\n";
  for (const std::string& reason : summary.retry_reasons) std::cout << "  retried " << reason << "\n";
}

int RunLiveSolve(CaptureState& state, const RigDescription& rig, Camera& camera, LightController& lights) {
  LiveSolveOptions options;
  options.capture = state.options;
  options.solve = state.solve_options;
  options.queue_frames = state.solve_queue;
  options.develop_ahead = state.solve_develop_ahead;
  LiveSolveController live(state.session_dir, rig, &camera, &lights, options);
  const int code = RunController(live);
  if (code != kExitSuccess) return code;
  PrintCaptureSummary(state.session_dir, live.summary().capture);
  std::cout << live.summary().solve.FullReport() << live.summary().BriefReport() << "\n";
  for (const std::string& problem : live.summary().live_problems) {
    std::cout << "  decoded by the solve instead: " << problem << "\n";
  }
  return code;
}

int RunCapture(CaptureState& state, const RigDescription& rig, Camera& camera, LightController& lights) {
  if (state.solve) return RunLiveSolve(state, rig, camera, lights);
  CaptureController capture(state.session_dir, rig, &camera, &lights, state.options);
  const int code = RunController(capture);
  if (code == kExitSuccess) PrintCaptureSummary(state.session_dir, capture.summary());
  return code;
}

int CaptureSimulated(CaptureState& state) {
  SimulatedRigOptions rig_options;
  rig_options.width = state.width;
  rig_options.height = state.height;
  TextileSceneOptions scene;
  scene.material = state.material;
  scene.fold_amplitude_mm = state.fold_amplitude_mm;
  state.options.simulation = SimulatedSceneOf(rig_options, scene);  // refuses a resume with another scene
  const auto rig = std::make_shared<SimulatedRig>(rig_options, TextileScene(scene),
                                                  MakeDefaultSimulatedRig(state.width, state.height));
  SimulatedLedBoard board;
  std::cout << "Simulated bench: LED firmware in simavr on " << board.port_path() << ", simulated camera "
            << state.width << "x" << state.height << "\n";
  SerialLightController lights(board.port_path());
  SimulatedCamera camera(rig, [&board]() { return board.SingleLitLed(); });
  return RunCapture(state, rig->rig(), camera, lights);
}

int CaptureHardware(CaptureState& state) {
  if (state.rig_file.empty()) {
    throw std::invalid_argument("capture --rig hardware needs --rig-file: the bench's rig description (JSON)");
  }
  const RigDescription rig = LoadRigDescriptionFile(state.rig_file.string());
  SerialLightController lights(state.port.empty() ? FindArduinoPort({"name its port with --port", "use --rig sim"})
                                                  : state.port);
  GPhotoCameraOptions camera_options;
  camera_options.model = state.camera_model;
  camera_options.port = state.camera_port;
  GPhotoCamera camera(camera_options);
  std::cout << "Bench: " << lights.description() << ", " << camera.description() << "\n";
  return RunCapture(state, rig, camera, lights);
}

}  // namespace

void RegisterCaptureCommands(CLI::App& app, int* exit_code) {
  auto state = std::make_shared<CaptureState>();
  CLI::App* command = app.add_subcommand(
      "capture",
      "Capture a session: exposure check, dark frame, one RAW frame per LED, verified against the LED board. "
      "A new capture needs a new, empty folder; --resume completes an interrupted one.");
  command->add_option("session", state->session_dir,
                      "Session folder: a new, empty one (or, with --resume, an interrupted capture's)")
      ->required();
  command->add_flag("--resume", state->options.resume,
                    "Resume the interrupted capture in the session folder (same camera, LEDs and scene); the frames "
                    "it journalled are kept");
  command->add_option("--rig", state->rig_kind, "sim: simulated camera + LED firmware in simavr; hardware: the bench")
      ->check(CLI::IsMember({"sim", "hardware"}))
      ->capture_default_str();
  SetsField(command->add_option("--sample-name", state->options.sample_name, "Sample name recorded in session.json"),
            "CaptureOptions.sample_name")
      ->required();
  command->add_option("--notes", state->options.notes, "Free text recorded in session.json");
  SetsField(command->add_option("--width", state->width, "sim: image width in pixels"),
            {"SimulatedRigOptions.width", "MakeDefaultSimulatedRig.width"})
      ->capture_default_str();
  SetsField(command->add_option("--height", state->height, "sim: image height in pixels"),
            {"SimulatedRigOptions.height", "MakeDefaultSimulatedRig.height"})
      ->capture_default_str();
  AddMaterialOption(*command, state->material);
  SetsField(command->add_option("--fold-amplitude", state->fold_amplitude_mm,
                                "--rig sim: fold amplitude, mm (folds lift the cloth by 0 .. 2x this)"),
            "TextileSceneOptions.fold_amplitude_mm")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command->add_option("--port", state->port, "hardware: LED board serial port (default: the one Arduino found)");
  command->add_option("--rig-file", state->rig_file, "hardware: rig description JSON (LED positions, camera)");
  command->add_option("--camera-model", state->camera_model, "hardware: camera model as libgphoto2 names it");
  command->add_option("--camera-port", state->camera_port, "hardware: camera port, e.g. usb:001,004");
  SetsField(command->add_option("--iso", state->options.exposure.iso, "ISO to set (default: leave the camera's)"),
            "CaptureOptions.exposure.iso");
  SetsField(command->add_option("--exposure-time", state->options.exposure.exposure_time_s,
                                "Exposure time in seconds to set (default: leave the camera's)"),
            "CaptureOptions.exposure.exposure_time_s");
  SetsField(command->add_option("--f-number", state->options.exposure.f_number,
                                "Aperture to set (default: leave the camera's)"),
            "CaptureOptions.exposure.f_number");
  command->add_flag("--no-exposure-check", [state](std::int64_t) { state->options.check_exposure = false; },
                    "Skip the test frame per LED before a new capture");
  SetsField(command->add_option("--attempts", state->options.max_attempts, "Attempts per frame"),
            "CaptureOptions.max_attempts")
      ->capture_default_str();
  command->add_flag("--solve", state->solve,
                    "Solve while capturing: each frame is decoded as it is journalled, the result (bit-equal to "
                    "`scanbench solve` of the finished session) follows the last frame into results/");
  SetsField(command->add_option("--solve-queue", state->solve_queue,
                                "--solve: journalled frames waiting for the decoder before the capture waits for it"),
            "LiveSolveOptions.queue_frames")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  command->add_flag("--solve-develop-ahead", state->solve_develop_ahead,
                    "--solve: develop (demosaic) each frame as it lands instead of leaving it to the solve after the "
                    "last frame: less work after it, but 18 bytes a pixel per LED frame held until the solve "
                    "(2.9 GB at 16 MP)");
  AddSolveOptions(*command->add_option_group("solve", "With --solve: the solve's options, as scanbench solve's"),
                  state->solve_options);
  command->callback([state, exit_code] {
    Guarded(exit_code, [&] {
      // The controller checks again under its lock; this refuses before a board or camera is opened.
      CheckCaptureFolder(state->session_dir, state->options.resume);
      return state->rig_kind == "sim" ? CaptureSimulated(*state) : CaptureHardware(*state);
    });
  });
}

}  // namespace scanbench
