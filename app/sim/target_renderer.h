// Calibration targets on the simulated rig: a checkerboard held at any pose,
// a matte gray chart, a white sheet and a ColorChecker Classic colour chart
// lying flat, rendered from the rig's
// TRUE camera, LEDs and sensor, so that a calibration can be scored against
// parameters it never sees. Plus the rig description an operator would write
// down before calibrating ("measured": tape-measure LED positions, datasheet
// falloff and brightness, nominal lens).
//
// Light model: the one of simulated_rig.h (near-field LEDs, cos^mu off axis,
// inverse square, Lambertian target; reflectance as white-balanced camera RGB,
// neutral for every target but the colour chart, whose patches come from
// their measured spectra through the sensor's colour model, plus a little
// gloss), on the target's plane; no shadows (a
// raised target does not shade the table: the table is only seen around it).
// Each pixel integrates the target's reflectance over its area (box filter,
// supersampled), so that edges are anti-aliased as on a real sensor.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "app/sim/simulated_rig.h"
#include "calibration/calibration_targets.h"
#include "calibration/raw_image.h"
#include "calibration/rig.h"
#include "core/image.h"

namespace scanbench {

// What is in front of the camera, in the table frame.
struct SimulatedTarget {
  enum class Kind { kCheckerboard, kGrayChart, kWhiteSheet, kColorChart };
  Kind kind = Kind::kWhiteSheet;

  // kCheckerboard: the board and where it is. The visible face is the
  // target's +z side; the squares are framed by a light margin.
  CheckerboardTarget checkerboard;
  Eigen::Isometry3d table_from_target = Eigen::Isometry3d::Identity();
  double board_margin_mm = 9.0;       // light border around the squares, >= 0
  double board_dark_reflectance = 0.04;
  double board_light_reflectance = 0.85;

  // kGrayChart: patches on a card lying flat at gray_chart.height_mm.
  GrayChartTarget gray_chart;
  double card_size_mm = 64.0;            // square card around the patches, > 0
  double card_reflectance = 0.198;       // Munsell N5

  // kWhiteSheet: a sheet lying flat at white_sheet.height_mm (e.g. on a spacer).
  WhiteSheetTarget white_sheet;
  Eigen::Vector2d sheet_size_mm{297.0, 210.0};  // A4, centred on the table origin
  double paper_texture = 0.01;           // relative rms reflectance variation of the paper fibres, [0, 0.2]
  double paper_texture_mm = 0.2;         // correlation length of that variation, > 0
  uint64_t paper_seed = 99;

  // kColorChart: a ColorChecker Classic card lying flat at chart_height_mm,
  // centred on the table origin, dark skin at the image's top left (-x, +y).
  double chart_patch_mm = 16.0;          // side of a square patch, > 0
  double chart_pitch_mm = 20.0;          // patch centre spacing, >= chart_patch_mm
  double chart_height_mm = 0.0;          // the card's face above the table, [0, 200]
  double chart_border_mm = 4.0;          // black surround beyond the outer patches' edges, >= 0
  double chart_surround_reflectance = 0.03;  // the black surround (neutral), [0, 1]
  double chart_gloss = 0.02;             // specular reflectance added at the mirror direction, [0, 0.2]
  double chart_gloss_width_deg = 12.0;   // half-vector angle where the gloss falls to 1/e, (0, 45]

  double table_reflectance = 0.35;       // the table seen around the target, [0, 1]

