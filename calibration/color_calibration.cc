#include "calibration/color_calibration.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/mcc.hpp>

#include "calibration/color_science.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace {

// OpenCV mcc's chart model (units of its CChartModel): patches of 2.5 at a
// pitch of 2.75, the patch grid 16.25 x 10.75, the detector's box 0.25 wider
// on every side.
constexpr double kPatchSide = 2.5;
constexpr double kPatchPitch = 2.75;
constexpr double kGridWidth = kColorCheckerColumns * kPatchPitch - (kPatchPitch - kPatchSide);
constexpr double kGridHeight = kColorCheckerRows * kPatchPitch - (kPatchPitch - kPatchSide);
constexpr double kMccBoxMargin = 0.25;
constexpr int kNumPatches = kColorCheckerRows * kColorCheckerColumns;

// ---------------------------------------------------------------------------
// Chart geometry.

// Homography taking (u, v) in [0, 1]^2 to the quad's corners (0,0) (1,0) (1,1) (0,1).
Eigen::Matrix3d QuadFromUnitSquare(const std::array<Eigen::Vector2d, 4>& corners) {
  static const double kUnit[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  Eigen::Matrix<double, 8, 8> a = Eigen::Matrix<double, 8, 8>::Zero();
  Eigen::Matrix<double, 8, 1> b;
  for (int i = 0; i < 4; ++i) {
    const double u = kUnit[i][0], v = kUnit[i][1];
    const double x = corners[i].x(), y = corners[i].y();
    a.row(2 * i) << u, v, 1, 0, 0, 0, -u * x, -v * x;
    a.row(2 * i + 1) << 0, 0, 0, u, v, 1, -u * y, -v * y;
    b(2 * i) = x;
    b(2 * i + 1) = y;
  }
  const Eigen::Matrix<double, 8, 1> h = a.fullPivLu().solve(b);
  Eigen::Matrix3d homography;
  homography << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  return homography;
}

Eigen::Vector2d Apply(const Eigen::Matrix3d& homography, double u, double v) {
  const Eigen::Vector3d p = homography * Eigen::Vector3d(u, v, 1.0);
  return p.head<2>() / p.z();
}

// The patch's inset rectangle in (u, v).
struct UvRect {
  double u0, u1, v0, v1;
};

UvRect PatchRect(int index, double inset) {
  const int row = index / kColorCheckerColumns;
  const int column = index % kColorCheckerColumns;
  const double margin = inset * kPatchSide;
  const double x0 = column * kPatchPitch + margin, x1 = column * kPatchPitch + kPatchSide - margin;
  const double y0 = row * kPatchPitch + margin, y1 = row * kPatchPitch + kPatchSide - margin;
  return {x0 / kGridWidth, x1 / kGridWidth, y0 / kGridHeight, y1 / kGridHeight};
}

bool Finite(const Eigen::Vector2d& p) { return std::isfinite(p.x()) && std::isfinite(p.y()); }

// The 8 corner orders of a quad: 4 cyclic shifts, each as given and mirrored.
// Order 0 is the quad as given.
std::array<std::array<Eigen::Vector2d, 4>, 8> CornerOrders(const std::array<Eigen::Vector2d, 4>& corners) {
  std::array<std::array<Eigen::Vector2d, 4>, 8> orders;
  for (int shift = 0; shift < 4; ++shift) {
    for (int mirror = 0; mirror < 2; ++mirror) {
      for (int i = 0; i < 4; ++i) {
        const int source = mirror ? (shift - i + 4) % 4 : (shift + i) % 4;
        orders[2 * shift + mirror][i] = corners[source];
      }
    }
  }
  return orders;
}

// mcc's box (its model corners (0,0) (W,0) (W,H) (0,H) in the order given)
// to the quad of the patch grid inside it.
ColorChartQuad GridQuadFromMccBox(const std::array<Eigen::Vector2d, 4>& box) {
  const double box_width = kGridWidth + 2 * kMccBoxMargin, box_height = kGridHeight + 2 * kMccBoxMargin;
  const Eigen::Matrix3d homography = QuadFromUnitSquare(box);
  const double u0 = kMccBoxMargin / box_width, u1 = 1.0 - u0;
  const double v0 = kMccBoxMargin / box_height, v1 = 1.0 - v0;
  return ColorChartQuad{{Apply(homography, u0, v0), Apply(homography, u1, v0), Apply(homography, u1, v1),
                         Apply(homography, u0, v1)}};
}

// ---------------------------------------------------------------------------
// Frames.

void CheckFrames(const RawImage& frame, const RawImage* dark, const std::string& where) {
  if (frame.mosaic.empty() || frame.mosaic.channels() != 1 || frame.width() < 2 || frame.height() < 2) {
    throw std::invalid_argument(where + ": the frame " + ShapeText(frame.mosaic) +
                                " must be a 1-channel mosaic of at least 2x2");
  }
  for (int i = 0; i < 4; ++i) {
    if (frame.white_level <= frame.black_level[i]) {
      throw std::invalid_argument(where + ": white level " + std::to_string(frame.white_level) +
                                  " must exceed black level " + std::to_string(frame.black_level[i]));
    }
  }
  if (dark != nullptr && (!dark->mosaic.SameSize(frame.mosaic) || dark->cfa != frame.cfa ||
                          dark->mosaic.channels() != 1)) {
    throw std::invalid_argument(where + ": dark frame " + ShapeText(dark->mosaic) + " " +
                                CfaPatternName(dark->cfa) + " does not match the frame " +
                                ShapeText(frame.mosaic) + " " + CfaPatternName(frame.cfa));
  }
}

// (raw - dark) / (white - black) at one raw pixel.
class LinearReader {
 public:
  LinearReader(const RawImage& frame, const RawImage* dark) : frame_(frame), dark_(dark) {
    for (int i = 0; i < 4; ++i) inverse_range_[i] = 1.0 / (double(frame.white_level) - frame.black_level[i]);
  }
  double operator()(int x, int y) const {
    const int reference = dark_ != nullptr ? dark_->mosaic(x, y) : frame_.BlackAt(x, y);
    return (int(frame_.mosaic(x, y)) - reference) * inverse_range_[(y & 1) * 2 + (x & 1)];
  }

 private:
  const RawImage& frame_;
  const RawImage* dark_;
  std::array<double, 4> inverse_range_{};
};

double Median(std::vector<double>& values) {
  if (values.empty()) return 0.0;
  const size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + middle, values.end());
  const double upper = values[middle];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + middle);
  return 0.5 * (lower + upper);
}

