#include "calibration/light_calibration.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <set>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>
#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>

#include "core/field_error.h"
#include "core/format.h"
#include "calibration/bayer_sampling.h"
#include "calibration/camera_model.h"

namespace scanbench {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// Relative standard errors below this are not believed (weights stay finite).
constexpr double kMinRelativeError = 1e-4;
constexpr int kNumParams = 9;  // position (3), axis (2), mu, log intensity (3)
// Raised-sheet cells whose LED ray meets the table closer than this to the
// edge of the measured cells are left out of the per-pixel position step.
constexpr double kSelectionMarginCells = 4;

// ---------------------------------------------------------------------------
// Cells: raw samples averaged per colour.

struct CellValue {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d standard_error = Eigen::Vector3d::Zero();
  bool valid = false;
};

struct SheetCells {
  std::string name;
  double height_mm = 0;
  double reflectance = 1;
  int nx = 0, ny = 0;
  std::vector<Eigen::Vector3d> points;           // table point of each cell centre on the sheet
  std::vector<std::vector<CellValue>> values;    // [led][cell]
};

// The cell grid: square cells of `cell` pixels from pixel (0, 0); also the
// nodes of the per-pixel field.
struct CellGrid {
  int cell = 2;
  int nx = 0, ny = 0;

  size_t num_cells() const { return static_cast<size_t>(nx) * ny; }
  // Pixel position of cell (0, 0)'s centre.
  double origin() const { return 0.5 * (cell - 1); }
  std::vector<Eigen::Vector2d> CentresInPixels() const {
    std::vector<Eigen::Vector2d> centres;
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) centres.emplace_back(i * cell + origin(), j * cell + origin());
    }
    return centres;
  }
};

CellGrid MakeCellGrid(const LightCalibrationOptions& options, int width, int height) {
  CellGrid grid;
  grid.cell = options.cell_px > 0 ? options.cell_px : std::max(2, 2 * static_cast<int>(std::lround(width / 128.0)));
  grid.nx = width / grid.cell;
  grid.ny = height / grid.cell;
  return grid;
}

// The raw samples of every cell averaged per colour; cells with a clipped,
// too dark or too thin colour are invalid.
std::vector<CellValue> AverageCells(const RawImage& frame, const RawImage& dark, const CellGrid& grid,
                                    const LightCalibrationOptions& options, const std::string& name) {
  const LinearBayerReader reader(frame, dark, options.clip_fraction, name);
  std::vector<RgbStatistics> stats(grid.num_cells());
  for (int y = 0; y < grid.ny * grid.cell; ++y) {
    RgbStatistics* row_cells = &stats[static_cast<size_t>(y / grid.cell) * grid.nx];
    for (int x = 0; x < grid.nx * grid.cell; ++x) reader.Accumulate(x, y, row_cells[x / grid.cell]);
  }
  std::vector<CellValue> cells(stats.size());
  for (size_t i = 0; i < stats.size(); ++i) {
    CellValue& v = cells[i];
    v.valid = true;
    for (int c = 0; c < 3; ++c) {
      const ChannelStatistics& s = stats[i][c];
      v.mean[c] = s.Mean();
      v.standard_error[c] = s.StandardError();
      v.valid &= s.clipped == 0 && s.count >= 2 && v.mean[c] >= options.min_level && v.mean[c] > 0;
    }
  }
  return cells;
}

// Dust and creases: a cell far from the median of its neighbourhood becomes
// invalid. A smooth light gradient leaves the centre at the median.
std::vector<CellValue> DropOutlierCells(const std::vector<CellValue>& cells, const CellGrid& grid,
                                        double outlier_sigma) {
  const int nx = grid.nx, ny = grid.ny;
  std::vector<CellValue> filtered = cells;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      CellValue& v = filtered[static_cast<size_t>(j) * nx + i];
      if (!v.valid) continue;
      for (int c = 0; c < 3 && v.valid; ++c) {
        std::vector<double> neighbours;
        for (int dj = -1; dj <= 1; ++dj) {
          for (int di = -1; di <= 1; ++di) {
            const int ii = i + di, jj = j + dj;
            if (ii < 0 || jj < 0 || ii >= nx || jj >= ny) continue;
            const CellValue& n = cells[static_cast<size_t>(jj) * nx + ii];
            if (n.valid) neighbours.push_back(n.mean[c]);
          }
        }
        if (neighbours.size() < 5) continue;
        std::nth_element(neighbours.begin(), neighbours.begin() + neighbours.size() / 2, neighbours.end());
        const double median = neighbours[neighbours.size() / 2];
        const double sigma = std::max(v.standard_error[c], kMinRelativeError * v.mean[c]);
        if (std::abs(v.mean[c] - median) > outlier_sigma * 1.5 * sigma) v.valid = false;
      }
    }
  }
  return filtered;
}

// log(measured / reflectance) of one colour of a valid cell, and its weight
// 1 / relative standard error.
struct LogCellValue {
  double log_value = 0;
  double weight = 1;
};

LogCellValue LogOfCell(const CellValue& v, int channel, double reflectance) {
  return {std::log(v.mean[channel] / reflectance),
          1.0 / std::max(kMinRelativeError, v.standard_error[channel] / v.mean[channel])};
}

