#include "app/gui/calibration_quality.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "calibration/color_checker.h"
#include "calibration/color_science.h"
#include "core/format.h"

namespace scanbench {
namespace limits = calibration_limits;
using Mark = QualityFigure::Mark;

namespace {

std::string Percent(double fraction, int digits) { return Fixed(100 * fraction, digits) + " %"; }

// Pass up to `pass`, warn up to `warn`, fail above (NaN fails).
Mark Grade(double value, double pass, double warn) {
  if (value <= pass) return Mark::kPass;
  if (value <= warn) return Mark::kWarn;
  return Mark::kFail;
}

std::string Limit(const std::string& pass, const std::string& warn) {
  return "pass <= " + pass + ", warn <= " + warn;
}

// "a, b and c"
std::string JoinAnd(const std::vector<std::string>& items) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) {
    if (i > 0) out += i + 1 == items.size() ? " and " : ", ";
    out += items[i];
  }
  return out;
}

// A view's short name: its session folder's name.
std::string ViewName(const CalibrationViewReport& view) {
  const std::filesystem::path path(view.name);
  const std::string name = path.filename().string();
  return name.empty() ? path.parent_path().filename().string() : name;
}

QualityFigure Figure(std::string group, std::string name, double value, std::string text, std::string limit,
                     Mark mark, std::string hint) {
  QualityFigure figure;
  figure.group = std::move(group);
  figure.name = std::move(name);
  figure.value = value;
  figure.text = std::move(text);
  figure.limit = std::move(limit);
  figure.mark = mark;
  if (mark == Mark::kWarn || mark == Mark::kFail) figure.hint = std::move(hint);
  return figure;
}

}  // namespace

const char* QualityMarkName(Mark mark) {
  switch (mark) {
    case Mark::kPass: return "pass";
    case Mark::kWarn: return "warn";
    case Mark::kFail: return "FAIL";
    case Mark::kInfo: return "";
  }
  return "";
}

Mark WorstMark(const std::vector<QualityFigure>& figures) {
  Mark worst = Mark::kPass;
  for (const QualityFigure& figure : figures) {
    if (figure.mark == Mark::kFail) return Mark::kFail;
    if (figure.mark == Mark::kWarn) worst = Mark::kWarn;
  }
  return worst;
}

