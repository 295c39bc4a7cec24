// Colour calibration on an X-Rite ColorChecker Classic: find the chart on a RAW
// mosaic, sample its 24 patches on the Bayer data per CFA colour, and fit the
// 3x3 matrix from white-balanced camera RGB to linear Rec.709 (D65). Without a
// chart, Rec709FromWhiteBalancedCamera derives the matrix from the RAW file's
// own colour matrix (the weaker path: a maker's matrix for a standard light,
// not this rig's LEDs).
//
// The chart frame: u runs along the 6 columns from dark skin towards bluish
// green, v along the 4 rows from the top row towards the gray row; the quad's
// corners are the outer corners of the corner patches, so (u, v) in [0, 1]^2
// covers the patch grid. Patches and gaps follow OpenCV mcc's chart model
// (patch 2.5, pitch 2.75 units).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calibration/color_checker.h"
#include "calibration/raw_image.h"
#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"

namespace scanbench {

// Image-pixel corners of the chart's 6x4 patch grid (outer corners of the corner patches):
// [0] dark skin (top left), [1] bluish green (top right), [2] black (bottom right), [3] white (bottom left).
// Pixel centres sit at integer coordinates of the full-resolution mosaic.
struct ColorChartQuad {
  std::array<Eigen::Vector2d, 4> corners_px{Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(),
                                            Eigen::Vector2d::Zero()};
};

// The homography from chart coordinates (u, v, 1) to image pixels (x, y, 1) * w.
Eigen::Matrix3d ColorChartImageFromUv(const ColorChartQuad& quad);
// Pixel position of chart point (u, v) (see the file comment) through the
// quad's homography.
Eigen::Vector2d ColorChartPointPx(const ColorChartQuad& quad, double u, double v);
// Corners of patch `index` (chart order, 0..23) shrunk by `inset` (fraction of
// the patch side left out at each edge, [0, 0.5)), in the quad's corner order.
std::array<Eigen::Vector2d, 4> ColorPatchCornersPx(const ColorChartQuad& quad, int index, double inset = 0);

struct ColorChartDetectionOptions {
  // Corner points given by the user: the detector is skipped; the orientation
  // is still checked (and corrected, with a warning, when another corner
  // order fits the reference far better).
  std::optional<ColorChartQuad> corners;
  // The longer side of the preview mcc searches, in pixels, [500, 8000]: the
  // mosaic is binned down by an even factor until it fits.
  int max_preview_side = 2000;
  // Charts mcc may return; each is checked against the reference, >= 1.
  int max_candidates = 3;
  // Part of the patch side left out at each edge when the orientation check
  // samples the patches, [0, 0.45].
  double patch_inset = 0.25;
  // Relative rms residual of the orientation check's linear fit (camera RGB ->
  // reference linear Rec.709) above which a candidate is not a ColorChecker, (0, 1].
  double max_fit_residual = 0.25;
  // A raw sample at or above this fraction of the white level is clipped, (0, 1].
  double clip_fraction = 0.98;
  // Names the frame in messages ("no ColorChecker found in <source_name>").
  std::string source_name = "the frame";

  // Throws std::invalid_argument (FieldError) naming the field, its value and the rule.
  void Check() const;
};

struct ColorChartDetectionSummary : AlgorithmSummary {
  ColorChartQuad quad;               // in chart order, full-resolution mosaic pixels
  std::string method;                // "mcc" or "corners"
  int candidates = 0;                // charts the detector returned (0 with given corners)
  int preview_binning = 0;           // mosaic pixels per preview pixel (0 with given corners)
  // Orientation check: relative rms residual of the best corner order's linear
  // fit, of the next best order's, and 1 - best / next best in [0, 1]
  // (near 1: unambiguous).
  double fit_residual = 0;
  double next_fit_residual = 0;
  double confidence = 0;
  int patches_used_for_check = 0;    // unclipped, exposed patches in the check
  bool reordered = false;            // the detector's / user's corner order was changed
  std::string warning;               // e.g. given corners that were reordered; empty if none

  // "Colour chart detection (mcc): success, orientation residual 0.021 (next 0.41, confidence 0.95)".
  std::string BriefReport() const;
};

// Finds the chart on a RAW mosaic (develops a binned, gray-world balanced,
// sRGB-encoded preview for mcc), checks patch order and orientation against
// the reference (all 8 corner orders: 4 rotations, mirrored or not; the one
// whose patches fit the reference best through a linear fit wins) and returns
// the quad in chart order. kFailure with "no ColorChecker found in <source>:
// ..." when mcc finds none or no candidate fits. Throws std::invalid_argument
// for bad options or frames that do not fit together.
ColorChartDetectionSummary DetectColorChart(const ColorChartDetectionOptions& options, const RawImage& frame,
                                            const RawImage* dark, const ProgressCallback& progress = {});

struct PatchSample {
  // Per colour: median of (raw - dark) / (white - black), divided by the white
  // response when given (then a reflectance).
  Eigen::Vector3d value = Eigen::Vector3d::Zero();
  std::array<int, 3> samples{};      // per colour, unclipped samples in the inset square
  bool clipped = false;              // a sample reached clip_fraction * white
  bool too_dark = false;             // a colour's median below min_level
  bool too_few = false;              // a colour with fewer than min_samples samples
  bool used = false;                 // none of the above
};

struct ColorPatchSamplingOptions {
  // Part of the patch side left out at each edge, [0, 0.45]: keeps the
  // samples inside the patch despite registration error and blur.
  double patch_inset = 0.2;
  // A raw sample at or above this fraction of the white level is clipped, (0, 1].
  double clip_fraction = 0.98;
  // A patch whose median is below this in any colour is too dark (noise and
  // black error dominate), in the units of `value`, [0, 1).
  double min_level = 0.002;
  // Samples needed per patch and colour, >= 1.
  int min_samples = 20;

