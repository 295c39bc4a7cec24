// The capture sequencer: an exposure check, then a dark frame and one RAW
// frame per LED, each written into the session the moment it arrives. Before
// every exposure the LED state the firmware reports is verified, and again
// after it (a watchdog or a board reset during the exposure spoils the frame);
// all LEDs go off at the end and on any failure; a frame that fails is
// retried; an interrupted capture resumes from the session's journal when
// asked to (CaptureOptions::resume); a new one needs a new, empty folder.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/devices/camera/camera.h"
#include "app/devices/light_controller.h"
#include "app/session/session.h"
#include "calibration/rig.h"

namespace scanbench {

struct CaptureOptions {
  std::string sample_name;                   // required; recorded in session.json
  std::string notes;
  // false: a new capture, into a missing or empty folder only; true: the
  // resume of the interrupted capture in the folder, which must be there
  // (app/session/capture_folder.h decides; the refusal names what is there).
  bool resume = false;
  // Applied before the run; 0 leaves the camera's own value.
  ExposureSettings exposure;
  bool check_exposure = true;                // one test frame per LED before a new capture (not kept)
  double clip_fraction = 0.98;               // a raw sample at or above this fraction of white is clipped, (0, 1]
  double max_clipped_fraction = 1e-4;        // clipped share of an LED frame's raw samples allowed, [0, 1]
  double min_signal = 0.05;                  // 99th percentile of an LED frame, fraction of the raw range, [0, 1)
  int max_attempts = 3;                      // per frame, [1, 10]
  std::chrono::milliseconds led_settle{20};  // LED switched -> exposure, [0, 10 s]
  uint32_t watchdog_ms = 0;                  // board watchdog during the run; 0 keeps the board's
  // capture --rig sim: the scene the simulated camera renders, recorded in
  // session.json; a resume with another scene is refused. nullopt = a real bench.
  std::optional<SimulatedSceneRecord> simulation;

  void Check() const;
};

// What the exposure check or a captured frame measured.
struct FrameExposure {
  std::string frame;             // "dark", "led_03"
  double clipped_fraction = 0;   // of raw samples
  double signal_p99 = 0;         // fraction of the raw range above black
};

struct CaptureSummary {
  std::filesystem::path session_dir;
  int frames_captured = 0;        // this run
  int frames_resumed = 0;         // already in the session from an interrupted run
  int retries = 0;                // frames taken again after a failure
  std::vector<std::string> retry_reasons;
  std::vector<FrameExposure> exposure_check;
  double seconds = 0;
};

class CaptureController : public BaseController {
 public:
  // `rig` describes the bench: rig.leds[k].id is the firmware channel of LED k.
  // The camera and lights are used, not owned, and must outlive Run().
  CaptureController(std::filesystem::path session_dir, RigDescription rig, Camera* camera,
                    LightController* lights, CaptureOptions options);
  void Run() override;
  const CaptureSummary& summary() const { return summary_; }

  // Called on Run()'s thread once a frame is durably journalled (its file and
  // session.json fsynced), with the session as journalled so far and the
  // frame's record; on a resume first for every frame the interrupted run
  // journalled. An exception from it ends the capture (the frame stays).
  using FrameJournalledCallback = std::function<void(const Session& session, const FrameRecord& frame)>;
  void SetFrameJournalledCallback(FrameJournalledCallback callback) { frame_journalled_ = std::move(callback); }

 private:
  std::filesystem::path session_dir_;
  RigDescription rig_;
  Camera* camera_;
  LightController* lights_;
  CaptureOptions options_;
  CaptureSummary summary_;
  FrameJournalledCallback frame_journalled_;
};

}  // namespace scanbench