// ---------------------------------------------------------------------------
std::vector<QualityFigure> CameraQuality(const CameraCalibrationSummary& s) {
  std::vector<QualityFigure> figures;
  const std::string rms_limit = Limit(Fixed(limits::kReprojectionRmsPassPx, 1) + " px",
                                      Fixed(limits::kReprojectionRmsWarnPx, 1) + " px");

  // The views to retake first: those above the pass level, worst first.
  std::vector<const CalibrationViewReport*> used;
  for (const CalibrationViewReport& view : s.views) {
    if (view.used) used.push_back(&view);
  }
  std::sort(used.begin(), used.end(), [](auto* a, auto* b) { return a->rms_px > b->rms_px; });
  std::vector<std::string> worst;
  for (const CalibrationViewReport* view : used) {
    if (view->rms_px > limits::kReprojectionRmsPassPx && worst.size() < 3) worst.push_back(ViewName(*view));
  }
  std::string retake = worst.empty() ? "" : ", and retake " + JoinAnd(worst) + " (the worst views)";

  const double rms = s.reprojection_rms_px;
  figures.push_back(Figure("", "reprojection RMS, all views", rms, Fixed(rms, 3) + " px", rms_limit,
                           Grade(rms, limits::kReprojectionRmsPassPx, limits::kReprojectionRmsWarnPx),
                           "reprojection RMS " + Fixed(rms, 2) + " px > " + Fixed(limits::kReprojectionRmsPassPx, 1) +
                               " px: refocus on the board, hold it flatter (mounted on glass or card) and still" +
                               retake));
  const double table_rms = s.table_view_rms_px;
  figures.push_back(Figure("", "reprojection RMS, table view", table_rms, Fixed(table_rms, 3) + " px", rms_limit,
                           Grade(table_rms, limits::kReprojectionRmsPassPx, limits::kReprojectionRmsWarnPx),
                           "table view RMS " + Fixed(table_rms, 2) + " px > " +
                               Fixed(limits::kReprojectionRmsPassPx, 1) +
                               " px: the board lying on the table sets the table's pose; lay it flat (no bulge, "
                               "nothing under it), rows along the image's x, and retake that view"));

  const int num_views = static_cast<int>(s.views.size());
  const int rejected = num_views - s.num_used_views;
  const CameraCalibrationOptions defaults;
  Mark views_mark = s.num_used_views < defaults.min_views ? Mark::kFail
                    : (s.num_used_views < limits::kUsedViewsPass || rejected > 0) ? Mark::kWarn
                                                                                   : Mark::kPass;
  std::string views_hint;
  if (rejected > 0) views_hint = std::to_string(rejected) + " view(s) rejected (see below): retake them";
  if (s.num_used_views < limits::kUsedViewsPass) {
    views_hint += std::string(views_hint.empty() ? "" : "; ") + "only " + std::to_string(s.num_used_views) +
                  " views used: add poses with the board tilted 20-35 degrees in different directions";
  }
  figures.push_back(Figure("", "views used", s.num_used_views,
                           std::to_string(s.num_used_views) + " of " + std::to_string(num_views),
                           "pass: all, and >= " + std::to_string(limits::kUsedViewsPass) + "; fail < " +
                               std::to_string(defaults.min_views),
                           views_mark, views_hint));

  const CameraIntrinsics& k = s.camera.intrinsics;
  const double focal_std = std::max(s.intrinsics_std[0] / k.fx, s.intrinsics_std[1] / k.fy);
  figures.push_back(Figure("", "focal length uncertainty", focal_std,
                           Percent(focal_std, 2) + " (fx " + Fixed(k.fx, 1) + " +- " + Fixed(s.intrinsics_std[0], 1) +
                               " px)",
                           Limit(Percent(limits::kFocalStdPass, 0), Percent(limits::kFocalStdWarn, 0)),
                           Grade(focal_std, limits::kFocalStdPass, limits::kFocalStdWarn),
                           "the focal length is uncertain by " + Percent(focal_std, 1) +
                               ": add views with the board tilted more (20-35 degrees) in different directions"));
  const double centre_std = std::max(s.intrinsics_std[2], s.intrinsics_std[3]) / std::max(1, k.width);
  figures.push_back(Figure("", "principal point uncertainty", centre_std,
                           Percent(centre_std, 1) + " of the width (cx " + Fixed(k.cx, 1) + " +- " +
                               Fixed(s.intrinsics_std[2], 1) + ", cy " + Fixed(k.cy, 1) + " +- " +
                               Fixed(s.intrinsics_std[3], 1) + " px)",
                           Limit(Percent(limits::kPrincipalPointStdPass, 0),
                                 Percent(limits::kPrincipalPointStdWarn, 0)),
                           Grade(centre_std, limits::kPrincipalPointStdPass, limits::kPrincipalPointStdWarn),
                           "the image centre is uncertain by " + Percent(centre_std, 1) +
                               " of the width: add views tilted about both axes, with the board near the corners "
                               "of the image as well as in the middle"));

  const CheckerboardDetectionOptions detection;
  for (const CalibrationViewReport& view : s.views) {
    const std::string group = "view " + ViewName(view) + (view.on_table ? " (on the table)" : "");
    if (!view.used) {
      figures.push_back(Figure(group, "rejected", 0, view.reason, "", Mark::kWarn,
                               "retake " + ViewName(view) + ": " + view.reason));
      continue;
    }
    figures.push_back(Figure(group, "reprojection RMS", view.rms_px, Fixed(view.rms_px, 3) + " px", rms_limit,
                             Grade(view.rms_px, limits::kReprojectionRmsPassPx, limits::kReprojectionRmsWarnPx),
                             "retake " + ViewName(view) + " (RMS " + Fixed(view.rms_px, 2) +
                                 " px): hold the board flat and still"));
    figures.push_back(Figure(group, "edge width", view.edge_width_px, Fixed(view.edge_width_px, 2) + " px",
                             "pass <= " + Fixed(limits::kEdgeWidthPassPx, 1) + " px, rejected > " +
                                 Fixed(detection.max_edge_width_px, 1) + " px",
                             view.edge_width_px <= limits::kEdgeWidthPassPx ? Mark::kPass : Mark::kWarn,
                             ViewName(view) + " is soft (edges " + Fixed(view.edge_width_px, 1) +
                                 " px wide): refocus on the board, stop down, or steady the camera"));
  }
  return figures;
}