// ---------------------------------------------------------------------------
// The LED model in logs, and its Levenberg-Marquardt fit.

struct FitSample {
  Eigen::Vector3d point;   // table mm, on a horizontal sheet
  int channel = 0;
  double log_value = 0;    // log(measured / reflectance)
  double weight = 1;       // 1 / relative standard error
};

struct LedParameters {
  Eigen::Vector3d axis0;   // axis the two axis parameters tilt
  Eigen::Vector3d e1, e2;  // unit, perpendicular to axis0 and each other

  explicit LedParameters(const Eigen::Vector3d& axis) : axis0(axis.normalized()) {
    const Eigen::Vector3d helper = std::abs(axis0.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    e1 = axis0.cross(helper).normalized();
    e2 = axis0.cross(e1).normalized();
  }
  Eigen::Vector3d Axis(const Eigen::VectorXd& x) const { return (axis0 + x[3] * e1 + x[4] * e2).normalized(); }

  Eigen::VectorXd Pack(const LedDescription& led) const {
    Eigen::VectorXd x(kNumParams);
    x.head<3>() = led.position_in_table_mm;
    x[3] = x[4] = 0;  // axis0 = led's axis
    x[5] = led.mu;
    for (int c = 0; c < 3; ++c) x[6 + c] = std::log(std::max(led.rgb_intensity[c], 1e-12));
    return x;
  }
  LedDescription Unpack(const Eigen::VectorXd& x, int id) const {
    LedDescription led;
    led.id = id;
    led.position_in_table_mm = x.head<3>();
    led.axis_in_table = Axis(x);
    led.mu = x[5];
    for (int c = 0; c < 3; ++c) led.rgb_intensity[c] = std::exp(x[6 + c]);
    return led;
  }
};

// log of rgb_intensity_c cos^mu (1000 / d)^2 n.l at a sample, n = up.
double LogModel(const LedParameters& parameters, const Eigen::VectorXd& x, const FitSample& s) {
  const Eigen::Vector3d to_led = x.head<3>() - s.point;
  const double d2 = to_led.squaredNorm();
  const Eigen::Vector3d l = to_led / std::sqrt(d2);
  const double cos_off_axis = std::max(1e-9, -l.dot(parameters.Axis(x)));
  return x[6 + s.channel] + x[5] * std::log(cos_off_axis) +
         std::log(kLedReferenceDistanceMm * kLedReferenceDistanceMm / d2) + std::log(std::max(1e-9, l.z()));
}

// What Eigen's NumericalDiff and LevenbergMarquardt look up on a functor:
// both fits have a run-time number of parameters and residuals.
struct DynamicSizeFunctor {
  using Scalar = double;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  using InputType = Eigen::VectorXd;
  using ValueType = Eigen::VectorXd;
  using JacobianType = Eigen::MatrixXd;
};

struct LedFunctor : DynamicSizeFunctor {
  const LedParameters* parameters;
  const std::vector<FitSample>* samples;

  int inputs() const { return kNumParams; }
  int values() const { return static_cast<int>(samples->size()); }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& residuals) const {
    for (size_t i = 0; i < samples->size(); ++i) {
      const FitSample& s = (*samples)[i];
      residuals[static_cast<Eigen::Index>(i)] = s.weight * (LogModel(*parameters, x, s) - s.log_value);
    }
    return 0;
  }
};

const char* LmStatusName(int status) {
  switch (status) {
    case Eigen::LevenbergMarquardtSpace::ImproperInputParameters: return "improper input parameters";
    case Eigen::LevenbergMarquardtSpace::RelativeReductionTooSmall: return "converged (relative reduction)";
    case Eigen::LevenbergMarquardtSpace::RelativeErrorTooSmall: return "converged (relative error)";
    case Eigen::LevenbergMarquardtSpace::RelativeErrorAndReductionTooSmall: return "converged";
    case Eigen::LevenbergMarquardtSpace::CosinusTooSmall: return "converged (gradient orthogonal)";
    case Eigen::LevenbergMarquardtSpace::TooManyFunctionEvaluation: return "too many function evaluations";
    case Eigen::LevenbergMarquardtSpace::FtolTooSmall: return "ftol too small";
    case Eigen::LevenbergMarquardtSpace::XtolTooSmall: return "xtol too small";
    case Eigen::LevenbergMarquardtSpace::GtolTooSmall: return "gtol too small";
    default: return "stopped";
  }
}

struct FitResult {
  Eigen::VectorXd x;
  Eigen::MatrixXd covariance;  // scaled by the reduced chi^2
  double chi = 0;              // rms weighted residual
  double residual_rms = 0;     // rms unweighted (relative) residual
  double noise_rms = 0;
  int evaluations = 0;
  std::string termination;
  bool ok = false;
};