// ---------------------------------------------------------------------------
// The orientation check: which corner order makes the patches fit the
// reference through one linear map.

struct OrientationFit {
  double residual = std::numeric_limits<double>::infinity();
  int used = 0;
};

// Relative rms residual of reference ~ M * measured (M free 3x3, least
// squares) over the used patches: sqrt(SSE / spread of the reference). The
// gray row and the chromatic patches make every wrong order fit badly.
OrientationFit FitOrientation(const std::vector<PatchSample>& samples, const std::vector<ColorCheckerPatch>& reference) {
  OrientationFit fit;
  std::vector<int> used;
  for (int i = 0; i < kNumPatches; ++i) {
    if (samples[i].used) used.push_back(i);
  }
  fit.used = static_cast<int>(used.size());
  if (used.size() < 8) return fit;
  Eigen::MatrixXd a(used.size(), 3), b(used.size(), 3);
  for (size_t k = 0; k < used.size(); ++k) {
    a.row(k) = samples[used[k]].value.transpose();
    b.row(k) = reference[used[k]].linear_rec709.transpose();
  }
  const Eigen::MatrixXd m = a.colPivHouseholderQr().solve(b);
  const double sse = (a * m - b).squaredNorm();
  const double spread = (b.rowwise() - b.colwise().mean()).squaredNorm();
  if (!(spread > 0) || !std::isfinite(sse)) return fit;
  fit.residual = std::sqrt(sse / spread);
  return fit;
}

struct OrientationChoice {
  ColorChartQuad quad;
  int order = 0;
  OrientationFit best, next;
};

// Tries every candidate quad (in order) and keeps the best fit; `next` is the
// best of the other candidates from the same corner set.
OrientationChoice ChooseOrientation(const std::array<ColorChartQuad, 8>& candidates, const RawImage& frame,
                                    const RawImage* dark, const ColorChartDetectionOptions& options) {
  ColorPatchSamplingOptions sampling;
  sampling.patch_inset = options.patch_inset;
  sampling.clip_fraction = options.clip_fraction;
  sampling.min_level = 1e-4;
  sampling.min_samples = 4;
  const std::vector<ColorCheckerPatch>& reference = ColorCheckerClassic();
  OrientationChoice choice;
  for (int order = 0; order < 8; ++order) {
    bool inside = true;
    for (const Eigen::Vector2d& corner : candidates[order].corners_px) inside = inside && Finite(corner);
    if (!inside) continue;
    const OrientationFit fit =
        FitOrientation(SampleColorChartPatches(sampling, frame, dark, candidates[order], nullptr), reference);
    if (fit.residual < choice.best.residual) {
      choice.next = choice.best;
      choice.best = fit;
      choice.quad = candidates[order];
      choice.order = order;
    } else if (fit.residual < choice.next.residual) {
      choice.next = fit;
    }
  }
  return choice;
}

// "0.034", or why there is no figure.
std::string ResidualText(const OrientationFit& fit) {
  return std::isfinite(fit.residual) ? Fixed(fit.residual, 3)
                                     : "none (" + std::to_string(fit.used) + " usable patches, 8 needed)";
}

void Record(const OrientationChoice& choice, ColorChartDetectionSummary* summary) {
  summary->quad = choice.quad;
  summary->fit_residual = std::isfinite(choice.best.residual) ? choice.best.residual : 0.0;
  summary->next_fit_residual = std::isfinite(choice.next.residual) ? choice.next.residual : 0.0;
  summary->confidence = std::isfinite(choice.next.residual) && choice.next.residual > 0
                            ? std::clamp(1.0 - choice.best.residual / choice.next.residual, 0.0, 1.0)
                            : 0.0;
  summary->patches_used_for_check = choice.best.used;
}

// ---------------------------------------------------------------------------
// The preview mcc searches: binned per colour, gray-world balanced, exposed
// so that the bright end sits near white, sRGB-encoded, 8-bit BGR.

int PreviewBinning(const RawImage& frame, int max_side) {
  const int longer = std::max(frame.width(), frame.height());
  const int half_steps = (longer + 2 * max_side - 1) / (2 * max_side);
  return 2 * std::max(1, half_steps);
}