  void Check() const;
};

// Per patch (chart order, 24) and CFA colour: median of (raw - dark) / (white
// - black) inside the inset patch, optionally divided per pixel and channel by
// `white_response` (3-channel image of the mosaic's size: what a perfect white
// would read at that pixel, e.g. the calibrated light field times n.l), which
// makes the values reflectances. `dark` null: the frame's black level.
// Throws std::invalid_argument for bad options or inputs that do not fit.
std::vector<PatchSample> SampleColorChartPatches(const ColorPatchSamplingOptions& options, const RawImage& frame,
                                                 const RawImage* dark, const ColorChartQuad& quad,
                                                 const ImageF* white_response);

struct ColorCorrectionOptions {
  enum class Method {
    kCiede2000Fit,  // weighted least squares in linear RGB, then Levenberg-Marquardt on CIEDE2000
    kOpenCvCcm,     // OpenCV's cv::ccm::ColorCorrectionModel (3x3, CIEDE2000, Nelder-Mead)
  };
  Method method = Method::kCiede2000Fit;
  // Constrain M * (1, 1, 1) = (1, 1, 1): neutrals stay neutral and the absolute
  // scale set by the white sheet survives. kCiede2000Fit only (OpenCV's ccm
  // has no such constraint; its summary says so).
  bool preserve_white = true;
  // Weight of a neutral patch relative to a chromatic one in the fit, [0, 100].
  double neutral_weight = 1.0;
  // Balance the measured values first with per-colour gains fitted on the used
  // neutral patches to their reference reflectance (for a RAW frame without a
  // white response); false: `measured` is white-balanced already.
  bool balance_on_neutral_patches = false;
  // Levenberg-Marquardt iterations of kCiede2000Fit, [1, 10000].
  int max_iterations = 200;
  // Fewest used patches, and neutral ones among them, a fit needs ([6, 24], [2, 6]).
  int min_patches = 6;
  int min_neutral_patches = 2;

  void Check() const;
};
// "ciede2000_fit", "opencv_ccm".
std::string ColorCorrectionMethodName(ColorCorrectionOptions::Method method);

struct ColorPatchResult {
  std::string name;
  Eigen::Vector3d measured_camera = Eigen::Vector3d::Zero();          // white-balanced camera RGB
  Eigen::Vector3d reference_linear_rec709 = Eigen::Vector3d::Zero();
  Eigen::Vector3d corrected_linear_rec709 = Eigen::Vector3d::Zero();  // rec709_from_camera * measured
  double delta_e_before = 0;  // CIEDE2000, camera RGB taken as linear Rec.709
  double delta_e_after = 0;   // CIEDE2000 of the corrected value
  bool used = false;          // in the fit (and in the statistics)
  std::string status;         // "used", or why not: "clipped", "too dark", "too few samples", "not finite"
};

struct ColorCorrectionSummary : AlgorithmSummary {
  Eigen::Matrix3d rec709_from_camera = Eigen::Matrix3d::Identity();  // linear Rec.709 = M * white-balanced camera RGB
  std::string method;
  // Gains applied to the measured values before M (balance_on_neutral_patches), else (1, 1, 1).
  Eigen::Vector3d camera_balance_gains = Eigen::Vector3d::Ones();
  std::vector<ColorPatchResult> patches;  // chart order
  int used_patches = 0;
  // CIEDE2000 over the used patches.
  double mean_delta_e_before = 0, max_delta_e_before = 0, mean_delta_e_after = 0, max_delta_e_after = 0;

  // "Colour correction (ciede2000_fit): success, 24 patches, CIEDE2000 mean 9.1 -> 0.6, max 21.3 -> 1.9".
  std::string BriefReport() const;
  // One header line, then one line per patch: name, measured, reference,
  // corrected, CIEDE2000 before and after, used or why not.
  std::string PatchTable() const;
};

// Per colour, the gain that takes the used neutral patches of `measured`
// (chart order) to their reference in least squares: the white balance and
// scale a photo's gray row gives. nullopt (and the reason in *why) with fewer
// than 2 usable neutral patches or a colour they do not register in.
std::optional<Eigen::Vector3d> NeutralPatchGains(const std::vector<PatchSample>& measured,
                                                 const std::vector<ColorCheckerPatch>& reference,
                                                 std::string* why = nullptr);

// Fits rec709_from_camera on the used patches of `measured` (chart order, one
// per reference patch). kFailure naming what is missing with fewer than
// min_patches used patches or min_neutral_patches neutral ones among them.
// Throws std::invalid_argument for bad options or sizes that do not fit.
ColorCorrectionSummary FitColorCorrection(const ColorCorrectionOptions& options,
                                          const std::vector<PatchSample>& measured,
                                          const std::vector<ColorCheckerPatch>& reference);

// The fallback without a chart: from the RAW file's camera matrix (XYZ ->
// camera native under D65, any scale, e.g. the DNG's ColorMatrix1) to a linear
// Rec.709 matrix for white-balanced camera RGB (camera native divided by the
// D65 white's native response), scaled so that (1, 1, 1) -> (1, 1, 1).
// Throws std::invalid_argument for a singular or non-finite matrix.
Eigen::Matrix3d Rec709FromWhiteBalancedCamera(const Eigen::Matrix3d& camera_from_xyz);

}  // namespace scanbench