FitResult FitLed(const LedParameters& parameters, const std::vector<FitSample>& samples, Eigen::VectorXd x,
                 int max_evaluations) {
  FitResult result;
  LedFunctor functor{{}, &parameters, &samples};
  Eigen::NumericalDiff<LedFunctor> numeric(functor);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<LedFunctor>> lm(numeric);
  lm.parameters.maxfev = max_evaluations;
  lm.parameters.xtol = 1e-12;
  lm.parameters.ftol = 1e-12;
  lm.parameters.factor = 1.0;  // small first steps: the model has kinks far from the start
  const int status = lm.minimize(x);
  result.evaluations = static_cast<int>(lm.nfev);
  result.termination = LmStatusName(status);
  result.ok = status >= 1 && status <= 4 && x.allFinite() && x[5] >= 0;
  result.x = x;
  Eigen::VectorXd residuals(samples.size());
  functor(x, residuals);
  double sum_relative = 0, sum_noise = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double r = residuals[static_cast<Eigen::Index>(i)] / samples[i].weight;
    sum_relative += r * r;
    sum_noise += 1.0 / (samples[i].weight * samples[i].weight);
  }
  const double n = std::max<double>(1, samples.size());
  result.chi = std::sqrt(residuals.squaredNorm() / n);
  result.residual_rms = std::sqrt(sum_relative / n);
  result.noise_rms = std::sqrt(sum_noise / n);
  // Covariance from a central-difference Jacobian at the solution.
  const int num_params = static_cast<int>(x.size());
  Eigen::MatrixXd jacobian(samples.size(), num_params);
  for (int p = 0; p < num_params; ++p) {
    const double h = 1e-6 * std::max(1.0, std::abs(x[p]));
    Eigen::VectorXd plus = x, minus = x, f_plus(samples.size()), f_minus(samples.size());
    plus[p] += h;
    minus[p] -= h;
    functor(plus, f_plus);
    functor(minus, f_minus);
    jacobian.col(p) = (f_plus - f_minus) / (2 * h);
  }
  const double dof = std::max(1.0, n - num_params);
  const double reduced_chi2 = residuals.squaredNorm() / dof;
  result.covariance = (jacobian.transpose() * jacobian).completeOrthogonalDecomposition().pseudoInverse() *
                      std::max(1.0, reduced_chi2);
  return result;
}

// Start values: the measured LED, intensities from the data.
Eigen::VectorXd StartValues(const LedParameters& parameters, const LedDescription& measured,
                            const std::vector<FitSample>& samples) {
  Eigen::VectorXd x = parameters.Pack(measured);
  for (int c = 0; c < 3; ++c) {
    x[6 + c] = 0;
    std::vector<double> offsets;
    for (const FitSample& s : samples) {
      if (s.channel == c) offsets.push_back(s.log_value - LogModel(parameters, x, s));
    }
    if (!offsets.empty()) {
      std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
      x[6 + c] = offsets[offsets.size() / 2];
    }
  }
  return x;
}

double LambertZ(const Eigen::Vector3d& led, const Eigen::Vector3d& point) {
  return std::max(1e-9, (led - point).normalized().z());
}

// What the model LED delivers to a surface facing it at p.
Eigen::Vector3d ModelIntensity(const LedDescription& led, const Eigen::Vector3d& p) {
  const Eigen::Vector3d to_led = led.position_in_table_mm - p;
  const double d2 = to_led.squaredNorm();
  const double cos_off_axis = std::max(0.0, -(to_led / std::sqrt(d2)).dot(led.axis_in_table));
  return led.rgb_intensity * std::pow(cos_off_axis, led.mu) * (kLedReferenceDistanceMm * kLedReferenceDistanceMm / d2);
}

// Log intensity per colour on the table sheet's cell grid, bilinear in pixels.
struct CellMap {
  int nx = 0, ny = 0;
  double origin = 0, step = 1;  // pixel of cell (0, 0)'s centre, cell side
  std::vector<Eigen::Vector3d> log_intensity;

  double At(const Eigen::Vector2d& pixel, int channel) const {
    const double u = std::clamp((pixel.x() - origin) / step, 0.0, nx - 1.0);
    const double v = std::clamp((pixel.y() - origin) / step, 0.0, ny - 1.0);
    const int i = std::min(static_cast<int>(u), nx - 2), j = std::min(static_cast<int>(v), ny - 2);
    const double fu = u - i, fv = v - j;
    auto value = [&](int a, int b) { return log_intensity[static_cast<size_t>(b) * nx + a][channel]; };
    return (1 - fv) * ((1 - fu) * value(i, j) + fu * value(i + 1, j)) +
           fv * ((1 - fu) * value(i, j + 1) + fu * value(i + 1, j + 1));
  }
};

// A raised-sheet cell: it sees the LED along the same ray as the table point
// below it on the line to the LED.
struct RatioSample {
  Eigen::Vector3d point;  // on the raised sheet, table mm
  double height_mm = 0;
  int channel = 0;
  double log_value = 0;   // log(measured / reflectance)
  double weight = 1;
};

// Residual of a raised cell given the LED position x: predicted from the
// table sheet's intensity where the LED's ray through the cell meets the
// table, times the inverse-square gain (d_table / d_raised)^2 and the
// cell's Lambert factor.
struct PositionFunctor : DynamicSizeFunctor {
  const CameraGeometry* camera;
  const CellMap* map;
  const std::vector<RatioSample>* samples;