cv::Mat DevelopPreview(const RawImage& frame, const RawImage* dark, int binning) {
  const int width = frame.width() / binning, height = frame.height() / binning;
  const LinearReader read(frame, dark);
  std::vector<Eigen::Vector3d> linear(static_cast<size_t>(width) * height, Eigen::Vector3d::Zero());
  Eigen::Vector3d channel_sum = Eigen::Vector3d::Zero();
  for (int py = 0; py < height; ++py) {
    for (int px = 0; px < width; ++px) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero(), count = Eigen::Vector3d::Zero();
      for (int y = py * binning; y < (py + 1) * binning; ++y) {
        for (int x = px * binning; x < (px + 1) * binning; ++x) {
          const int colour = CfaColorAt(frame.cfa, x, y);
          sum[colour] += read(x, y);
          count[colour] += 1;
        }
      }
      const Eigen::Vector3d value = sum.cwiseQuotient(count).cwiseMax(0.0);
      linear[static_cast<size_t>(py) * width + px] = value;
      channel_sum += value;
    }
  }
  // Gray world: the channels' means made equal, so the chart's neutrals read
  // roughly neutral whatever the sensor's primaries.
  Eigen::Vector3d gains = Eigen::Vector3d::Ones();
  for (int c = 0; c < 3; ++c) gains[c] = channel_sum[c] > 0 ? channel_sum[1] / channel_sum[c] : 1.0;
  std::vector<double> levels;
  levels.reserve(linear.size());
  for (Eigen::Vector3d& value : linear) {
    value = value.cwiseProduct(gains);
    levels.push_back(value.maxCoeff());
  }
  const size_t high = std::min(levels.size() - 1, static_cast<size_t>(0.995 * levels.size()));
  std::nth_element(levels.begin(), levels.begin() + high, levels.end());
  const double scale = levels[high] > 0 ? 0.95 / levels[high] : 1.0;
  cv::Mat bgr(height, width, CV_8UC3);
  for (int py = 0; py < height; ++py) {
    cv::Vec3b* out = bgr.ptr<cv::Vec3b>(py);
    for (int px = 0; px < width; ++px) {
      const Eigen::Vector3d& value = linear[static_cast<size_t>(py) * width + px];
      for (int c = 0; c < 3; ++c) {
        out[px][2 - c] = static_cast<uint8_t>(std::lround(255.0 * SrgbEncode(scale * value[c])));
      }
    }
  }
  return bgr;
}

// mcc's candidates as boxes in full-resolution mosaic pixels, best first.
std::vector<std::array<Eigen::Vector2d, 4>> RunMcc(const cv::Mat& preview, int binning, int max_candidates,
                                                  std::string* error) {
  std::vector<std::array<Eigen::Vector2d, 4>> boxes;
  try {
    cv::Ptr<cv::mcc::CCheckerDetector> detector = cv::mcc::CCheckerDetector::create();
    if (!detector->process(preview, cv::mcc::MCC24, max_candidates)) return boxes;
    for (const cv::Ptr<cv::mcc::CChecker>& checker : detector->getListColorChecker()) {
      const std::vector<cv::Point2f> box = checker->getBox();
      if (box.size() != 4) continue;
      std::array<Eigen::Vector2d, 4> corners;
      // A preview pixel averages binning x binning mosaic pixels; its centre
      // is (binning - 1) / 2 past the block's first pixel.
      for (int i = 0; i < 4; ++i) {
        corners[i] = Eigen::Vector2d(binning * double(box[i].x) + 0.5 * (binning - 1),
                                     binning * double(box[i].y) + 0.5 * (binning - 1));
      }
      boxes.push_back(corners);
    }
  } catch (const cv::Exception& exception) {
    *error = exception.what();
  }
  return boxes;
}

// ---------------------------------------------------------------------------
// The colour fit.

struct FitData {
  std::vector<Eigen::Vector3d> camera;  // white-balanced camera RGB
  std::vector<Eigen::Vector3d> reference_rgb;
  std::vector<Eigen::Vector3d> reference_lab;
  std::vector<double> weight;
};

// The 3x3 matrix from the free parameters: 9 of them, or 6 with the rows
// constrained to sum to 1 (M * (1,1,1) = (1,1,1)).
Eigen::Matrix3d MatrixFromParameters(const Eigen::VectorXd& p, bool preserve_white) {
  Eigen::Matrix3d m;
  for (int row = 0; row < 3; ++row) {
    if (preserve_white) {
      m(row, 0) = p(2 * row);
      m(row, 1) = p(2 * row + 1);
      m(row, 2) = 1.0 - p(2 * row) - p(2 * row + 1);
    } else {
      m.row(row) = p.segment<3>(3 * row).transpose();
    }
  }
  return m;
}

Eigen::VectorXd ParametersFromMatrix(const Eigen::Matrix3d& m, bool preserve_white) {
  Eigen::VectorXd p(preserve_white ? 6 : 9);
  for (int row = 0; row < 3; ++row) {
    if (preserve_white) {
      p(2 * row) = m(row, 0);
      p(2 * row + 1) = m(row, 1);
    } else {
      p.segment<3>(3 * row) = m.row(row).transpose();
    }
  }
  return p;
}

