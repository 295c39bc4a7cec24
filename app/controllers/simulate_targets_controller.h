// Renders the calibration target sessions on the simulated rig, each as the
// capture sequencer would write it (a dark frame and one DNG per LED, a
// journalled session.json) plus its target.json:
//
//   <output>/checkerboard_0 .. checkerboard_8   the board at the default poses (0: flat on the table)
//   <output>/gray_chart                          Munsell neutral value scale lying flat
//   <output>/white_sheet_table                   99 % white sheet on the table
//   <output>/white_sheet_spacer                  the same on a spacer (default 40 mm)
//   <output>/color_chart                         ColorChecker Classic lying flat (16 mm patches, 20 mm pitch)
//
// The frames come from the rig's TRUE parameters; session.json records the
// rig as an operator would have measured it (MakeMeasuredRigDescription), the
// starting point the calibrations must improve on.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/session/session.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/target_renderer.h"

namespace scanbench {

struct SimulateTargetsOptions {
  SimulatedRigOptions rig;          // sensor, size, noise, colour model; seed also names the camera serial (as a scan's)
  MeasuredRigOptions measured;      // the rig description written into each session.json
  CheckerboardTarget board;         // the board of the camera calibration
  int num_board_poses = 9;          // views, the first flat on the table, [4, 9]
  double board_exposure = 0.6;      // relative exposure of the board captures, (0, 100]
  double spacer_mm = 40.0;          // height of the raised white sheet, (0, 200]
  bool checkerboard = true;         // render the board sessions
  bool gray_chart = true;           // render the chart session
  bool white_sheets = true;         // render both white sheet sessions
  bool color_chart = true;          // render the colour chart session
  double chart_patch_mm = 16.0;     // ColorChecker patch side, (0, 100]
  double chart_pitch_mm = 20.0;     // ColorChecker patch spacing, [chart_patch_mm, 200]

  void Check() const;
};

struct SimulateTargetsSummary {
  std::vector<std::filesystem::path> checkerboard_sessions;
  std::filesystem::path gray_chart_session;               // empty if not rendered
  std::vector<std::filesystem::path> white_sheet_sessions;
  std::filesystem::path color_chart_session;              // empty if not rendered
  int sessions_written = 0;
  int sessions_skipped = 0;  // found complete from an earlier run
  double seconds = 0;
};

class SimulateTargetsController : public BaseController {
 public:
  SimulateTargetsController(std::filesystem::path output_dir, SimulateTargetsOptions options);
  // Writes every target session; complete ones from an earlier run are kept,
  // interrupted ones resumed.
  void Run() override;
  const SimulateTargetsSummary& summary() const { return summary_; }

 private:
  // The frames `session` (in folder `dir`, named after the job) still lacks,
  // rendered and journalled; job_index names the noise and the progress.
  void RenderFrames(const TargetRenderer& renderer, const SimulatedTarget& target, const TargetRenderOptions& render,
                    size_t job_index, double total_frames, const std::filesystem::path& dir, Session& session);

  std::filesystem::path output_dir_;
  SimulateTargetsOptions options_;
  SimulateTargetsSummary summary_;
};

}  // namespace scanbench