  int inputs() const { return 3; }
  int values() const { return static_cast<int>(samples->size()); }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& residuals) const {
    const Eigen::Vector3d led = x.head<3>();
    for (size_t i = 0; i < samples->size(); ++i) {
      const RatioSample& s = (*samples)[i];
      const Eigen::Vector3d& point = s.point;
      const double t = led.z() / std::max(1e-6, led.z() - s.height_mm);
      const Eigen::Vector3d below = led + t * (point - led);
      const Eigen::Vector3d in_cam = camera->cam_from_table * below;
      const Eigen::Vector2d pixel = ProjectToPixel(camera->intrinsics, in_cam);
      const double predicted = std::log(LambertZ(led, point)) + map->At(pixel, s.channel) + 2.0 * std::log(t);
      residuals[static_cast<Eigen::Index>(i)] = s.weight * (predicted - s.log_value);
    }
    return 0;
  }
};

struct PositionFit {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double residual_rms = 0;
  std::string termination;
  bool ok = false;
};

PositionFit FitPosition(const CameraGeometry& camera, const CellMap& map, const std::vector<RatioSample>& samples,
                        const Eigen::Vector3d& start, int max_evaluations) {
  PositionFit result;
  if (samples.size() < 10) {
    result.termination = "fewer than 10 usable raised-sheet cells";
    return result;
  }
  PositionFunctor functor{{}, &camera, &map, &samples};
  Eigen::NumericalDiff<PositionFunctor> numeric(functor);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<PositionFunctor>> lm(numeric);
  lm.parameters.maxfev = max_evaluations;
  // The table map is bilinear (kinks at the cells): stop at a micrometre.
  lm.parameters.xtol = 1e-9;
  lm.parameters.ftol = 1e-10;
  lm.parameters.factor = 1.0;
  Eigen::VectorXd x = start;
  const int status = lm.minimize(x);
  result.termination = LmStatusName(status);
  result.ok = status >= 1 && status <= 4 && x.allFinite() && x.z() > 0;
  result.position = x.head<3>();
  Eigen::VectorXd residuals(samples.size());
  functor(x, residuals);
  double sum = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double r = residuals[static_cast<Eigen::Index>(i)] / samples[i].weight;
    sum += r * r;
  }
  result.residual_rms = std::sqrt(sum / samples.size());
  return result;
}

// ---------------------------------------------------------------------------
// The steps of CalibrateLights.

// Progress over the calibration's steps: one per sheet and LED measured, two
// per LED calibrated. Next() is false once the callback asks to stop.
class StepProgress {
 public:
  StepProgress(const ProgressCallback& progress, double total_steps) : progress_(progress), total_(total_steps) {}
  bool Next() {
    steps_ += 1;
    return !progress_ || progress_(steps_ / total_);
  }

 private:
  const ProgressCallback& progress_;
  double total_;
  double steps_ = 0;
};

// The captures against the camera and the LEDs (throws std::invalid_argument
// naming the sheet or LED); the first sheet on the table (-1 if none) and the
// heights the sheets lie at.
struct SheetLayout {
  int table_sheet = -1;
  std::set<double> heights_mm;
};

SheetLayout CheckInputs(const CameraGeometry& camera, const std::vector<LedDescription>& measured_leds,
                        const std::vector<WhiteSheetCapture>& sheets) {
  const int width = camera.intrinsics.width, height = camera.intrinsics.height;
  const size_t num_leds = measured_leds.size();
  if (num_leds == 0) throw std::invalid_argument("CalibrateLights: no LEDs given");
  if (sheets.empty()) throw std::invalid_argument("CalibrateLights: no white sheet captures given");
  SheetLayout layout;
  for (size_t s = 0; s < sheets.size(); ++s) {
    const WhiteSheetCapture& capture = sheets[s];
    capture.sheet.Check();
    if (capture.dark == nullptr) throw std::invalid_argument("white sheet " + capture.name + ": no dark frame");
    if (capture.led_frames.size() != num_leds) {
      throw std::invalid_argument("white sheet " + capture.name + ": " + std::to_string(capture.led_frames.size()) +
                                  " LED frames for " + std::to_string(num_leds) + " LEDs");
    }
    for (const RawImage* frame : capture.led_frames) {
      if (frame == nullptr || !frame->mosaic.SameSize(width, height)) {
        throw std::invalid_argument("white sheet " + capture.name + ": a frame is missing or not " +
                                    std::to_string(width) + "x" + std::to_string(height) + " like the camera");
      }
    }
    if (capture.sheet.height_mm == 0 && layout.table_sheet < 0) layout.table_sheet = static_cast<int>(s);
    layout.heights_mm.insert(capture.sheet.height_mm);
  }
  for (size_t k = 0; k < num_leds; ++k) {
    const Eigen::Vector3d& position = measured_leds[k].position_in_table_mm;
    if (!(position.z() > 0) || !position.allFinite()) {
      throw std::invalid_argument("CalibrateLights: LED " + std::to_string(k) +
                                  " measured position must be finite and above the table");
    }
  }
  return layout;
}