// Weighted least squares in linear RGB, row by row (with the row-sum
// constraint substituted: a m0 + b m1 + (1 - a - b) m2).
Eigen::Matrix3d WeightedLeastSquares(const FitData& data, bool preserve_white) {
  const int n = static_cast<int>(data.camera.size());
  const int unknowns = preserve_white ? 2 : 3;
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  for (int row = 0; row < 3; ++row) {
    Eigen::MatrixXd a(n, unknowns);
    Eigen::VectorXd b(n);
    for (int i = 0; i < n; ++i) {
      const double w = std::sqrt(data.weight[i]);
      const Eigen::Vector3d& c = data.camera[i];
      if (preserve_white) {
        a.row(i) << w * (c[0] - c[2]), w * (c[1] - c[2]);
        b(i) = w * (data.reference_rgb[i][row] - c[2]);
      } else {
        a.row(i) = w * c.transpose();
        b(i) = w * data.reference_rgb[i][row];
      }
    }
    const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
    if (preserve_white) {
      m.row(row) << x(0), x(1), 1.0 - x(0) - x(1);
    } else {
      m.row(row) = x.transpose();
    }
  }
  return m;
}

Eigen::VectorXd DeltaEResiduals(const FitData& data, const Eigen::Matrix3d& m) {
  Eigen::VectorXd r(data.camera.size());
  for (size_t i = 0; i < data.camera.size(); ++i) {
    r(i) = std::sqrt(data.weight[i]) * Ciede2000(LabFromLinearRec709(m * data.camera[i]), data.reference_lab[i]);
  }
  return r;
}

// Levenberg-Marquardt on the weighted CIEDE2000 residuals, central-difference
// Jacobian (6 or 9 parameters, 24 residuals: cheap).
Eigen::Matrix3d MinimiseCiede2000(const FitData& data, const Eigen::Matrix3d& start, bool preserve_white,
                                  int max_iterations) {
  Eigen::VectorXd p = ParametersFromMatrix(start, preserve_white);
  Eigen::VectorXd r = DeltaEResiduals(data, MatrixFromParameters(p, preserve_white));
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  const double step = 1e-6;
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    Eigen::MatrixXd jacobian(r.size(), p.size());
    for (int k = 0; k < p.size(); ++k) {
      Eigen::VectorXd plus = p, minus = p;
      plus(k) += step;
      minus(k) -= step;
      jacobian.col(k) = (DeltaEResiduals(data, MatrixFromParameters(plus, preserve_white)) -
                         DeltaEResiduals(data, MatrixFromParameters(minus, preserve_white))) /
                        (2 * step);
    }
    const Eigen::MatrixXd jtj = jacobian.transpose() * jacobian;
    const Eigen::VectorXd jtr = jacobian.transpose() * r;
    bool improved = false;
    while (lambda < 1e10) {
      Eigen::MatrixXd damped = jtj;
      damped.diagonal() += lambda * (jtj.diagonal().array() + 1e-12).matrix();
      const Eigen::VectorXd candidate = p - damped.ldlt().solve(jtr);
      const Eigen::VectorXd candidate_r = DeltaEResiduals(data, MatrixFromParameters(candidate, preserve_white));
      const double candidate_cost = candidate_r.squaredNorm();
      if (std::isfinite(candidate_cost) && candidate_cost < cost) {
        const double gain = cost - candidate_cost;
        p = candidate;
        r = candidate_r;
        cost = candidate_cost;
        lambda = std::max(1e-9, lambda * 0.3);
        improved = gain > 1e-12 * std::max(1.0, cost);
        break;
      }
      lambda *= 10;
    }
    if (!improved) break;
  }
  return MatrixFromParameters(p, preserve_white);
}

// OpenCV's ccm: reference as linear sRGB (= linear Rec.709), input already
// linear, 3x3, CIEDE2000 loss. Its matrix multiplies row vectors.
Eigen::Matrix3d OpenCvCcm(const FitData& data, std::string* error) {
  const int n = static_cast<int>(data.camera.size());
  cv::Mat source(n, 1, CV_64FC3), colors(n, 1, CV_64FC3), weights(n, 1, CV_64FC1);
  for (int i = 0; i < n; ++i) {
    source.at<cv::Vec3d>(i, 0) = cv::Vec3d(data.camera[i][0], data.camera[i][1], data.camera[i][2]);
    colors.at<cv::Vec3d>(i, 0) =
        cv::Vec3d(data.reference_rgb[i][0], data.reference_rgb[i][1], data.reference_rgb[i][2]);
    weights.at<double>(i, 0) = data.weight[i];
  }
  try {
    cv::ccm::ColorCorrectionModel model(source, colors, cv::ccm::COLOR_SPACE_sRGBL);
    model.setColorSpace(cv::ccm::COLOR_SPACE_sRGB);
    model.setCCM_TYPE(cv::ccm::CCM_3x3);
    model.setDistance(cv::ccm::DISTANCE_CIE2000);
    model.setLinear(cv::ccm::LINEARIZATION_IDENTITY);
    // The patches are chosen already (clipped and dark ones left out).
    model.setSaturatedThreshold(-1e9, 1e9);
    model.setWeightsList(weights);
    model.run();
    const cv::Mat ccm = model.getCCM();
    Eigen::Matrix3d m;
    for (int row = 0; row < 3; ++row) {
      for (int column = 0; column < 3; ++column) m(row, column) = ccm.at<double>(column, row);
    }
    return m;
  } catch (const cv::Exception& exception) {
    *error = exception.what();
    return Eigen::Matrix3d::Identity();
  }
}