  static SimulatedTarget Checkerboard(const CheckerboardTarget& board, const Eigen::Isometry3d& table_from_target);
  static SimulatedTarget GrayChart(const GrayChartTarget& chart);
  static SimulatedTarget WhiteSheet(const WhiteSheetTarget& sheet);
  static SimulatedTarget ColorChart(double patch_mm = 16.0, double pitch_mm = 20.0, double height_mm = 0.0);

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct TargetRenderOptions {
  double exposure = 1.0;     // relative exposure (time x aperture) against the scan's, (0, 100]
  double blur_px = 0.0;      // Gaussian defocus blur sigma, pixels, [0, 50]
  int supersampling = 0;     // samples per pixel side, [0, 16]; 0 = per target (board 4, chart 2, sheet 1)
  // Rings in every LED's emission pattern (an imperfect LED lens), which
  // the cos^mu model cannot follow: relative amplitude, [0, 0.5], and angular
  // period off the axis, degrees, (0, 90]. 0 = the ideal LED of the scan.
  double led_ripple = 0.0;
  double led_ripple_period_deg = 4.0;

  void Check() const;
};

// A target traced through the true camera once: per pixel its reflectance
// (area-averaged), the surface point and normal its centre's ray meets.
// Lighting it for each LED is then cheap.
struct PreparedTarget {
  // [0, 1]: 1 channel for a neutral target (every camera channel alike), 3
  // for the colour chart: white-balanced camera RGB per channel.
  ImageF reflectance;
  ImageF point_in_table;    // 3 channels, mm
  ImageF normal_in_table;   // 3 channels, unit
  // 1 channel: specular reflectance at the mirror direction; empty = matte.
  ImageF gloss;
  double gloss_width_deg = 12.0;  // half-vector angle where the gloss falls to 1/e
};

class TargetRenderer {
 public:
  // `sensor`: size, noise and Bayer layout (as the scan's); `true_rig`: the
  // rig as built. Throws std::invalid_argument if they do not fit together.
  TargetRenderer(const SimulatedRigOptions& sensor, RigDescription true_rig);

  const SimulatedRigOptions& sensor() const { return sensor_; }
  const RigDescription& rig() const { return rig_; }
  int num_leds() const { return static_cast<int>(rig_.leds.size()); }

  // Throws std::invalid_argument for a bad target or supersampling.
  PreparedTarget Prepare(const SimulatedTarget& target, const TargetRenderOptions& render = {}) const;

  // Noise-free linear RGB (fraction of the raw range above black), unclipped:
  // the LEDs `leds` (indices into rig().leds; empty = the dark frame) plus
  // ambient, times the exposure, then the blur. Throws std::out_of_range for a
  // bad LED index.
  ImageF RenderLinear(const PreparedTarget& target, const std::vector<int>& leds,
                      const TargetRenderOptions& render = {}) const;
  ImageF RenderLinear(const SimulatedTarget& target, std::optional<int> led,
                      const TargetRenderOptions& render = {}) const;

  // The RAW capture of the same, through the sensor model (RenderSensorMosaic).
  // Give every capture its own frame_index: it fixes the noise.
  RawImage RenderFrame(const PreparedTarget& target, const std::vector<int>& leds, uint64_t frame_index,
                       const TargetRenderOptions& render = {}) const;
  RawImage RenderFrame(const SimulatedTarget& target, std::optional<int> led, uint64_t frame_index,
                       const TargetRenderOptions& render = {}) const;

 private:
  SimulatedRigOptions sensor_;
  RigDescription rig_;
  ImageF rays_in_table_;  // per pixel centre, unit
  Eigen::Vector3d camera_centre_in_table_;
};

// table_from_target of the standard checkerboard views for a board of about
// 110 x 80 mm: the first lies flat on the table (it fixes the table pose), the
// others are tilted by 20 to 35 degrees at 30 to 70 mm above the table, all
// inside the field of view of the default rig.
std::vector<Eigen::Isometry3d> DefaultCheckerboardPoses();

// The rig as an operator describes it before calibrating.
struct MeasuredRigOptions {
  double led_position_error_mm = 3.0;  // rms per axis of the tape-measure error of each LED position, [0, 50]
  double nominal_mu = 1.0;             // datasheet angular falloff (Lambertian emitter), >= 0
  uint64_t seed = 2024;                // fixes the position errors

  void Check() const;
};

// From the true rig: LED positions off by a few mm (axes aimed from there at
// the table origin), every LED with the nominal mu and the same nominal
// intensity (the truth's mean, with the sensor's D65 raw white balance), the
// nominal camera (focal length from the lens and sensor size, principal point
// at the image centre, no distortion) looking straight down from 600 mm.
RigDescription MakeMeasuredRigDescription(const RigDescription& truth, const MeasuredRigOptions& options = {});

}  // namespace scanbench