// Every sheet's cells under every LED. False when the progress callback
// asked to stop.
bool MeasureSheets(const CameraGeometry& camera, const CellGrid& grid, const std::vector<WhiteSheetCapture>& sheets,
                   size_t num_leds, const LightCalibrationOptions& options, StepProgress& steps,
                   std::vector<SheetCells>* cells) {
  const std::vector<Eigen::Vector2d> centres = grid.CentresInPixels();
  cells->assign(sheets.size(), SheetCells());
  for (size_t s = 0; s < sheets.size(); ++s) {
    SheetCells& sc = (*cells)[s];
    sc.name = sheets[s].name;
    sc.height_mm = sheets[s].sheet.height_mm;
    sc.reflectance = sheets[s].sheet.reflectance;
    sc.nx = grid.nx;
    sc.ny = grid.ny;
    sc.points = ComputePlanePointsInTable(camera, centres, sc.height_mm);
    for (size_t k = 0; k < num_leds; ++k) {
      const std::string name = "white sheet " + sc.name + ", LED " + std::to_string(k);
      sc.values.push_back(DropOutlierCells(
          AverageCells(*sheets[s].led_frames[k], *sheets[s].dark, grid, options, name), grid, options.outlier_sigma));
      if (!steps.Next()) return false;
    }
  }
  return true;
}

// The model's samples of LED k: every valid cell of every sheet, per colour.
std::vector<FitSample> ModelSamples(const std::vector<SheetCells>& cells, size_t k) {
  std::vector<FitSample> samples;
  for (const SheetCells& sc : cells) {
    for (size_t i = 0; i < sc.points.size(); ++i) {
      const CellValue& v = sc.values[k][i];
      if (!v.valid) continue;
      for (int c = 0; c < 3; ++c) {
        const LogCellValue value = LogOfCell(v, c, sc.reflectance);
        FitSample s;
        s.point = sc.points[i];
        s.channel = c;
        s.log_value = value.log_value;
        s.weight = value.weight;
        samples.push_back(s);
      }
    }
  }
  return samples;
}

// The axis the fit tilts: the measured one, or towards the table origin when
// none was measured.
LedParameters ParametersFor(const LedDescription& measured) {
  return LedParameters(measured.axis_in_table.norm() > 1e-12 ? measured.axis_in_table
                                                              : Eigen::Vector3d(-measured.position_in_table_mm));
}

// Fit the LED model: Levenberg-Marquardt from the measured LED with
// brightness from the data. A failed fit keeps the start (the measured LED
// with fitted brightness), flagged unusable: the per-pixel field is then the
// only result.
LedModelFit FitLedModel(const LedParameters& parameters, const LedDescription& measured,
                        const std::vector<FitSample>& samples, int max_evaluations) {
  const Eigen::VectorXd start = StartValues(parameters, measured, samples);
  const FitResult model = FitLed(parameters, samples, start, max_evaluations);
  LedModelFit fit;
  fit.usable = model.ok;
  fit.led = parameters.Unpack(model.ok ? model.x : start, measured.id);
  auto standard_deviation = [&](int p) { return std::sqrt(std::max(0.0, model.covariance(p, p))); };
  for (int a = 0; a < 3; ++a) fit.position_std_mm[a] = standard_deviation(a);
  fit.axis_std_deg = std::sqrt(std::max(0.0, model.covariance(3, 3) + model.covariance(4, 4))) * kRadToDeg;
  fit.mu_std = standard_deviation(5);
  for (int c = 0; c < 3; ++c) fit.intensity_std[c] = standard_deviation(6 + c);
  fit.residual_rms = model.residual_rms;
  fit.noise_rms = model.noise_rms;
  fit.chi = model.chi;
  fit.evaluations = model.evaluations;
  fit.termination = model.ok ? model.termination
                             : model.termination + ", but the result is unusable (mu < 0 or not finite)";
  return fit;
}

// The raised sheets' cells of LED k for the position step: only cells whose
// ray from `position` meets the table well inside the measured cells (a low
// LED shifts the ray's foot far outwards); chosen once, with room for the
// position to move, so that the iteration does not chase a changing set.
std::vector<RatioSample> RaisedSheetSamples(const CameraGeometry& camera, const CellGrid& grid,
                                            const std::vector<SheetCells>& cells, size_t k,
                                            const Eigen::Vector3d& position) {
  std::vector<RatioSample> samples;
  for (const SheetCells& sc : cells) {
    if (sc.height_mm == 0) continue;
    for (size_t i = 0; i < sc.points.size(); ++i) {
      const CellValue& v = sc.values[k][i];
      if (!v.valid) continue;
      const double t = position.z() / std::max(1e-6, position.z() - sc.height_mm);
      const Eigen::Vector3d below = position + t * (sc.points[i] - position);
      const Eigen::Vector2d pixel = ProjectToPixel(camera.intrinsics, camera.cam_from_table * below);
      const double u = (pixel.x() - grid.origin()) / grid.cell, w = (pixel.y() - grid.origin()) / grid.cell;
      if (!(u >= kSelectionMarginCells && w >= kSelectionMarginCells && u <= grid.nx - 1 - kSelectionMarginCells &&
            w <= grid.ny - 1 - kSelectionMarginCells)) {
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const LogCellValue value = LogOfCell(v, c, sc.reflectance);
        RatioSample rs;
        rs.point = sc.points[i];
        rs.height_mm = sc.height_mm;
        rs.channel = c;
        rs.log_value = value.log_value;
        rs.weight = value.weight;
        samples.push_back(rs);
      }
    }
  }
  return samples;
}