std::string VectorText(const Eigen::Vector3d& v, int decimals) {
  return Fixed(v[0], decimals) + " " + Fixed(v[1], decimals) + " " + Fixed(v[2], decimals);
}

std::string WhyNotUsed(const PatchSample& sample) {
  if (sample.used) return "used";
  std::string why;
  if (sample.clipped) why += "clipped";
  if (sample.too_dark) why += std::string(why.empty() ? "" : ", ") + "too dark";
  if (sample.too_few) why += std::string(why.empty() ? "" : ", ") + "too few samples";
  return why.empty() ? "not used" : why;
}

}  // namespace

// ---------------------------------------------------------------------------

Eigen::Matrix3d ColorChartImageFromUv(const ColorChartQuad& quad) { return QuadFromUnitSquare(quad.corners_px); }

Eigen::Vector2d ColorChartPointPx(const ColorChartQuad& quad, double u, double v) {
  return Apply(QuadFromUnitSquare(quad.corners_px), u, v);
}

std::array<Eigen::Vector2d, 4> ColorPatchCornersPx(const ColorChartQuad& quad, int index, double inset) {
  if (index < 0 || index >= kNumPatches) {
    throw std::invalid_argument("colour patch index " + std::to_string(index) + " must lie in [0, 23]");
  }
  const Eigen::Matrix3d homography = QuadFromUnitSquare(quad.corners_px);
  const UvRect r = PatchRect(index, inset);
  return {Apply(homography, r.u0, r.v0), Apply(homography, r.u1, r.v0), Apply(homography, r.u1, r.v1),
          Apply(homography, r.u0, r.v1)};
}

void ColorChartDetectionOptions::Check() const {
  const std::string where = "ColorChartDetectionOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "max_preview_side", max_preview_side, 500, 8000);
  SCANBENCH_REQUIRE_GE(where, "max_candidates", max_candidates, 1);
  SCANBENCH_REQUIRE_GE_LE(where, "patch_inset", patch_inset, 0, 0.45);
  SCANBENCH_REQUIRE_GT_LE(where, "max_fit_residual", max_fit_residual, 0, 1);
  SCANBENCH_REQUIRE_GT_LE(where, "clip_fraction", clip_fraction, 0, 1);
  if (corners) {
    for (int i = 0; i < 4; ++i) {
      if (!Finite(corners->corners_px[i])) {
        throw FieldError(where, "corners[" + std::to_string(i) + "]", "non-finite", "must be finite pixel coordinates");
      }
    }
  }
}

std::string ColorChartDetectionSummary::BriefReport() const {
  std::ostringstream text;
  text << "Colour chart detection (" << (method.empty() ? "none" : method) << "): " << TerminationName(termination);
  if (termination == Termination::kSuccess) {
    text << ", orientation residual " << Fixed(fit_residual, 3) << " (next " << Fixed(next_fit_residual, 3)
         << ", confidence " << Fixed(confidence, 2) << ", " << patches_used_for_check << " patches)";
    if (!warning.empty()) text << "; warning: " << warning;
  } else if (!message.empty()) {
    text << ": " << message;
  }
  return text.str();
}

ColorChartDetectionSummary DetectColorChart(const ColorChartDetectionOptions& options, const RawImage& frame,
                                            const RawImage* dark, const ProgressCallback& progress) {
  options.Check();
  CheckFrames(frame, dark, "DetectColorChart");
  ColorChartDetectionSummary summary;
  const std::string frame_text = options.source_name + " (" + SizeText(frame.width(), frame.height()) + " mosaic)";

  if (options.corners) {
    summary.method = "corners";
    std::array<ColorChartQuad, 8> candidates;
    const auto orders = CornerOrders(options.corners->corners_px);
    for (int i = 0; i < 8; ++i) candidates[i].corners_px = orders[i];
    const OrientationChoice choice = ChooseOrientation(candidates, frame, dark, options);
    Record(choice, &summary);
    if (!(choice.best.residual <= options.max_fit_residual)) {
      summary.SetFailure("no ColorChecker found in " + frame_text + " at the given corners: the patches fit the " +
                         "reference with a relative residual of " + ResidualText(choice.best) +
                         " at best (must be <= " + Fixed(options.max_fit_residual, 3) + ", " +
                         std::to_string(choice.best.used) + " usable patches)");
      return summary;
    }
    if (choice.order != 0) {
      summary.reordered = true;
      summary.warning = "the given corners fit the reference far better in another order (residual " +
                        Fixed(choice.best.residual, 3) + "); reordered to dark skin, bluish green, black, white";
    }
    summary.termination = Termination::kSuccess;
    if (progress && !progress(1.0)) summary.SetCancelled();
    return summary;
  }

  summary.method = "mcc";
  summary.preview_binning = PreviewBinning(frame, options.max_preview_side);
  const cv::Mat preview = DevelopPreview(frame, dark, summary.preview_binning);
  if (progress && !progress(0.2)) {
    summary.SetCancelled();
    return summary;
  }
  std::string error;
  const std::vector<std::array<Eigen::Vector2d, 4>> boxes =
      RunMcc(preview, summary.preview_binning, options.max_candidates, &error);
  summary.candidates = static_cast<int>(boxes.size());
  if (progress && !progress(0.7)) {
    summary.SetCancelled();
    return summary;
  }
  if (boxes.empty()) {
    summary.SetFailure("no ColorChecker found in " + frame_text + ": OpenCV mcc found no 24-patch chart in the " +
                       SizeText(preview.cols, preview.rows) + " preview" +
                       (error.empty() ? "" : " (" + error + ")") +
                       "; give the chart's corner points instead");
    return summary;
  }
  OrientationChoice best;
  for (const std::array<Eigen::Vector2d, 4>& box : boxes) {
    std::array<ColorChartQuad, 8> candidates;
    const auto orders = CornerOrders(box);
    for (int i = 0; i < 8; ++i) candidates[i] = GridQuadFromMccBox(orders[i]);
    const OrientationChoice choice = ChooseOrientation(candidates, frame, dark, options);
    if (choice.best.residual < best.best.residual) best = choice;
  }
  Record(best, &summary);
  if (progress && !progress(1.0)) {
    summary.SetCancelled();
    return summary;
  }
  if (!(best.best.residual <= options.max_fit_residual)) {
    summary.SetFailure("no ColorChecker found in " + frame_text + ": mcc returned " +
                       std::to_string(boxes.size()) + " candidate(s), but their patches fit the reference with a " +
                       "relative residual of " + ResidualText(best.best) + " at best (must be <= " +
                       Fixed(options.max_fit_residual, 3) + ")");
    return summary;
  }
  summary.reordered = best.order != 0;
  summary.termination = Termination::kSuccess;
  return summary;
}