// ---------------------------------------------------------------------------
std::vector<QualityFigure> WhiteBalanceQuality(const WhiteBalanceSummary& s) {
  std::vector<QualityFigure> figures;
  // Each colour's median gain over the LEDs: what "the others" read.
  Eigen::Vector3d median = Eigen::Vector3d::Ones();
  for (int c : {0, 2}) {
    std::vector<double> gains;
    for (const LedWhiteBalance& led : s.leds) gains.push_back(led.gains[c]);
    if (gains.empty()) continue;
    std::nth_element(gains.begin(), gains.begin() + gains.size() / 2, gains.end());
    median[c] = gains[gains.size() / 2];
  }
  for (const LedWhiteBalance& led : s.leds) {
    const std::string group = "LED " + std::to_string(led.led_index);
    const std::string name = "LED " + std::to_string(led.led_index);

    const double linear = led.linearity_rms.maxCoeff();
    figures.push_back(Figure(group, "linearity residual", linear,
                             Percent(linear, 2) + " rms over " + Fixed(led.linear_range_min, 3) + ".." +
                                 Fixed(led.linear_range_max, 3) + " of the range",
                             Limit(Percent(limits::kLinearityRmsPass, 1), Percent(limits::kLinearityRmsWarn, 0)),
                             Grade(linear, limits::kLinearityRmsPass, limits::kLinearityRmsWarn),
                             name + " reads off the linear fit by " + Percent(linear, 2) +
                                 ": the chart must be matte, flat and evenly lit (no shadow, no glare from the LED)"));

    const double exponent = (led.response_exponent.array() - 1).abs().maxCoeff();
    figures.push_back(Figure(group, "response exponent", exponent,
                             Fixed(led.response_exponent[0], 3) + " / " + Fixed(led.response_exponent[1], 3) + " / " +
                                 Fixed(led.response_exponent[2], 3) + " (R/G/B; 1 = linear)",
                             "|exponent - 1| " +
                                 Limit(Fixed(limits::kExponentPass, 2), Fixed(limits::kExponentWarn, 2)),
                             Grade(exponent, limits::kExponentPass, limits::kExponentWarn),
                             "the sensor does not respond linearly under " + name +
                                 ": the frames must be RAW (NEF, DNG), not JPEG, with in-camera processing "
                                 "(Active D-Lighting, picture control) off"));

    std::vector<std::string> clipped, underexposed, nonlinear;
    for (const PatchMeasurement& patch : led.patches) {
      if (patch.clipped) clipped.push_back(patch.name);
      if (patch.underexposed) underexposed.push_back(patch.name);
      if (patch.nonlinear) nonlinear.push_back(patch.name);
    }
    const int total = static_cast<int>(led.patches.size());
    const int left_out = total - led.used_patches;
    Mark patches_mark = led.used_patches < 3 ? Mark::kFail
                        : (!clipped.empty() || left_out > limits::kPatchesLeftOutPass) ? Mark::kWarn
                                                                                        : Mark::kPass;
    std::string flags;
    if (!clipped.empty()) flags += "; clipped " + JoinAnd(clipped);
    if (!underexposed.empty()) flags += "; underexposed " + JoinAnd(underexposed);
    if (!nonlinear.empty()) flags += "; non-linear " + JoinAnd(nonlinear);
    std::string hint;
    if (!clipped.empty()) {
      hint = JoinAnd(clipped) + " clipped under " + name + ": shorten the exposure (or lower the LED current)";
    }
    if (underexposed.size() > static_cast<size_t>(limits::kPatchesLeftOutPass)) {
      hint += std::string(hint.empty() ? "" : "; ") + JoinAnd(underexposed) + " underexposed under " + name +
              ": lengthen the exposure";
    }
    if (!nonlinear.empty()) {
      hint += std::string(hint.empty() ? "" : "; ") + JoinAnd(nonlinear) + " off the linear fit under " + name +
              ": check the chart for glare, dirt or a shadow on those patches";
    }
    figures.push_back(Figure(group, "patches used", led.used_patches,
                             std::to_string(led.used_patches) + " of " + std::to_string(total) + flags,
                             "pass: none clipped, <= " + std::to_string(limits::kPatchesLeftOutPass) +
                                 " left out; fail < 3 used",
                             patches_mark, hint));

    const double deviation = std::max(std::abs(led.gains[0] / median[0] - 1), std::abs(led.gains[2] / median[2] - 1));
    figures.push_back(Figure(group, "gray deviation from the other LEDs", deviation,
                             Percent(deviation, 1) + " (gains R " + Fixed(led.gains[0], 4) + ", B " +
                                 Fixed(led.gains[2], 4) + ")",
                             Limit(Percent(limits::kGrayDeviationPass, 0), Percent(limits::kGrayDeviationWarn, 0)),
                             Grade(deviation, limits::kGrayDeviationPass, limits::kGrayDeviationWarn),
                             name + "'s colour differs from the others' by " + Percent(deviation, 1) +
                                 ": check it is the same LED type (D65) as the others and that nothing coloured "
                                 "reflects its light onto the chart (the solve corrects each LED, but a mixed set "
                                 "is worth fixing)"));

    const double gain_std = std::max(led.gains_std[0] / led.gains[0], led.gains_std[2] / led.gains[2]);
    figures.push_back(Figure(group, "gain uncertainty", gain_std, Percent(gain_std, 3),
                             Limit(Percent(limits::kGainStdPass, 1), Percent(limits::kGainStdWarn, 0)),
                             Grade(gain_std, limits::kGainStdPass, limits::kGainStdWarn),
                             name + "'s gains are uncertain by " + Percent(gain_std, 2) +
                                 ": the chart's patches disagree; clean the chart and keep it flat and matte"));
  }
  return figures;
}