// The table sheet's log intensity of LED k at `position`: measured cells
// divided by their Lambert factor, invalid ones from the model LED.
CellMap TableIntensityMap(const CellGrid& grid, const SheetCells& table, size_t k, const Eigen::Vector3d& position,
                          const LedDescription& model_led) {
  CellMap map{grid.nx, grid.ny, grid.origin(), static_cast<double>(grid.cell), {}};
  map.log_intensity.resize(grid.num_cells());
  for (size_t i = 0; i < grid.num_cells(); ++i) {
    const CellValue& v = table.values[k][i];
    const Eigen::Vector3d& p = table.points[i];
    const Eigen::Vector3d value = v.valid ? Eigen::Vector3d(v.mean / (table.reflectance * LambertZ(position, p)))
                                          : ModelIntensity(model_led, p);
    map.log_intensity[i] = value.array().max(1e-12).log();
  }
  return map;
}

// The per-pixel procedure for LED k: intensities on the table sheet under the
// current directions; a new position from them and the raised sheet (along a
// ray from the LED the intensity falls as 1 / d^2 whatever the LED's emission
// pattern); repeat until directions and intensities stop changing. Without a
// raised sheet the directions come from the model's position. Sets *failure
// when a position step fails.
LedPerPixelFit RunPerPixelProcedure(const CameraGeometry& camera, const CellGrid& grid,
                                    const std::vector<SheetCells>& cells, const SheetCells& table, size_t k,
                                    const LedDescription& measured, const LedDescription& model_led,
                                    bool has_raised_sheet, const LightCalibrationOptions& options,
                                    std::string* failure) {
  LedPerPixelFit per_pixel;
  Eigen::Vector3d position = has_raised_sheet ? measured.position_in_table_mm : model_led.position_in_table_mm;
  const std::vector<RatioSample> ratio_samples = RaisedSheetSamples(camera, grid, cells, k, position);
  for (int iteration = 1; has_raised_sheet && iteration <= options.max_iterations; ++iteration) {
    const CellMap map = TableIntensityMap(grid, table, k, position, model_led);
    const PositionFit position_step = FitPosition(camera, map, ratio_samples, position, options.max_fit_evaluations);
    if (!position_step.ok) {
      *failure = "LED " + std::to_string(k) + ": the per-pixel procedure's position step failed in iteration " +
                 std::to_string(iteration) + ": " + position_step.termination;
      return per_pixel;
    }
    const Eigen::Vector3d next = position_step.position;
    double direction_change = 0, intensity_change = 0;
    for (const Eigen::Vector3d& p : table.points) {
      const Eigen::Vector3d before = (position - p).normalized(), after = (next - p).normalized();
      direction_change = std::max(direction_change, std::atan2(before.cross(after).norm(), before.dot(after)));
      intensity_change = std::max(intensity_change, std::abs(LambertZ(position, p) / LambertZ(next, p) - 1.0));
    }
    per_pixel.direction_change_deg.push_back(direction_change * kRadToDeg);
    per_pixel.intensity_change.push_back(intensity_change);
    per_pixel.iterations = iteration;
    per_pixel.residual_rms = position_step.residual_rms;
    position = next;
    if (direction_change * kRadToDeg <= options.direction_tolerance_deg &&
        intensity_change <= options.intensity_tolerance) {
      per_pixel.converged = true;
      break;
    }
  }
  if (!has_raised_sheet) per_pixel.converged = true;  // directions from the model: nothing to iterate
  per_pixel.position_in_table_mm = position;
  return per_pixel;
}

// The field's intensities of LED k at the table sheet's cells: measured
// under the converged position, gaps filled from the model; counts the cells
// used and dropped into *per_pixel.
std::vector<Eigen::Vector3d> FieldIntensities(const SheetCells& table, size_t k, const LedDescription& model_led,
                                              LedPerPixelFit* per_pixel) {
  std::vector<Eigen::Vector3d> intensity(table.points.size());
  for (size_t i = 0; i < table.points.size(); ++i) {
    const CellValue& v = table.values[k][i];
    const Eigen::Vector3d& p = table.points[i];
    if (v.valid) {
      intensity[i] = v.mean / (table.reflectance * LambertZ(per_pixel->position_in_table_mm, p));
      ++per_pixel->cells_used;
    } else {
      intensity[i] = ModelIntensity(model_led, p);
      ++per_pixel->cells_dropped;
    }
  }
  return intensity;
}

// Smooth the cells with a 3x3 binomial filter (filters what the cell averages
// leave of the paper's texture). At the border a one-sided average would pull
// a sloped field inwards: the border cells stay as measured.
std::vector<Eigen::Vector3d> SmoothCells(const std::vector<Eigen::Vector3d>& intensity, const CellGrid& grid) {
  const int nx = grid.nx, ny = grid.ny;
  std::vector<Eigen::Vector3d> smoothed(intensity.size());
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const size_t centre = static_cast<size_t>(j) * nx + i;
      const bool inside = i > 0 && j > 0 && i < nx - 1 && j < ny - 1;
      if (!inside) {
        smoothed[centre] = intensity[centre];
        continue;
      }
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double weights = 0;
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const double w = (di == 0 ? 2.0 : 1.0) * (dj == 0 ? 2.0 : 1.0);
          sum += w * intensity[static_cast<size_t>(j + dj) * nx + i + di];
          weights += w;
        }
      }
      smoothed[centre] = sum / weights;
    }
  }
  return smoothed;
}

