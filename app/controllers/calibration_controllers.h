// The calibrations as long jobs: each reads target sessions (session.json +
// target.json + DNG frames), runs the calibration library and writes its
// section of a calibration set (app/session/calibration_set.h).
//
//   camera  checkerboard sessions -> a NEW set (intrinsics, distortion, table pose)
//   white   one gray-chart session -> the set's white_balance section
//   lights  white-sheet sessions   -> the set's lights section (+ per-pixel field files)
//   color   colour chart sessions or RAW photos of a ColorChecker -> the set's color section
//
// white and lights need the set's camera section and refuse target sessions
// of another camera, lens or resolution.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/session/calibration_set.h"
#include "calibration/camera_calibration.h"
#include "calibration/color_calibration.h"
#include "calibration/light_calibration.h"
#include "calibration/raw_develop.h"
#include "calibration/white_balance.h"

namespace scanbench {

struct CameraCalibrationJobOptions {
  CameraCalibrationOptions calibration;
  bool verify_checksums = true;  // re-hash every frame against its session.json
  bool replace = false;          // overwrite an existing calibration set at the output folder

  void Check() const;
};

class CameraCalibrationController : public BaseController {
 public:
  CameraCalibrationController(std::vector<std::filesystem::path> target_sessions,
                              std::filesystem::path calibration_dir, CameraCalibrationJobOptions options);
  // Throws with the reason when the calibration fails (no set is written then).
  void Run() override;
  const CameraCalibrationSummary& summary() const { return summary_; }

 private:
  struct Inputs;  // the views and records of the checkerboard sessions
  void CheckOutputFolder() const;
  Inputs ReadCheckerboardSessions() const;
  void Calibrate(const Inputs& inputs);
  void WriteSet(const Inputs& inputs) const;

  std::vector<std::filesystem::path> sessions_;
  std::filesystem::path calibration_dir_;
  CameraCalibrationJobOptions options_;
  CameraCalibrationSummary summary_;
};

struct WhiteBalanceJobOptions {
  WhiteBalanceOptions white_balance;
  bool verify_checksums = true;

  void Check() const { white_balance.Check(); }
};

class WhiteBalanceController : public BaseController {
 public:
  WhiteBalanceController(std::filesystem::path target_session, std::filesystem::path calibration_dir,
                         WhiteBalanceJobOptions options);
  void Run() override;
  const WhiteBalanceSummary& summary() const { return summary_; }

 private:
  struct Inputs;  // the gray chart session and the set it goes into
  Inputs ReadInputs() const;
  void Calibrate(const Inputs& inputs);
  void WriteSet(Inputs& inputs) const;

  std::filesystem::path session_;
  std::filesystem::path calibration_dir_;
  WhiteBalanceJobOptions options_;
  WhiteBalanceSummary summary_;
};

struct LightCalibrationJobOptions {
  LightCalibrationOptions lights;
  bool verify_checksums = true;

  void Check() const { lights.Check(); }
};

class LightCalibrationController : public BaseController {
 public:
  LightCalibrationController(std::vector<std::filesystem::path> target_sessions,
                             std::filesystem::path calibration_dir, LightCalibrationJobOptions options);
  void Run() override;
  const LightCalibrationSummary& summary() const { return summary_; }

 private:
  struct Inputs;  // the white sheet sessions and the set they go into
  Inputs ReadWhiteSheetSessions() const;
  void Calibrate(const Inputs& inputs);
  void WriteSet(Inputs& inputs) const;

  std::vector<std::filesystem::path> sessions_;
  std::filesystem::path calibration_dir_;
  LightCalibrationJobOptions options_;
  LightCalibrationSummary summary_;
};

struct ColorCalibrationJobOptions {
  ColorChartDetectionOptions detection;
  ColorPatchSamplingOptions sampling;
  ColorCorrectionOptions correction;
  bool verify_checksums = true;

  void Check() const;
};

struct ColorCalibrationJobSummary {
  ColorCorrectionSummary fit;
  std::vector<std::string> detections;  // per target: where the chart was found and how
  std::string white_reference;          // "light_field" or "neutral_patches" (ColorSection)
  int num_frames = 0;                   // frames sampled
  bool new_set = false;                 // the set was created for a RAW photo

  // The detections, the fit and the per-patch table, for the CLI.
  std::string FullReport() const;
};

// Colour calibration (issue #12): each target is a colour chart target session
// (every LED frame, the dark frame subtracted) or a single RAW photo of a
// ColorChecker. With the set's light calibration, patch values are divided by
// what a perfect white reads there under each LED (absolute reflectance in the
// solver's albedo space); otherwise each frame is balanced on the chart's gray
// row (relative). The colour correction fitted to the 24 patches goes into the
// set's color section. A RAW photo may start a new set (its camera, no lens).
class ColorCalibrationController : public BaseController {
 public:
  ColorCalibrationController(std::vector<std::filesystem::path> targets, std::filesystem::path calibration_dir,
                             ColorCalibrationJobOptions options);
  void Run() override;
  const ColorCalibrationJobSummary& summary() const { return summary_; }

 private:
  struct Inputs;  // the targets, decoded, and the set they go into
  Inputs ReadTargets() const;
  std::vector<PatchSample> MeasurePatches(const Inputs& inputs);
  void Fit(const std::vector<PatchSample>& patches);
  void WriteSet(Inputs& inputs) const;

  std::vector<std::filesystem::path> targets_;
  std::filesystem::path calibration_dir_;
  ColorCalibrationJobOptions options_;
  ColorCalibrationJobSummary summary_;
};

}  // namespace scanbench