// ---------------------------------------------------------------------------
std::vector<QualityFigure> LightsQuality(const LightCalibrationSummary& s,
                                         const std::vector<LedDescription>& measured_leds) {
  std::vector<QualityFigure> figures;
  const bool model_selected = s.selected == LightCalibrationSummary::Choice::kModel;
  figures.push_back(Figure("", "light description used", model_selected ? 1 : 0,
                           std::string(model_selected ? "fitted LED model" : "per-pixel field") + " (" +
                               s.selection_reason + ")",
                           "", Mark::kInfo, ""));
  for (const std::string& warning : s.warnings) {
    figures.push_back(Figure("", "warning", 0, warning, "", Mark::kWarn, warning));
  }
  for (size_t k = 0; k < s.model.size(); ++k) {
    const LedModelFit& m = s.model[k];
    const std::string name = "LED " + std::to_string(m.led.id);
    const std::string group = name;

    if (!m.usable) {
      figures.push_back(Figure(group, "model fit", 0, "failed: " + m.termination, "", Mark::kWarn,
                               name + " does not fit the LED model (" + m.termination +
                                   "): the per-pixel field is used; check the LED lights evenly and both sheets "
                                   "fill the view"));
    } else {
      figures.push_back(Figure(group, "model residual / noise (chi)", m.chi,
                               Fixed(m.chi, 2) + " (residual " + Percent(m.residual_rms, 3) + ", noise " +
                                   Percent(m.noise_rms, 3) + ")",
                               "pass <= " + Fixed(limits::kChiPass, 1) + " (the model is used)",
                               m.chi <= limits::kChiPass ? Mark::kPass : Mark::kWarn,
                               name + " does not follow the point-source model (chi " + Fixed(m.chi, 2) + " > " +
                                   Fixed(limits::kChiPass, 1) +
                                   "): the per-pixel field is used instead; check its diffuser and reflector, and "
                                   "that the sheets are flat, clean and not creased"));
      const double position_std = m.position_std_mm.maxCoeff();
      figures.push_back(Figure(group, "position uncertainty", position_std, "+- " + Fixed(position_std, 2) + " mm",
                               Limit(Fixed(limits::kPositionStdPassMm, 0) + " mm",
                                     Fixed(limits::kPositionStdWarnMm, 0) + " mm"),
                               Grade(position_std, limits::kPositionStdPassMm, limits::kPositionStdWarnMm),
                               name + "'s position is uncertain by " + Fixed(position_std, 1) +
                                   " mm: add the sheet on the spacer (a second height fixes the distance) and let "
                                   "both sheets fill the view"));
    }

    // Where the light calibration puts the LED against the rig description.
    if (k < measured_leds.size()) {
      Eigen::Vector3d position = m.led.position_in_table_mm;
      if (!model_selected && k < s.per_pixel.size()) position = s.per_pixel[k].position_in_table_mm;
      const double change = (position - measured_leds[k].position_in_table_mm).norm();
      figures.push_back(Figure(group, "position change from the rig description", change,
                               Fixed(change, 1) + " mm (now at " + Fixed(position.x(), 1) + ", " +
                                   Fixed(position.y(), 1) + ", " + Fixed(position.z(), 1) + " mm)",
                               Limit(Fixed(limits::kPositionChangePassMm, 0) + " mm",
                                     Fixed(limits::kPositionChangeWarnMm, 0) + " mm"),
                               Grade(change, limits::kPositionChangePassMm, limits::kPositionChangeWarnMm),
                               name + " lies " + Fixed(change, 0) +
                                   " mm from where the rig description puts it: re-measure it, and check that the "
                                   "LED wiring order matches the rig file"));
    }

    if (k < s.per_pixel.size()) {
      const LedPerPixelFit& f = s.per_pixel[k];
      figures.push_back(Figure(group, "per-pixel procedure", f.converged ? 1 : 0,
                               std::to_string(f.iterations) + " iterations, " +
                                   (f.converged ? "converged" : "NOT converged"),
                               "pass: converged",
                               f.converged ? Mark::kPass : model_selected ? Mark::kWarn : Mark::kFail,
                               name + "'s per-pixel field did not converge in " + std::to_string(f.iterations) +
                                   " iterations: check that the sheets lie flat and that the spacer height in the "
                                   "spacer session's target.json is right"));
      const int cells = f.cells_used + f.cells_dropped;
      const double dropped = cells > 0 ? double(f.cells_dropped) / cells : 0;
      figures.push_back(Figure(group, "cells dropped", dropped,
                               Percent(dropped, 1) + " (" + std::to_string(f.cells_dropped) + " of " +
                                   std::to_string(cells) + ")",
                               Limit(Percent(limits::kCellsDroppedPass, 0), Percent(limits::kCellsDroppedWarn, 0)),
                               Grade(dropped, limits::kCellsDroppedPass, limits::kCellsDroppedWarn),
                               Percent(dropped, 0) + " of the sheet's cells under " + name +
                                   " were dropped (clipped, dark, dust or creases): clean and flatten the sheet, "
                                   "and shorten the exposure if it clips"));
    }
  }
  return figures;
}

