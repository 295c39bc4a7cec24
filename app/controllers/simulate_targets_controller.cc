#include "app/controllers/simulate_targets_controller.h"

#include "app/controllers/simulate_controller.h"

#include <chrono>
#include <optional>

#include "app/session/calibration_target.h"
#include "app/session/session.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

struct TargetJob {
  std::string name;
  SimulatedTarget target;
  CalibrationTargetDescription description;
  TargetRenderOptions render;
};

// Every target to render, in order, with its session folder noted in the summary.
std::vector<TargetJob> PlanTargetJobs(const SimulateTargetsOptions& options, const fs::path& output_dir,
                                      SimulateTargetsSummary* summary) {
  std::vector<TargetJob> jobs;
  if (options.checkerboard) {
    const std::vector<Eigen::Isometry3d> poses = DefaultCheckerboardPoses();
    for (int i = 0; i < options.num_board_poses; ++i) {
      TargetJob job;
      job.name = "checkerboard_" + std::to_string(i);
      job.target = SimulatedTarget::Checkerboard(options.board, poses[i]);
      job.description.kind = CalibrationTargetDescription::Kind::kCheckerboard;
      job.description.checkerboard = options.board;
      job.description.on_table = i == 0;
      job.description.board_height_mm = 0;
      job.render.exposure = options.board_exposure;
      jobs.push_back(job);
      summary->checkerboard_sessions.push_back(output_dir / job.name);
    }
  }
  if (options.gray_chart) {
    TargetJob job;
    job.name = "gray_chart";
    job.target = SimulatedTarget::GrayChart(GrayChartTarget::MunsellNeutralScale());
    job.description.kind = CalibrationTargetDescription::Kind::kGrayChart;
    job.description.gray_chart = job.target.gray_chart;
    jobs.push_back(job);
    summary->gray_chart_session = output_dir / job.name;
  }
  if (options.white_sheets) {
    for (const double height : {0.0, options.spacer_mm}) {
      TargetJob job;
      job.name = height == 0 ? "white_sheet_table" : "white_sheet_spacer";
      WhiteSheetTarget sheet;
      sheet.height_mm = height;
      job.target = SimulatedTarget::WhiteSheet(sheet);
      job.description.kind = CalibrationTargetDescription::Kind::kWhiteSheet;
      job.description.white_sheet = sheet;
      jobs.push_back(job);
      summary->white_sheet_sessions.push_back(output_dir / job.name);
    }
  }
  if (options.color_chart) {
    TargetJob job;
    job.name = "color_chart";
    job.target = SimulatedTarget::ColorChart(options.chart_patch_mm, options.chart_pitch_mm);
    job.description.kind = CalibrationTargetDescription::Kind::kColorChart;
    job.description.color_chart.patch_mm = options.chart_patch_mm;
    job.description.color_chart.pitch_mm = options.chart_pitch_mm;
    job.description.color_chart.height_mm = job.target.chart_height_mm;
    jobs.push_back(job);
    summary->color_chart_session = output_dir / job.name;
  }
  return jobs;
}

// A new target session as the capture sequencer starts it: the measured rig,
// the simulated camera at the job's exposure, no frames yet.
Session NewTargetSession(const TargetJob& job, const RigDescription& measured, const SimulatedRigOptions& rig) {
  return NewSimulatedSession("calibration target: " + job.name,
                             "rendered by the scanbench simulated rig from its true parameters; rig = measured description",
                             measured, rig, kSimulatedExposureTimeS * job.render.exposure);
}

}  // namespace

void SimulateTargetsOptions::Check() const {
  rig.Check();
  measured.Check();
  board.Check();
  const std::string where = "SimulateTargetsOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "num_board_poses", num_board_poses, 4, 9);
  SCANBENCH_REQUIRE_GT_LE(where, "board_exposure", board_exposure, 0, 100);
  SCANBENCH_REQUIRE_GT_LE(where, "spacer_mm", spacer_mm, 0, 200);
  SCANBENCH_REQUIRE_GT_LE(where, "chart_patch_mm", chart_patch_mm, 0, 100);
  if (!(chart_pitch_mm >= chart_patch_mm && chart_pitch_mm <= 200)) {
    throw FieldError(where, "chart_pitch_mm", chart_pitch_mm,
                     "must lie in [chart_patch_mm = " + std::to_string(chart_patch_mm) + ", 200]");
  }
}

SimulateTargetsController::SimulateTargetsController(fs::path output_dir, SimulateTargetsOptions options)
    : output_dir_(std::move(output_dir)), options_(std::move(options)) {}

void SimulateTargetsController::Run() {
  options_.Check();
  const auto start = std::chrono::steady_clock::now();
  summary_ = SimulateTargetsSummary();
  const RigDescription truth = MakeDefaultSimulatedRig(options_.rig.width, options_.rig.height, options_.rig.color);
  const RigDescription measured = MakeMeasuredRigDescription(truth, options_.measured);
  const TargetRenderer renderer(options_.rig, truth);
  const std::vector<TargetJob> jobs = PlanTargetJobs(options_, output_dir_, &summary_);
  const int num_frames = 1 + renderer.num_leds();
  const double total = static_cast<double>(jobs.size() * num_frames);
  for (size_t j = 0; j < jobs.size(); ++j) {
    const TargetJob& job = jobs[j];
    const fs::path dir = output_dir_ / job.name;
    std::optional<Session> existing;
    if (fs::exists(dir / "session.json")) {
      existing = LoadSession(dir);
      if (existing->capture_complete) {
        ++summary_.sessions_skipped;
        continue;
      }
    }
    Session session = existing ? *existing : NewTargetSession(job, measured, options_.rig);
    if (!existing) {
      CreateSessionFolder(dir);
      WriteSessionManifest(dir, session);
    }
    WriteCalibrationTarget(dir, job.description);
    RenderFrames(renderer, job.target, job.render, j, total, dir, session);
    session.capture_complete = true;
    WriteSessionManifest(dir, session);
    ++summary_.sessions_written;
  }
  ReportProgress("simulate targets", 1);
  summary_.seconds = SecondsSince(start);
}

void SimulateTargetsController::RenderFrames(const TargetRenderer& renderer, const SimulatedTarget& target,
                                             const TargetRenderOptions& render, size_t job_index, double total_frames,
                                             const fs::path& dir, Session& session) {
  const std::string stage = "render " + dir.filename().string();
  const int num_frames = 1 + renderer.num_leds();
  const size_t frames_before = job_index * num_frames;
  ReportProgress("simulate targets", frames_before / total_frames);
  const PreparedTarget prepared = renderer.Prepare(target, render);
  for (int f = 0; f < num_frames; ++f) {
    ThrowIfStopRequested(stage);
    const std::optional<int> led = f == 0 ? std::nullopt : std::optional<int>(f - 1);
    if (led ? FindLedFrame(session, *led) != nullptr : FindDarkFrame(session) != nullptr) continue;  // resumed
    // Every target gets its own noise: frame index 1000 * target + frame.
    const RawImage raw = renderer.RenderFrame(prepared, led ? std::vector<int>{*led} : std::vector<int>{},
                                              1000 * (job_index + 1) + f, render);
    AddSimulatedFrame(dir, session, led, raw, renderer.sensor().color);
    ReportProgress("simulate targets", (frames_before + f + 1) / total_frames);
  }
}

}  // namespace scanbench