void ColorPatchSamplingOptions::Check() const {
  const std::string where = "ColorPatchSamplingOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "patch_inset", patch_inset, 0, 0.45);
  SCANBENCH_REQUIRE_GT_LE(where, "clip_fraction", clip_fraction, 0, 1);
  SCANBENCH_REQUIRE_GE_LT(where, "min_level", min_level, 0, 1);
  SCANBENCH_REQUIRE_GE(where, "min_samples", min_samples, 1);
}

std::vector<PatchSample> SampleColorChartPatches(const ColorPatchSamplingOptions& options, const RawImage& frame,
                                                 const RawImage* dark, const ColorChartQuad& quad,
                                                 const ImageF* white_response) {
  options.Check();
  CheckFrames(frame, dark, "SampleColorChartPatches");
  if (white_response != nullptr && (!white_response->SameSize(frame.mosaic) || white_response->channels() != 3)) {
    throw std::invalid_argument("SampleColorChartPatches: white_response " + ShapeText(*white_response) +
                                " must be " + SizeText(frame.width(), frame.height()) + "x3 like the frame");
  }
  for (int i = 0; i < 4; ++i) {
    if (!Finite(quad.corners_px[i])) {
      throw std::invalid_argument("SampleColorChartPatches: quad corner " + std::to_string(i) + " is not finite");
    }
  }
  const Eigen::Matrix3d quad_from_uv = QuadFromUnitSquare(quad.corners_px);
  const Eigen::Matrix3d uv_from_quad = quad_from_uv.inverse();
  const LinearReader read(frame, dark);
  const int clip_level = static_cast<int>(options.clip_fraction * frame.white_level);

  std::vector<PatchSample> samples(kNumPatches);
  for (int index = 0; index < kNumPatches; ++index) {
    PatchSample& sample = samples[index];
    const UvRect rect = PatchRect(index, options.patch_inset);
    double min_x = 1e300, max_x = -1e300, min_y = 1e300, max_y = -1e300;
    for (const double u : {rect.u0, rect.u1}) {
      for (const double v : {rect.v0, rect.v1}) {
        const Eigen::Vector2d p = Apply(quad_from_uv, u, v);
        min_x = std::min(min_x, p.x());
        max_x = std::max(max_x, p.x());
        min_y = std::min(min_y, p.y());
        max_y = std::max(max_y, p.y());
      }
    }
    std::array<std::vector<double>, 3> values;
    if (Finite({min_x, min_y}) && Finite({max_x, max_y})) {
      const int x0 = std::max(0, static_cast<int>(std::ceil(min_x)));
      const int x1 = std::min(frame.width() - 1, static_cast<int>(std::floor(max_x)));
      const int y0 = std::max(0, static_cast<int>(std::ceil(min_y)));
      const int y1 = std::min(frame.height() - 1, static_cast<int>(std::floor(max_y)));
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
          const Eigen::Vector3d uvw = uv_from_quad * Eigen::Vector3d(x, y, 1.0);
          const double u = uvw.x() / uvw.z(), v = uvw.y() / uvw.z();
          if (!(u >= rect.u0 && u <= rect.u1 && v >= rect.v0 && v <= rect.v1)) continue;
          if (frame.mosaic(x, y) >= clip_level) {
            sample.clipped = true;
            continue;
          }
          const int colour = CfaColorAt(frame.cfa, x, y);
          double value = read(x, y);
          if (white_response != nullptr) {
            const double white = (*white_response)(x, y, colour);
            if (!(white > 0) || !std::isfinite(white)) continue;
            value /= white;
          }
          values[colour].push_back(value);
        }
      }
    }
    for (int c = 0; c < 3; ++c) {
      sample.samples[c] = static_cast<int>(values[c].size());
      sample.value[c] = Median(values[c]);
      if (sample.samples[c] < options.min_samples) sample.too_few = true;
      if (sample.value[c] < options.min_level) sample.too_dark = true;
    }
    sample.used = !sample.clipped && !sample.too_dark && !sample.too_few;
  }
  return samples;
}

