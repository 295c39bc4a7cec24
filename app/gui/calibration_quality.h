// Judges the figures the calibrations report (their summaries, nothing
// recomputed) against thresholds, and says in plain words what to fix when a
// figure is bad. The Calibration page shows the result; plain C++ (no Qt), so
// that the limits can be tested and read in one place.
//
// The calibrations themselves only reject what cannot be used (a blurred view,
// a clipped patch); these limits are the operator's: a calibration that runs
// but whose figures say the capture should be retaken. Where the calibration
// library has a limit of its own (max_view_rms_px, linearity_tolerance,
// model_noise_factor, max_edge_width_px) the warn/fail levels are taken from
// it; the others are set from what the simulated rig measures with clean
// captures (docs/calibration.md) with room for a real bench, and are
// documented in docs/gui.md (Calibration).
#pragma once

#include <string>
#include <vector>

#include "calibration/camera_calibration.h"
#include "calibration/color_calibration.h"
#include "calibration/light_calibration.h"
#include "calibration/rig.h"
#include "calibration/white_balance.h"
#include "core/image.h"

namespace scanbench {

// Every threshold of the Calibration page. A figure passes up to `pass`, warns
// up to `warn` and fails above (or below, for the minimum counts).
namespace calibration_limits {
// Camera. Corner positions from a sharp, flat board fit the lens model to a
// tenth of a pixel (0.075 px on the simulated rig); above half a pixel the
// board bent or moved, or the focus was off. The calibration rejects a view
// above its max_view_rms_px (1 px), so 1 px overall is a failure.
inline constexpr double kReprojectionRmsPassPx = 0.5;
inline constexpr double kReprojectionRmsWarnPx = 1.0;  // = CameraCalibrationOptions::max_view_rms_px
// Per view: edges rising over more pixels than this are soft (an in-focus
// board measures 1-2.4 px; the calibration rejects above 3 px).
inline constexpr double kEdgeWidthPassPx = 2.5;
// Views: 6 or more poses at varied tilts pin down focal length and principal
// point; 4 is the calibration's minimum (CameraCalibrationOptions::min_views).
inline constexpr int kUsedViewsPass = 6;
// One standard deviation of the focal length, relative (0.4 % on the
// simulated rig with 9 views), and of the principal point, as a fraction of
// the image width (2.8 % there: a narrow lens ties it to the views' tilt).
inline constexpr double kFocalStdPass = 0.01;
inline constexpr double kFocalStdWarn = 0.03;
inline constexpr double kPrincipalPointStdPass = 0.05;
inline constexpr double kPrincipalPointStdWarn = 0.10;

// White balance, per LED. Residual of the linear fit, rms relative: the
// simulated sensor shows 0.1-0.4 %; above linearity_tolerance (1 %) the
// calibration would flag patches non-linear.
inline constexpr double kLinearityRmsPass = 0.005;
inline constexpr double kLinearityRmsWarn = 0.01;  // = WhiteBalanceOptions::linearity_tolerance
// |response exponent - 1|: a RAW sensor is linear (1.000 +- 0.003 simulated);
// a JPEG or a processed file shows 0.4-0.5 off.
inline constexpr double kExponentPass = 0.02;
inline constexpr double kExponentWarn = 0.05;
// Patches left out (clipped, underexposed, non-linear): the darkest one or two
// are expected under the low LEDs; fewer than 3 used fails the calibration.
inline constexpr int kPatchesLeftOutPass = 2;
// An LED's gains against the median of all LEDs, relative: LEDs of one bin
// differ by a few percent; more means another LED type or a coloured
// reflection near it.
inline constexpr double kGrayDeviationPass = 0.05;
inline constexpr double kGrayDeviationWarn = 0.15;
// Gain uncertainty, relative (0.06 % simulated).
inline constexpr double kGainStdPass = 0.005;
inline constexpr double kGainStdWarn = 0.02;

// Lights, per LED. The model's residual over the cells' noise (chi): the
// model is used when within LightCalibrationOptions::model_noise_factor (2).
inline constexpr double kChiPass = 2.0;  // = LightCalibrationOptions::model_noise_factor
// How far the calibrated LED lies from the rig description's (tape-measured)
// position: a careful measurement is a few mm off per axis (the simulated
// rig's 3 mm rms per axis puts the calibrated LEDs 3-12 mm away); several cm
// means a wrong position in the rig file or swapped LEDs.
inline constexpr double kPositionChangePassMm = 15.0;
inline constexpr double kPositionChangeWarnMm = 40.0;
// One standard deviation of the fitted position, largest axis (0.4-3 mm
// simulated with the spacer sheet; 10-15 mm with one sheet height only).
inline constexpr double kPositionStdPassMm = 5.0;
inline constexpr double kPositionStdWarnMm = 15.0;
// Cells of the table sheet dropped (clipped, dark, dust or creases).
inline constexpr double kCellsDroppedPass = 0.05;
inline constexpr double kCellsDroppedWarn = 0.20;

// Colour, CIEDE2000 of the corrected patches against the ColorChecker
// reference. About 1 is the smallest difference an observer sees side by
// side; the simulated D5100 fits to a mean of 1.0 and a max of 3.4 (cyan,
// outside the Rec.709 gamut) with clean captures. A mean above 4 or a patch
// above 10 means the chart, its light or the fit went wrong.
inline constexpr double kColorMeanDeltaEPass = 2.0;
inline constexpr double kColorMeanDeltaEWarn = 4.0;
inline constexpr double kColorMaxDeltaEPass = 5.0;
inline constexpr double kColorMaxDeltaEWarn = 10.0;
// Patches in the fit: all 24 pass; a few left out (clipped white, a patch
// in glare) warn; fewer than this fail (the fit's own minimum is 6).
inline constexpr int kColorPatchesUsedWarn = 18;
}  // namespace calibration_limits

struct QualityFigure {
  enum class Mark { kPass, kWarn, kFail, kInfo };
  std::string group;   // "" = the calibration as a whole; "LED 3", "View checkerboard_2"
  std::string name;    // "reprojection RMS"
  double value = 0;    // the summary's figure, as reported (units in `text`)
  std::string text;    // the value as shown, with its unit: "0.075 px"
  std::string limit;   // "pass <= 0.5 px, warn <= 1 px"
  Mark mark = Mark::kInfo;
  std::string hint;    // what to fix; "" when it passes
};

const char* QualityMarkName(QualityFigure::Mark mark);  // "pass", "warn", "FAIL", ""
// The worst mark of `figures` (kInfo counts as a pass); kPass when empty.
QualityFigure::Mark WorstMark(const std::vector<QualityFigure>& figures);

// Figures of a successful calibration, whole-calibration ones first, then per
// view or LED.
std::vector<QualityFigure> CameraQuality(const CameraCalibrationSummary& summary);
std::vector<QualityFigure> WhiteBalanceQuality(const WhiteBalanceSummary& summary);
// `measured_leds`: the rig description the calibration started from (the
// first white sheet session's), for the position change; empty leaves it out.
std::vector<QualityFigure> LightsQuality(const LightCalibrationSummary& summary,
                                         const std::vector<LedDescription>& measured_leds);

// Patches of `fit` in the fit, counted from the patches: a summary read back
// from a calibration set keeps each patch's `used` but not `used_patches`.
int UsedColorPatches(const ColorCorrectionSummary& fit);
// "used", or why not ("clipped", ...; "left out" when the reason was not kept).
std::string ColorPatchStatusText(const ColorPatchResult& patch);
// `white_reference`: the colour section's ("light_field" or "neutral_patches").
std::vector<QualityFigure> ColorQuality(const ColorCorrectionSummary& fit, const std::string& white_reference);

// The before / after swatches of a colour calibration, 8-bit sRGB (3
// channels), for the eye: the patches in chart order on a 6 x 4 grid (dark
// skin top left), each a square of `swatch_px` split into three vertical
// stripes — the measured camera RGB shown as if it were linear Rec.709
// (before), the reference, the corrected value (after) — so that each of
// before and after sits beside the reference. Swatch i's top left corner is at
// (g + (i % 6) (swatch_px + g), g + (i / 6) (swatch_px + g)) with the gap
// g = SwatchGapPx(swatch_px); stripe k covers x in [k s / 3, (k + 1) s / 3)
// (integer division). The gaps are dark gray; a patch left out of the fit is
// framed in red within the gap. Values are SrgbEncode'd (clamped to [0, 1]);
// a non-finite value shows black. Throws std::invalid_argument for swatch_px < 6.
ImageU8 ColorChartSwatches(const ColorCorrectionSummary& fit, int swatch_px = 48);
int SwatchGapPx(int swatch_px);

// A plain-language fix for a calibration that failed with `message` (the
// controller's error), or "" when the message says it all.
enum class CalibrationStep { kCamera, kWhiteBalance, kLights, kColor };
std::string FixHintForError(CalibrationStep step, const std::string& message);

}  // namespace scanbench