// ---------------------------------------------------------------------------
// ---------------------------------------------------------------------------
namespace {

// What to do about a patch the fit left out, by its status.
std::string PatchFix(const ColorPatchResult& patch) {
  if (patch.status.empty()) return patch.name + " left out: check it for glare, shadow or clipping";
  if (patch.status == "clipped") return patch.name + " clipped: shorten the exposure or dim the LEDs";
  if (patch.status == "too dark") return patch.name + " too dark: lengthen the exposure";
  if (patch.status == "too few samples") {
    return patch.name + " has too few pixels: bring the camera closer or use a larger chart";
  }
  return patch.name + " " + patch.status + ": check the chart's corners and retake it";
}

}  // namespace

int UsedColorPatches(const ColorCorrectionSummary& fit) {
  return static_cast<int>(
      std::count_if(fit.patches.begin(), fit.patches.end(), [](const ColorPatchResult& p) { return p.used; }));
}

std::string ColorPatchStatusText(const ColorPatchResult& patch) {
  if (patch.used) return "used";
  return patch.status.empty() ? "left out" : patch.status;
}

std::vector<QualityFigure> ColorQuality(const ColorCorrectionSummary& s, const std::string& white_reference) {
  std::vector<QualityFigure> figures;
  const int used = UsedColorPatches(s);
  const std::string over = " over " + std::to_string(used) + " patches";
  figures.push_back(Figure("", "CIEDE2000 mean, corrected", s.mean_delta_e_after,
                           Fixed(s.mean_delta_e_after, 2) + " (before " + Fixed(s.mean_delta_e_before, 2) + ")" + over,
                           Limit(Fixed(limits::kColorMeanDeltaEPass, 0), Fixed(limits::kColorMeanDeltaEWarn, 0)),
                           Grade(s.mean_delta_e_after, limits::kColorMeanDeltaEPass, limits::kColorMeanDeltaEWarn),
                           "the corrected patches are " + Fixed(s.mean_delta_e_after, 1) +
                               " CIEDE2000 off on average: light the chart evenly (no glare, no shadow), keep it "
                               "flat and clean, and calibrate the lights before this step"));

  const ColorPatchResult* worst = nullptr;
  for (const ColorPatchResult& patch : s.patches) {
    if (patch.used && (!worst || patch.delta_e_after > worst->delta_e_after)) worst = &patch;
  }
  const std::string worst_name = worst ? worst->name : std::string("none");
  figures.push_back(Figure("", "CIEDE2000 max, corrected", s.max_delta_e_after,
                           Fixed(s.max_delta_e_after, 2) + " (" + worst_name + "; before " +
                               Fixed(s.max_delta_e_before, 2) + ")",
                           Limit(Fixed(limits::kColorMaxDeltaEPass, 0), Fixed(limits::kColorMaxDeltaEWarn, 0)),
                           Grade(s.max_delta_e_after, limits::kColorMaxDeltaEPass, limits::kColorMaxDeltaEWarn),
                           worst_name + " is " + Fixed(s.max_delta_e_after, 1) +
                               " CIEDE2000 off after the correction: look for glare, dirt or a shadow on it"));

  const int total = static_cast<int>(s.patches.size());
  std::vector<std::string> fixes;
  for (const ColorPatchResult& patch : s.patches) {
    if (!patch.used) fixes.push_back(PatchFix(patch));
  }
  const Mark used_mark = used == total && total > 0                 ? Mark::kPass
                         : used >= limits::kColorPatchesUsedWarn ? Mark::kWarn
                                                                 : Mark::kFail;
  figures.push_back(Figure("", "patches used", used, std::to_string(used) + " of " + std::to_string(total),
                           "pass: all; fail < " + std::to_string(limits::kColorPatchesUsedWarn), used_mark,
                           fixes.empty() ? std::string("too few patches in the fit") : JoinAnd(fixes)));

  const bool absolute = white_reference == "light_field";
  figures.push_back(Figure("", "white reference", absolute ? 1 : 0,
                           absolute ? "the set's light calibration: absolute reflectance, the solver's albedo space"
                                    : "the chart's gray row per frame: relative (no light calibration when it ran)",
                           "", Mark::kInfo, ""));
  figures.push_back(Figure("", "method", 0, s.method, "", Mark::kInfo, ""));
  return figures;
}

