// Solve while capturing (issue #14 item 2): the capture runs as always, and
// every frame, as soon as it is journalled, is decoded on a worker thread into
// a SolvePreparation, which also builds the light field while the camera is
// still busy. When the last frame lands only the solve itself and the writing
// of the maps are left. The result is bit-equal to `scanbench solve` of the
// finished session, also when an interrupted capture is resumed (the frames
// of the earlier run are decoded from disk first). With
// SolveOptions::verify_checksums each frame is hashed as it is decoded, so the
// solve's load after the last frame does not read every frame again.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/controllers/capture_controller.h"
#include "app/controllers/solve_controller.h"

namespace scanbench {

struct LiveSolveOptions {
  CaptureOptions capture;
  SolveOptions solve;
  // Journalled frames waiting for the decoder before the capture waits for
  // it, [1, 64]; each waiting frame is only its record (the file is on disk).
  int queue_frames = 4;
  // Develop (demosaic) each LED frame whole as it lands
  // (SolvePreparation::DevelopFrame), so that after the last frame only its
  // development is left: 18 bytes a pixel more per frame held (2.9 GB for 10
  // LEDs at 16 MP, with the Bayer blend's mosaic) until the solve has run.
  // Off (the default): the solve develops every band after the last frame,
  // the same result. Off because it holds ten full-frame developed images,
  // which issue #14's memory-bounded pipeline rules out; on where the
  // memory is there and the seconds after the last frame count.
  bool develop_ahead = false;

  void Check() const;
};

struct LiveSolveSummary {
  CaptureSummary capture;
  SolveSummary solve;
  int frames_decoded_live = 0;             // decoded while capturing (the solve decoded the rest)
  // Of those, LED frames developed whole (develop_ahead); a frame the decoder
  // reached only after the last frame, or with more frames waiting, is left
  // to the solve's development.
  int frames_developed_live = 0;
  // The light field's table points made while capturing (else the solve made them band by band).
  bool surface_points_held = false;
  std::vector<std::string> live_problems;  // what the worker could not do; the solve then did it itself
  double seconds_after_last_frame = 0;     // last frame journalled -> result folder in place
  // Of those, until the solve started: the capture's end (LEDs off, the
  // session marked complete) and the decoder's last frames.
  double seconds_until_solve = 0;
  // The process's CPU time (user + system, all threads) over the same span:
  // what the wait costs on a machine shared with other work.
  double cpu_seconds_after_last_frame = 0;

  std::string BriefReport() const;
};

class LiveSolveController : public BaseController {
 public:
  // As CaptureController: the camera and lights are used, not owned.
  LiveSolveController(std::filesystem::path session_dir, RigDescription rig, Camera* camera,
                      LightController* lights, LiveSolveOptions options);
  void Run() override;
  const LiveSolveSummary& summary() const { return summary_; }

 private:
  // Reports `inner`'s progress as ours and passes a stop request on to it.
  ProgressReportCallback ForwardTo(BaseController& inner);

  std::filesystem::path session_dir_;
  RigDescription rig_;
  Camera* camera_;
  LightController* lights_;
  LiveSolveOptions options_;
  LiveSolveSummary summary_;
};

}  // namespace scanbench