void ColorCorrectionOptions::Check() const {
  const std::string where = "ColorCorrectionOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "neutral_weight", neutral_weight, 0, 100);
  SCANBENCH_REQUIRE_GE_LE(where, "max_iterations", max_iterations, 1, 10000);
  if (min_patches < 6 || min_patches > kNumPatches) {
    throw FieldError(where, "min_patches", min_patches, "must lie in [6, 24]");
  }
  if (min_neutral_patches < 2 || min_neutral_patches > kColorCheckerColumns) {
    throw FieldError(where, "min_neutral_patches", min_neutral_patches, "must lie in [2, 6]");
  }
}

std::string ColorCorrectionMethodName(ColorCorrectionOptions::Method method) {
  switch (method) {
    case ColorCorrectionOptions::Method::kCiede2000Fit: return "ciede2000_fit";
    case ColorCorrectionOptions::Method::kOpenCvCcm: return "opencv_ccm";
  }
  return "unknown";
}

std::string ColorCorrectionSummary::BriefReport() const {
  std::ostringstream text;
  text << "Colour correction (" << method << "): " << TerminationName(termination);
  if (termination == Termination::kSuccess) {
    text << ", " << used_patches << " patches, CIEDE2000 mean " << Fixed(mean_delta_e_before, 2) << " -> "
         << Fixed(mean_delta_e_after, 2) << ", max " << Fixed(max_delta_e_before, 2) << " -> "
         << Fixed(max_delta_e_after, 2);
  }
  if (!message.empty()) text << ": " << message;
  return text.str();
}

std::string ColorCorrectionSummary::PatchTable() const {
  std::ostringstream text;
  text << std::left << std::setw(22) << "patch" << std::setw(23) << "measured camera" << std::setw(23)
       << "reference rec709" << std::setw(23) << "corrected rec709" << std::right << std::setw(8) << "dE00"
       << std::setw(8) << "after" << "  status\n";
  for (const ColorPatchResult& patch : patches) {
    text << std::left << std::setw(22) << patch.name << std::setw(23) << VectorText(patch.measured_camera, 4)
         << std::setw(23) << VectorText(patch.reference_linear_rec709, 4) << std::setw(23)
         << VectorText(patch.corrected_linear_rec709, 4) << std::right << std::setw(8)
         << Fixed(patch.delta_e_before, 2) << std::setw(8) << Fixed(patch.delta_e_after, 2) << "  "
         << (patch.used ? "used" : "left out: " + patch.status) << "\n";
  }
  return text.str();
}

std::optional<Eigen::Vector3d> NeutralPatchGains(const std::vector<PatchSample>& measured,
                                                 const std::vector<ColorCheckerPatch>& reference, std::string* why) {
  if (measured.size() != reference.size()) {
    throw std::invalid_argument("NeutralPatchGains: " + std::to_string(measured.size()) + " measured patches for " +
                                std::to_string(reference.size()) + " reference patches");
  }
  Eigen::Vector3d numerator = Eigen::Vector3d::Zero(), denominator = Eigen::Vector3d::Zero();
  int neutrals = 0;
  for (size_t i = 0; i < measured.size(); ++i) {
    if (!reference[i].neutral || !measured[i].used || !measured[i].value.allFinite()) continue;
    ++neutrals;
    numerator += measured[i].value.cwiseProduct(reference[i].linear_rec709);
    denominator += measured[i].value.cwiseProduct(measured[i].value);
  }
  if (neutrals < 2) {
    if (why) {
      *why = "only " + std::to_string(neutrals) + " of the chart's gray patches are usable (neither clipped nor too "
             "dark); balancing on them needs at least 2: expose for the gray row";
    }
    return std::nullopt;
  }
  Eigen::Vector3d gains;
  for (int c = 0; c < 3; ++c) {
    if (!(numerator[c] > 0 && denominator[c] > 0)) {
      if (why) {
        *why = "the neutral patches read " + Fixed(std::sqrt(denominator[c]), 6) + " in colour " + std::to_string(c) +
               ": cannot balance on them";
      }
      return std::nullopt;
    }
    gains[c] = numerator[c] / denominator[c];
  }
  return gains;
}