int SwatchGapPx(int swatch_px) { return std::max(2, swatch_px / 8); }

namespace {

uint8_t SrgbByte(double linear) {
  if (!std::isfinite(linear)) return 0;
  return static_cast<uint8_t>(std::lround(255.0 * SrgbEncode(linear)));
}

void FillRect(ImageU8* image, int x0, int y0, int width, int height, const std::array<uint8_t, 3>& rgb) {
  for (int y = std::max(0, y0); y < std::min(image->height(), y0 + height); ++y) {
    for (int x = std::max(0, x0); x < std::min(image->width(), x0 + width); ++x) {
      uint8_t* pixel = image->data() + (static_cast<size_t>(y) * image->width() + x) * 3;
      std::copy(rgb.begin(), rgb.end(), pixel);
    }
  }
}

std::array<uint8_t, 3> SrgbBytes(const Eigen::Vector3d& linear) {
  return {SrgbByte(linear[0]), SrgbByte(linear[1]), SrgbByte(linear[2])};
}

}  // namespace

ImageU8 ColorChartSwatches(const ColorCorrectionSummary& fit, int swatch_px) {
  if (swatch_px < 6) {
    throw std::invalid_argument("ColorChartSwatches: swatch_px = " + std::to_string(swatch_px) + " must be >= 6");
  }
  const int s = swatch_px, g = SwatchGapPx(s);
  const int num = static_cast<int>(fit.patches.size());
  const int columns = kColorCheckerColumns;
  const int rows = std::max(kColorCheckerRows, (num + columns - 1) / columns);
  ImageU8 image(g + columns * (s + g), g + rows * (s + g), 3, uint8_t{0x30});
  for (int i = 0; i < num; ++i) {
    const ColorPatchResult& patch = fit.patches[i];
    const int x0 = g + (i % columns) * (s + g), y0 = g + (i / columns) * (s + g);
    if (!patch.used) {
      const int frame = std::max(1, g / 2);
      FillRect(&image, x0 - frame, y0 - frame, s + 2 * frame, s + 2 * frame, {0xe0, 0x20, 0x20});
    }
    const std::array<Eigen::Vector3d, 3> stripes = {patch.measured_camera, patch.reference_linear_rec709,
                                                    patch.corrected_linear_rec709};
    for (int k = 0; k < 3; ++k) {
      const int begin = k * s / 3, end = (k + 1) * s / 3;
      FillRect(&image, x0 + begin, y0, end - begin, s, SrgbBytes(stripes[k]));
    }
  }
  return image;
}