// The per-pixel field's node values, node-major (SampledLightField's layout).
struct FieldNodes {
  size_t num_leds = 0;
  std::vector<float> dirs_in_table, rgb_intensities;

  FieldNodes(size_t num_nodes, size_t leds)
      : num_leds(leds), dirs_in_table(num_nodes * leds * 3), rgb_intensities(num_nodes * leds * 3) {}
  // LED k's directions from `position` to every table cell and its intensities.
  void Store(size_t k, const std::vector<Eigen::Vector3d>& table_points, const Eigen::Vector3d& position,
             const std::vector<Eigen::Vector3d>& intensity) {
    for (size_t i = 0; i < table_points.size(); ++i) {
      const Eigen::Vector3d direction = (position - table_points[i]).normalized();
      for (int c = 0; c < 3; ++c) {
        dirs_in_table[(i * num_leds + k) * 3 + c] = static_cast<float>(direction[c]);
        rgb_intensities[(i * num_leds + k) * 3 + c] = static_cast<float>(std::max(0.0, intensity[i][c]));
      }
    }
  }
};

// Select the model or the per-pixel field: the model when every LED's fit
// converged and the worst residual is within model_noise_factor of the
// noise. The worst LED is the last failed fit, else the largest chi.
void SelectModel(double model_noise_factor, LightCalibrationSummary* summary) {
  double worst_chi = 0;
  size_t worst_led = 0;
  bool model_failed = false;
  for (size_t k = 0; k < summary->model.size(); ++k) {
    const LedModelFit& fit = summary->model[k];
    if (!fit.usable) {
      model_failed = true;
      worst_led = k;
    } else if (!model_failed && fit.chi > worst_chi) {
      worst_chi = fit.chi;
      worst_led = k;
    }
  }
  const LedModelFit& worst = summary->model[worst_led];
  const std::string figures = "largest model residual " + Fixed(100 * worst.residual_rms, 3) + " % rms (LED " +
                              std::to_string(worst_led) + ") is " + Fixed(worst.chi, 2) + "x the cells' noise " +
                              Fixed(100 * worst.noise_rms, 3) + " %";
  const std::string per_pixel_used =
      ": the LEDs do not follow the point-source model; the measured per-pixel field is used";
  if (model_failed) {
    summary->selected = LightCalibrationSummary::Choice::kPerPixel;
    summary->selection_reason = "the model fit failed for LED " + std::to_string(worst_led) + per_pixel_used;
  } else if (worst_chi <= model_noise_factor) {
    summary->selected = LightCalibrationSummary::Choice::kModel;
    summary->selection_reason =
        figures + ", within model_noise_factor " + Fixed(model_noise_factor, 2) +
        ": the LEDs follow the point-source model, which is compact and holds off the table plane";
  } else {
    summary->selected = LightCalibrationSummary::Choice::kPerPixel;
    summary->selection_reason = figures + ", above model_noise_factor " + Fixed(model_noise_factor, 2) + per_pixel_used;
  }
}

}  // namespace

void LightCalibrationOptions::Check() const {
  const std::string where = "LightCalibrationOptions";
  if (cell_px != 0 && (cell_px < 2 || cell_px > 512 || cell_px % 2 != 0)) {
    throw FieldError(where, "cell_px", cell_px, "must be 0 (automatic) or an even number in [2, 512]");
  }
  SCANBENCH_REQUIRE_GT_LE(where, "clip_fraction", clip_fraction, 0, 1);
  SCANBENCH_REQUIRE_GE_LT(where, "min_level", min_level, 0, 1);
  SCANBENCH_REQUIRE_GT(where, "outlier_sigma", outlier_sigma, 0);
  SCANBENCH_REQUIRE_GE_LE(where, "max_iterations", max_iterations, 1, 1000);
  SCANBENCH_REQUIRE_GT(where, "direction_tolerance_deg", direction_tolerance_deg, 0);
  SCANBENCH_REQUIRE_GT(where, "intensity_tolerance", intensity_tolerance, 0);
  SCANBENCH_REQUIRE_GE_LE(where, "max_fit_evaluations", max_fit_evaluations, 10, 1000000);
  SCANBENCH_REQUIRE_FINITE_GE(where, "model_noise_factor", model_noise_factor, 1);
}

std::vector<LedDescription> LightCalibrationSummary::ModelLeds() const {
  std::vector<LedDescription> leds;
  for (const LedModelFit& fit : model) leds.push_back(fit.led);
  return leds;
}