ColorCorrectionSummary FitColorCorrection(const ColorCorrectionOptions& options,
                                          const std::vector<PatchSample>& measured,
                                          const std::vector<ColorCheckerPatch>& reference) {
  options.Check();
  if (reference.empty() || measured.size() != reference.size()) {
    throw std::invalid_argument("FitColorCorrection: " + std::to_string(measured.size()) +
                                " measured patches must match the " + std::to_string(reference.size()) +
                                " reference patches (and there must be some)");
  }
  ColorCorrectionSummary summary;
  summary.method = ColorCorrectionMethodName(options.method);

  // Which patches take part, and why the others do not.
  std::vector<int> used;
  int neutrals = 0;
  std::string left_out;
  for (size_t i = 0; i < measured.size(); ++i) {
    const bool finite = measured[i].value.allFinite();
    if (measured[i].used && finite) {
      used.push_back(static_cast<int>(i));
      if (reference[i].neutral) ++neutrals;
    } else {
      left_out += (left_out.empty() ? "" : "; ") + reference[i].name + " (" +
                  (finite ? WhyNotUsed(measured[i]) : std::string("not finite")) + ")";
    }
  }
  summary.used_patches = static_cast<int>(used.size());
  if (summary.used_patches < options.min_patches || neutrals < options.min_neutral_patches) {
    summary.SetFailure("a colour fit needs >= " + std::to_string(options.min_patches) + " used patches including >= " +
                       std::to_string(options.min_neutral_patches) + " neutral ones, got " +
                       std::to_string(used.size()) + " used (" + std::to_string(neutrals) +
                       " neutral); left out: " + (left_out.empty() ? "none" : left_out));
    return summary;
  }

  if (options.balance_on_neutral_patches) {
    std::string why;
    const std::optional<Eigen::Vector3d> gains = NeutralPatchGains(measured, reference, &why);
    if (!gains) {
      summary.SetFailure(why);
      return summary;
    }
    summary.camera_balance_gains = *gains;
  }

  FitData data;
  for (const int i : used) {
    data.camera.push_back(measured[i].value.cwiseProduct(summary.camera_balance_gains));
    data.reference_rgb.push_back(reference[i].linear_rec709);
    data.reference_lab.push_back(LabFromLinearRec709(reference[i].linear_rec709));
    data.weight.push_back(reference[i].neutral ? options.neutral_weight : 1.0);
  }

  if (options.method == ColorCorrectionOptions::Method::kCiede2000Fit) {
    const Eigen::Matrix3d start = WeightedLeastSquares(data, options.preserve_white);
    summary.rec709_from_camera = MinimiseCiede2000(data, start, options.preserve_white, options.max_iterations);
  } else {
    std::string error;
    summary.rec709_from_camera = OpenCvCcm(data, &error);
    if (!error.empty()) {
      summary.SetFailure("OpenCV's ColorCorrectionModel failed: " + error);
      return summary;
    }
    if (options.preserve_white) {
      const Eigen::Vector3d white = summary.rec709_from_camera * Eigen::Vector3d::Ones();
      summary.message = "preserve_white is not available in OpenCV's ccm: camera white maps to " +
                        VectorText(white, 4);
    }
  }
  if (!summary.rec709_from_camera.allFinite()) {
    summary.SetFailure("the colour fit diverged (non-finite matrix)");
    summary.rec709_from_camera = Eigen::Matrix3d::Identity();
    return summary;
  }

  std::vector<bool> is_used(measured.size(), false);
  for (const int i : used) is_used[i] = true;
  double sum_before = 0, sum_after = 0;
  for (size_t i = 0; i < measured.size(); ++i) {
    ColorPatchResult result;
    result.name = reference[i].name;
    result.used = is_used[i];
    result.status = measured[i].value.allFinite() ? WhyNotUsed(measured[i]) : "not finite";
    result.reference_linear_rec709 = reference[i].linear_rec709;
    result.measured_camera = measured[i].value.allFinite()
                                 ? Eigen::Vector3d(measured[i].value.cwiseProduct(summary.camera_balance_gains))
                                 : Eigen::Vector3d::Zero();
    result.corrected_linear_rec709 = summary.rec709_from_camera * result.measured_camera;
    const Eigen::Vector3d reference_lab = LabFromLinearRec709(reference[i].linear_rec709);
    result.delta_e_before = Ciede2000(LabFromLinearRec709(result.measured_camera), reference_lab);
    result.delta_e_after = Ciede2000(LabFromLinearRec709(result.corrected_linear_rec709), reference_lab);
    if (!std::isfinite(result.delta_e_before)) result.delta_e_before = 0;
    if (!std::isfinite(result.delta_e_after)) result.delta_e_after = 0;
    if (result.used) {
      sum_before += result.delta_e_before;
      sum_after += result.delta_e_after;
      summary.max_delta_e_before = std::max(summary.max_delta_e_before, result.delta_e_before);
      summary.max_delta_e_after = std::max(summary.max_delta_e_after, result.delta_e_after);
    }
    summary.patches.push_back(result);
  }
  summary.mean_delta_e_before = sum_before / used.size();
  summary.mean_delta_e_after = sum_after / used.size();
  summary.termination = Termination::kSuccess;
  return summary;
}

Eigen::Matrix3d Rec709FromWhiteBalancedCamera(const Eigen::Matrix3d& camera_from_xyz) {
  if (!camera_from_xyz.allFinite()) {
    throw std::invalid_argument("Rec709FromWhiteBalancedCamera: camera_from_xyz must be finite");
  }
  const double scale = camera_from_xyz.cwiseAbs().maxCoeff();
  if (!(scale > 0) || !(std::abs(camera_from_xyz.determinant()) > 1e-9 * scale * scale * scale)) {
    throw std::invalid_argument("Rec709FromWhiteBalancedCamera: camera_from_xyz (determinant " +
                                std::to_string(camera_from_xyz.determinant()) + ") must be invertible");
  }
  const Eigen::Vector3d neutral = camera_from_xyz * D65WhiteXyz();
  if (!(neutral.minCoeff() > 0)) {
    throw std::invalid_argument("Rec709FromWhiteBalancedCamera: the D65 white's camera response " +
                                VectorText(neutral, 4) + " must be positive in every colour");
  }
  // rec709 = Rec709FromXyz * XyzFromCamera * native, native = diag(neutral) * w.
  Eigen::Matrix3d m = LinearRec709FromXyz() * camera_from_xyz.inverse() * neutral.asDiagonal();
  // Already maps (1,1,1) to the D65 white's Rec.709 (1,1,1) up to rounding;
  // the row scale makes it exact.
  for (int row = 0; row < 3; ++row) m.row(row) /= m.row(row).sum();
  return m;
}

}  // namespace scanbench