std::string FixHintForError(CalibrationStep step, const std::string& message) {
  const char* target = step == CalibrationStep::kCamera         ? "checkerboard"
                       : step == CalibrationStep::kWhiteBalance ? "gray chart"
                       : step == CalibrationStep::kLights       ? "white sheet"
                                                                : "colour chart";
  auto has = [&message](const char* text) { return message.find(text) != std::string::npos; };
  if (has("is no calibration target session")) {
    return std::string("That folder is a scan session, not a target capture: choose the ") + target +
           " session(s) (a target session holds a target.json beside its session.json).";
  }
  if (has("but this calibration needs")) {
    return std::string("A session of another target was chosen: this step needs the ") + target + " session(s).";
  }
  if (has("already exists")) {
    return "This folder holds a calibration set already: tick \"Replace an existing set\" to start it again, or "
           "choose a new folder.";
  }
  if (has("camera_calibration: missing") || has("a calibration set?")) {
    return "Run step 1 (camera) into this calibration set first.";
  }
  if (has("differs from")) {
    return "The target sessions were taken with another camera, lens or image size than the calibration set's: "
           "capture them with this camera, or calibrate the camera again.";
  }
  if (has("capture.complete: false")) {
    return "That target capture was interrupted: resume it on the Capture page first.";
  }
  if (has("usable views, min_views")) {
    return "Too few usable views (the reasons are listed): the whole board must be visible, sharp and evenly lit "
           "in each; retake the rejected poses or add more.";
  }
  if (has("no ColorChecker found") || has("in none of its LED frames")) {
    return "The ColorChecker was not found: lay the whole chart flat in view, face up and unobstructed, lit "
           "evenly without glare; or give its corners (scanbench calibrate color --corners).";
  }
  if (has("a colour chart session is calibrated into an existing set")) {
    return "A colour chart session needs the set's camera: run step 1 (camera), ideally step 3 (lights), first; a "
           "RAW photo of the chart may start a set on its own.";
  }
  if (has("cannot be fitted together")) {
    return "Calibrate from chart sessions or from RAW photos, not both: remove one kind from the list.";
  }
  if (has("neutral patches") || has("neutral ones") || has("gray patches are usable")) {
    return "The chart's gray row must be usable: expose so that the white patch does not clip and the black one "
           "is not lost in noise.";
  }
  if (has("lying flat on the table") || has("lying on the table was rejected")) {
    return "One checkerboard session must show the board lying flat on the table (on_table in its target.json), "
           "and that view must be usable: retake it.";
  }
  return "";
}

}  // namespace scanbench