std::string LightCalibrationSummary::BriefReport() const {
  std::ostringstream out;
  out << "Light calibration: " << (IsUsable() ? "success" : "failure");
  if (!message.empty()) out << " (" << message << ")";
  if (!IsUsable()) return out.str();
  out << ", cells of " << cell_px << " px; selected: " << (selected == Choice::kModel ? "model" : "per-pixel field")
      << " (" << selection_reason << ")";
  for (size_t k = 0; k < model.size(); ++k) {
    const LedModelFit& m = model[k];
    const Eigen::Vector3d& p = m.led.position_in_table_mm;
    out << "\n  LED " << k << ": model at (" << Fixed(p.x(), 2) << ", " << Fixed(p.y(), 2) << ", " << Fixed(p.z(), 2)
        << ") mm +- " << Fixed(m.position_std_mm.maxCoeff(), 2) << ", mu " << Fixed(m.led.mu, 3) << " +- "
        << Fixed(m.mu_std, 3) << ", residual " << Fixed(100 * m.residual_rms, 3) << " % (noise "
        << Fixed(100 * m.noise_rms, 3) << " %, chi " << Fixed(m.chi, 2) << ")";
    if (k < per_pixel.size()) {
      const LedPerPixelFit& f = per_pixel[k];
      out << "; per-pixel: " << f.iterations << " iterations, " << (f.converged ? "converged" : "NOT converged")
          << ", last change " << Fixed(f.direction_change_deg.empty() ? 0 : f.direction_change_deg.back(), 5)
          << " deg / " << Fixed(f.intensity_change.empty() ? 0 : f.intensity_change.back(), 6);
    }
  }
  for (const std::string& warning : warnings) out << "\n  warning: " << warning;
  return out.str();
}

LightCalibrationSummary CalibrateLights(const LightCalibrationOptions& options, const CameraGeometry& camera,
                                        const std::vector<LedDescription>& measured_leds,
                                        const std::vector<WhiteSheetCapture>& sheets,
                                        const ProgressCallback& progress) {
  options.Check();
  CheckCameraIntrinsics(camera.intrinsics);
  LightCalibrationSummary summary;
  const int width = camera.intrinsics.width, height = camera.intrinsics.height;
  const size_t num_leds = measured_leds.size();
  const SheetLayout layout = CheckInputs(camera, measured_leds, sheets);
  if (layout.table_sheet < 0) {
    summary.SetFailure("no white sheet lies on the table (height_mm = 0): the per-pixel field is measured there");
    return summary;
  }
  const bool has_raised_sheet = layout.heights_mm.size() >= 2;
  if (!has_raised_sheet) {
    summary.warnings.push_back("the white sheet was captured at one height only: LED distance, aim and falloff "
                               "trade off on one plane (add a capture on a spacer of known height)");
  }
  const CellGrid grid = MakeCellGrid(options, width, height);
  summary.cell_px = grid.cell;
  if (grid.nx < 3 || grid.ny < 3) {
    summary.SetFailure("cells of " + std::to_string(grid.cell) + " px leave fewer than 3x3 cells in the image");
    return summary;
  }

  StepProgress steps(progress, sheets.size() * num_leds + 2.0 * num_leds);
  std::vector<SheetCells> cells;
  if (!MeasureSheets(camera, grid, sheets, num_leds, options, steps, &cells)) {
    summary.SetCancelled();
    return summary;
  }
  const SheetCells& table = cells[layout.table_sheet];
  FieldNodes nodes(grid.num_cells(), num_leds);
  for (size_t k = 0; k < num_leds; ++k) {
    const std::vector<FitSample> samples = ModelSamples(cells, k);
    if (samples.size() < 3 * kNumParams) {
      summary.SetFailure("LED " + std::to_string(k) + ": only " + std::to_string(samples.size() / 3) +
                         " usable cells (clipped or too dark?)");
      return summary;
    }
    summary.model.push_back(
        FitLedModel(ParametersFor(measured_leds[k]), measured_leds[k], samples, options.max_fit_evaluations));
    const LedModelFit& model = summary.model.back();
    if (!model.usable) {
      summary.warnings.push_back("LED " + std::to_string(k) + ": the model fit failed: " + model.termination);
    }
    if (!steps.Next()) {
      summary.SetCancelled();
      return summary;
    }

    std::string failure;
    LedPerPixelFit per_pixel = RunPerPixelProcedure(camera, grid, cells, table, k, measured_leds[k], model.led,
                                                    has_raised_sheet, options, &failure);
    if (!failure.empty()) {
      summary.SetFailure(failure);
      return summary;
    }
    std::vector<Eigen::Vector3d> intensity = FieldIntensities(table, k, model.led, &per_pixel);
    if (options.smooth_intensity) intensity = SmoothCells(intensity, grid);
    nodes.Store(k, table.points, per_pixel.position_in_table_mm, intensity);
    summary.per_pixel.push_back(per_pixel);
    if (!per_pixel.converged) {
      summary.warnings.push_back("LED " + std::to_string(k) + ": the per-pixel procedure did not converge in " +
                                 std::to_string(options.max_iterations) + " iterations");
    }
    if (!steps.Next()) {
      summary.SetCancelled();
      return summary;
    }
  }

  LightFieldGrid field_grid;
  field_grid.width = width;
  field_grid.height = height;
  field_grid.origin_x = grid.origin();
  field_grid.origin_y = grid.origin();
  field_grid.step = grid.cell;
  field_grid.nodes_x = grid.nx;
  field_grid.nodes_y = grid.ny;
  summary.per_pixel_field.emplace(field_grid, static_cast<int>(num_leds), std::move(nodes.dirs_in_table),
                                  std::move(nodes.rgb_intensities));
  SelectModel(options.model_noise_factor, &summary);
  summary.termination = Termination::kSuccess;
  return summary;
}

}  // namespace scanbench
