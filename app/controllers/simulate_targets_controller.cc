#include "app/controllers/simulate_targets_controller.h"

#include "app/controllers/simulate_controller.h"

#include <chrono>
#include <optional>

#include "app/io/dng_writer.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

struct TargetJob {
  std::string name;
  SimulatedTarget target;
  CalibrationTargetDescription description;
  TargetRenderOptions render;
};

}  // namespace

void SimulateTargetsOptions::Check() const {
  rig.Check();
  measured.Check();
  board.Check();
  if (num_board_poses < 4 || num_board_poses > 9) {
    throw std::invalid_argument("SimulateTargetsOptions.num_board_poses = " + std::to_string(num_board_poses) +
                                " must lie in [4, 9]");
  }
  if (!(board_exposure > 0 && board_exposure <= 100)) {
    throw std::invalid_argument("SimulateTargetsOptions.board_exposure = " + std::to_string(board_exposure) +
                                " must lie in (0, 100]");
  }
  if (!(spacer_mm > 0 && spacer_mm <= 200)) {
    throw std::invalid_argument("SimulateTargetsOptions.spacer_mm = " + std::to_string(spacer_mm) +
                                " must lie in (0, 200]");
  }
}

SimulateTargetsController::SimulateTargetsController(fs::path output_dir, SimulateTargetsOptions options)
    : output_dir_(std::move(output_dir)), options_(std::move(options)) {}

void SimulateTargetsController::Run() {
  options_.Check();
  const auto start = std::chrono::steady_clock::now();
  summary_ = SimulateTargetsSummary();
  const RigDescription truth = MakeDefaultSimulatedRig(options_.rig.width, options_.rig.height);
  const RigDescription measured = MakeMeasuredRigDescription(truth, options_.measured);
  const TargetRenderer renderer(options_.rig, truth);

  std::vector<TargetJob> jobs;
  if (options_.checkerboard) {
    const std::vector<Eigen::Isometry3d> poses = DefaultCheckerboardPoses();
    for (int i = 0; i < options_.num_board_poses; ++i) {
      TargetJob job;
      job.name = "checkerboard_" + std::to_string(i);
      job.target = SimulatedTarget::Checkerboard(options_.board, poses[i]);
      job.description.kind = CalibrationTargetDescription::Kind::kCheckerboard;
      job.description.checkerboard = options_.board;
      job.description.on_table = i == 0;
      job.description.board_height_mm = 0;
      job.render.exposure = options_.board_exposure;
      jobs.push_back(job);
      summary_.checkerboard_sessions.push_back(output_dir_ / job.name);
    }
  }
  if (options_.gray_chart) {
    TargetJob job;
    job.name = "gray_chart";
    job.target = SimulatedTarget::GrayChart(GrayChartTarget::MunsellNeutralScale());
    job.description.kind = CalibrationTargetDescription::Kind::kGrayChart;
    job.description.gray_chart = job.target.gray_chart;
    jobs.push_back(job);
    summary_.gray_chart_session = output_dir_ / job.name;
  }
  if (options_.white_sheets) {
    for (const double height : {0.0, options_.spacer_mm}) {
      TargetJob job;
      job.name = height == 0 ? "white_sheet_table" : "white_sheet_spacer";
      WhiteSheetTarget sheet;
      sheet.height_mm = height;
      job.target = SimulatedTarget::WhiteSheet(sheet);
      job.description.kind = CalibrationTargetDescription::Kind::kWhiteSheet;
      job.description.white_sheet = sheet;
      jobs.push_back(job);
      summary_.white_sheet_sessions.push_back(output_dir_ / job.name);
    }
  }

  const int num_frames = 1 + renderer.num_leds();
  const double total = static_cast<double>(jobs.size() * num_frames);
  for (size_t j = 0; j < jobs.size(); ++j) {
    const TargetJob& job = jobs[j];
    const fs::path dir = output_dir_ / job.name;
    const std::string stage = "render " + job.name;
    std::optional<Session> existing;
    if (fs::exists(dir / "session.json")) {
      existing = LoadSession(dir);
      if (existing->capture_complete) {
        ++summary_.sessions_skipped;
        continue;
      }
    }
    Session session;
    if (existing) {
      session = *existing;
    } else {
      session = NewSimulatedSession("calibration target: " + job.name,
                                    "rendered by the scanbench simulated rig from its true parameters; rig = measured description",
                                    measured, options_.rig, kSimulatedExposureTimeS * job.render.exposure);
      CreateSessionFolder(dir);
      WriteSessionManifest(dir, session);
    }
    WriteCalibrationTarget(dir, job.description);

    ReportProgress("simulate targets", j * num_frames / total);
    const PreparedTarget prepared = renderer.Prepare(job.target, job.render);
    for (int f = 0; f < num_frames; ++f) {
      ThrowIfStopRequested(stage);
      const std::optional<int> led = f == 0 ? std::nullopt : std::optional<int>(f - 1);
      if (led ? FindLedFrame(session, *led) != nullptr : FindDarkFrame(session) != nullptr) continue;
      // Every target gets its own noise: frame index 1000 * target + frame.
      const RawImage raw = renderer.RenderFrame(prepared, led ? std::vector<int>{*led} : std::vector<int>{},
                                                1000 * (j + 1) + f, job.render);
      AddSimulatedFrame(dir, session, led, raw);
      ReportProgress("simulate targets", (j * num_frames + f + 1) / total);
    }
    session.capture_complete = true;
    WriteSessionManifest(dir, session);
    ++summary_.sessions_written;
  }
  ReportProgress("simulate targets", 1);
  summary_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace scanbench
