#include "maps/surface_occlusion.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

// Throws naming the caller and the shape, or the first non-finite pixel.
void CheckFiniteHeight(const ImageF& height_mm, const char* where) {
  if (height_mm.empty() || height_mm.channels() != 1) {
    throw std::invalid_argument(std::string(where) + ": height_mm is " + ShapeText(height_mm) +
                                ", must be a non-empty 1 channel image");
  }
  for (int y = 0; y < height_mm.height(); ++y) {
    const float* row = height_mm.row(y);
    for (int x = 0; x < height_mm.width(); ++x) {
      if (!std::isfinite(row[x])) {
        std::ostringstream text;
        text << where << ": height_mm(" << x << ", " << y << ") = " << row[x] << " is not finite";
        throw std::invalid_argument(text.str());
      }
    }
  }
}

void CheckOutput(const ImageF* output, const char* where, const char* name) {
  if (output == nullptr) throw std::invalid_argument(std::string(where) + ": " + name + " must not be null");
}

void FillFigures(const ImageF& map, OcclusionSummary* summary) {
  double sum = 0;
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  for (size_t i = 0; i < map.size(); ++i) {
    const float v = map.data()[i];
    sum += v;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  summary->mean = map.empty() ? 0 : sum / static_cast<double>(map.size());
  summary->min = map.empty() ? 0 : lo;
  summary->max = map.empty() ? 0 : hi;
}

// Rows on threads; a cancel is a false return. progress(0) first, so a stop
// requested before any work is honoured.
template <typename Body>
bool RunRows(int rows, int num_threads, const ProgressCallback& progress, const Body& body) {
  if (progress && !progress(0.0)) return false;
  return scanbench::ParallelRows(rows, num_threads, progress, 0.0, 1.0, body);
}

// One sample of a march, the same for every pixel: the pixel offset splits into
// an integer part and fixed bilinear weights, because pixel centres are integers.
struct MarchSample {
  int dx = 0, dy = 0;         // floor of the offset, pixels
  float fx = 0, fy = 0;       // fractional part, [0, 1)
  float inv_distance_mm = 0;  // 1 / horizontal distance
};

// Distances of the samples along an azimuth, pixels: evenly spaced when the
// radius has no more pixels than steps; otherwise at least one pixel apart and
// growing quadratically, so the near field (where most of the cosine weight
// is decided) is sampled densely and the far field sparsely.
std::vector<double> MarchDistances(double radius_px, int steps) {
  std::vector<double> distances(steps);
  for (int i = 0; i < steps; ++i) {
    const double t = static_cast<double>(i + 1) / steps;
    distances[i] = radius_px <= steps ? radius_px * t : (i + 1) + (radius_px - steps) * t * t;
  }
  return distances;
}

// Raises max_tangent[x] to the slope at which the bilinear field leaves each
// pixel of row y towards azimuth (cos_azimuth, sin_azimuth): the limit of the
// rise over distance as the distance goes to 0. Within the first cell the
// rise over distance is linear in the distance, so this and the samples
// beyond bracket it; without it a pixel at the bottom of a sharp pit would
// miss the walls between it and the first sample.
void LeavingSlopeRow(const ImageF& height_mm, int y, float cos_azimuth, float sin_azimuth, double mm_per_pixel,
                     float* max_tangent) {
  const int width = height_mm.width(), rows = height_mm.height();
  const float* centre = height_mm.row(y);
  const float* next_row = height_mm.row(std::clamp(y + (sin_azimuth > 0 ? 1 : -1), 0, rows - 1));
  const int step_x = cos_azimuth > 0 ? 1 : -1;
  const float wx = std::abs(cos_azimuth), wy = std::abs(sin_azimuth);
  const float inv_mm = static_cast<float>(1.0 / mm_per_pixel);
  for (int x = 0; x < width; ++x) {
    const int next_x = std::clamp(x + step_x, 0, width - 1);
    const float slope = (wx * (centre[next_x] - centre[x]) + wy * (next_row[x] - centre[x])) * inv_mm;
    max_tangent[x] = std::max(max_tangent[x], slope);
  }
}

// One sample's rise for pixels [begin, end), whose x + dx and x + dx + 1 lie
// inside the row (r0, r1 already offset by dx). Built for AVX-512, AVX2 and
// the baseline, picked at run time; each lane does the baseline's very
// operations (no FMA contraction: -ffp-contract=off), so every build gives
// the same bits.
__attribute__((target_clones("avx512f", "avx2", "default"))) void MarchInterior(
    const float* r0, const float* r1, const float* centre, float fx, float fy, float inv, int begin, int end,
    float* max_tangent) {
  for (int x = begin; x < end; ++x) {
    const float a = r0[x] + fx * (r0[x + 1] - r0[x]);
    const float b = r1[x] + fx * (r1[x + 1] - r1[x]);
    max_tangent[x] = std::max(max_tangent[x], (a + fy * (b - a) - centre[x]) * inv);
  }
}

// Four samples' rises for pixels [begin, end), inside the row for all four
// (r0[i], r1[i] already offset by sample i's dx): the centre heights and the
// horizons are read and written once for the four, which saves a third of
// the memory operations of four MarchInterior passes. Each sample's rise is
// MarchInterior's to the bit, and a maximum does not depend on the order its
// values come in (+0 and -0 aside, which give the same visibility).
__attribute__((target_clones("avx512f", "avx2", "default"))) void MarchInterior4(
    const float* const* r0, const float* const* r1, const float* centre, const float* fx, const float* fy,
    const float* inv, int begin, int end, float* __restrict max_tangent) {
  const float* r00 = r0[0];
  const float* r01 = r0[1];
  const float* r02 = r0[2];
  const float* r03 = r0[3];
  const float* r10 = r1[0];
  const float* r11 = r1[1];
  const float* r12 = r1[2];
  const float* r13 = r1[3];
  const float fx0 = fx[0], fx1 = fx[1], fx2 = fx[2], fx3 = fx[3];
  const float fy0 = fy[0], fy1 = fy[1], fy2 = fy[2], fy3 = fy[3];
  const float inv0 = inv[0], inv1 = inv[1], inv2 = inv[2], inv3 = inv[3];
  for (int x = begin; x < end; ++x) {
    const float c = centre[x];
    float m = max_tangent[x];
    {
      const float a = r00[x] + fx0 * (r00[x + 1] - r00[x]);
      const float b = r10[x] + fx0 * (r10[x + 1] - r10[x]);
      m = std::max(m, (a + fy0 * (b - a) - c) * inv0);
    }
    {
      const float a = r01[x] + fx1 * (r01[x + 1] - r01[x]);
      const float b = r11[x] + fx1 * (r11[x + 1] - r11[x]);
      m = std::max(m, (a + fy1 * (b - a) - c) * inv1);
    }
    {
      const float a = r02[x] + fx2 * (r02[x + 1] - r02[x]);
      const float b = r12[x] + fx2 * (r12[x + 1] - r12[x]);
      m = std::max(m, (a + fy2 * (b - a) - c) * inv2);
    }
    {
      const float a = r03[x] + fx3 * (r03[x + 1] - r03[x]);
      const float b = r13[x] + fx3 * (r13[x + 1] - r13[x]);
      m = std::max(m, (a + fy3 * (b - a) - c) * inv3);
    }
    max_tangent[x] = m;
  }
}

// Raises max_tangent[x] for one azimuth's samples to the steepest rise
// (height difference over distance) seen from each pixel of row y.
void MarchRow(const ImageF& height_mm, int y, const std::vector<MarchSample>& samples, float* max_tangent) {
  const int width = height_mm.width(), rows = height_mm.height();
  const float* centre = height_mm.row(y);
  // Sample i's rows, its interior [begin, end) (x + dx and x + dx + 1 both
  // inside the row) and everything outside it.
  struct Span {
    const float* r0;
    const float* r1;
    int begin, end;
  };
  auto span_of = [&](const MarchSample& s) {
    const int begin = std::clamp(-s.dx, 0, width);
    return Span{height_mm.row(std::clamp(y + s.dy, 0, rows - 1)), height_mm.row(std::clamp(y + s.dy + 1, 0, rows - 1)),
                begin, std::clamp(width - 1 - s.dx, begin, width)};
  };
  // Pixels [from, to) of sample s outside its interior: the clamp-to-edge rise.
  auto edge = [&](const MarchSample& s, const Span& span, int from, int to) {
    // a + f * (b - a) keeps a flat field exactly flat (no rounding rise).
    for (int x = from; x < to; ++x) {
      const int x0 = std::clamp(x + s.dx, 0, width - 1), x1 = std::clamp(x + s.dx + 1, 0, width - 1);
      const float a = span.r0[x0] + s.fx * (span.r0[x1] - span.r0[x0]);
      const float b = span.r1[x0] + s.fx * (span.r1[x1] - span.r1[x0]);
      max_tangent[x] = std::max(max_tangent[x], (a + s.fy * (b - a) - centre[x]) * s.inv_distance_mm);
    }
  };
  // One sample over the whole row.
  auto march_one = [&](const MarchSample& s, const Span& span, int from, int to) {
    const int begin = std::clamp(span.begin, from, to), end = std::clamp(span.end, begin, to);
    edge(s, span, from, begin);
    MarchInterior(span.r0 + s.dx, span.r1 + s.dx, centre, s.fx, s.fy, s.inv_distance_mm, begin, end, max_tangent);
    edge(s, span, end, to);
  };
  size_t i = 0;
  for (; i + 4 <= samples.size(); i += 4) {
    Span spans[4];
    const float* r0[4];
    const float* r1[4];
    float fx[4], fy[4], inv[4];
    int begin = 0, end = width;
    for (int j = 0; j < 4; ++j) {
      const MarchSample& s = samples[i + j];
      spans[j] = span_of(s);
      r0[j] = spans[j].r0 + s.dx;
      r1[j] = spans[j].r1 + s.dx;
      fx[j] = s.fx;
      fy[j] = s.fy;
      inv[j] = s.inv_distance_mm;
      begin = std::max(begin, spans[j].begin);
      end = std::min(end, spans[j].end);
    }
    end = std::max(end, begin);
    // Outside the four's common interior one sample at a time, inside it the four together.
    for (int j = 0; j < 4; ++j) {
      march_one(samples[i + j], spans[j], 0, begin);
      march_one(samples[i + j], spans[j], end, width);
    }
    MarchInterior4(r0, r1, centre, fx, fy, inv, begin, end, max_tangent);
  }
  for (; i < samples.size(); ++i) march_one(samples[i], span_of(samples[i]), 0, width);
}

// The samples of every azimuth, the same for every pixel.
struct AzimuthMarches {
  int steps = 0;                                  // samples per azimuth
  double radius_px = 0;                           // search radius, pixels
  std::vector<std::vector<MarchSample>> samples;  // per azimuth
  std::vector<float> cos_azimuth, sin_azimuth;    // x right, y down the rows
};

AzimuthMarches PlanMarches(const AmbientOcclusionOptions& options) {
  AzimuthMarches marches;
  marches.radius_px = options.radius_mm / options.mm_per_pixel;
  marches.steps =
      static_cast<int>(std::min<double>(options.max_steps, std::max(1.0, std::ceil(marches.radius_px))));
  const std::vector<double> distances = MarchDistances(marches.radius_px, marches.steps);
  const int num_directions = options.num_directions;
  marches.samples.resize(num_directions);
  marches.cos_azimuth.resize(num_directions);
  marches.sin_azimuth.resize(num_directions);
  for (int k = 0; k < num_directions; ++k) {
    // Half-step offset: no azimuth runs exactly along the pixel axes, so
    // axis-aligned structures are not over-weighted.
    const double azimuth = 2 * std::numbers::pi * (k + 0.5) / num_directions;
    marches.cos_azimuth[k] = static_cast<float>(std::cos(azimuth));
    marches.sin_azimuth[k] = static_cast<float>(std::sin(azimuth));
    for (double d : distances) {
      const double ox = d * std::cos(azimuth), oy = d * std::sin(azimuth);
      MarchSample s;
      s.dx = static_cast<int>(std::floor(ox));
      s.dy = static_cast<int>(std::floor(oy));
      s.fx = static_cast<float>(ox - s.dx);
      s.fy = static_cast<float>(oy - s.dy);
      s.inv_distance_mm = static_cast<float>(1.0 / (d * options.mm_per_pixel));
      marches.samples[k].push_back(s);
    }
  }
  return marches;
}

// The pixel normals of row y (x right, y down the rows, z up), from central
// differences of the height (one-sided at the border).
void PixelNormalsRow(const ImageF& height_mm, int y, double mm_per_pixel, std::vector<float>* normal_x,
                     std::vector<float>* normal_y, std::vector<float>* normal_z) {
  const int width = height_mm.width(), rows = height_mm.height();
  const float* up = height_mm.row(std::max(y - 1, 0));
  const float* down = height_mm.row(std::min(y + 1, rows - 1));
  const float* centre = height_mm.row(y);
  const int dy_px = std::min(y + 1, rows - 1) - std::max(y - 1, 0);
  for (int x = 0; x < width; ++x) {
    const int left = std::max(x - 1, 0), right = std::min(x + 1, width - 1);
    const double gx = right > left ? (centre[right] - centre[left]) / ((right - left) * mm_per_pixel) : 0;
    const double gy = dy_px > 0 ? (down[x] - up[x]) / (dy_px * mm_per_pixel) : 0;
    const double norm = std::sqrt(1 + gx * gx + gy * gy);
    (*normal_x)[x] = static_cast<float>(-gx / norm);
    (*normal_y)[x] = static_cast<float>(-gy / norm);
    (*normal_z)[x] = static_cast<float>(1 / norm);
  }
}

// Visibility of row y: per azimuth the steepest horizon, its half-slice's
// share of the hemisphere, the mean over the azimuths.
void VisibilityRow(const ImageF& height_mm, int y, const AzimuthMarches& marches,
                   const AmbientOcclusionOptions& options, float* visibility_row) {
  const int width = height_mm.width();
  const int num_directions = static_cast<int>(marches.samples.size());
  const bool pixel_normal = options.around_pixel_normal;
  const float half_pi = static_cast<float>(std::numbers::pi / 2);
  std::vector<float> max_tangent(width);
  std::vector<float> sum(width, 0.0f);
  std::vector<float> normal_x(width, 0.0f), normal_y(width, 0.0f), normal_z(width, 1.0f);
  if (pixel_normal) PixelNormalsRow(height_mm, y, options.mm_per_pixel, &normal_x, &normal_y, &normal_z);
  for (int k = 0; k < num_directions; ++k) {
    const float cos_azimuth = marches.cos_azimuth[k], sin_azimuth = marches.sin_azimuth[k];
    std::fill(max_tangent.begin(), max_tangent.end(), std::numeric_limits<float>::lowest());
    LeavingSlopeRow(height_mm, y, cos_azimuth, sin_azimuth, options.mm_per_pixel, max_tangent.data());
    MarchRow(height_mm, y, marches.samples[k], max_tangent.data());
    if (!pixel_normal) {
      // The half-slice towards this azimuth for the normal (0, 0, 1), horizon
      // elevation h >= 0 (the table plane bounds the hemisphere):
      // 2 * integral over zenith angles [0, pi/2 - h] of cos * sin = cos^2(h).
      for (int x = 0; x < width; ++x) {
        const float t = std::max(max_tangent[x], 0.0f);
        sum[x] += 1.0f / (1.0f + t * t);
      }
    } else {
      // GTAO's slice integral for normal n, per half-slice towards azimuth
      // d: with the horizon at zenith angle theta = pi/2 - atan(t), gamma the
      // angle of n projected into the slice (n_p), nd = n.d and nz = n.z,
      //   2 |n_p| * integral_0^theta cos(a - gamma) sin(a) da
      //     = nz / (1 + t^2) + nd * (theta - t / (1 + t^2)),
      // the horizon never below n's own hemisphere: t >= -nd / nz.
      for (int x = 0; x < width; ++x) {
        const float nd = normal_x[x] * cos_azimuth + normal_y[x] * sin_azimuth;
        const float t = std::max(max_tangent[x], -nd / normal_z[x]);
        const float inv = 1.0f / (1.0f + t * t);
        sum[x] += normal_z[x] * inv + nd * (half_pi - std::atan(t) - t * inv);
      }
    }
  }
  const float scale = 1.0f / num_directions;
  for (int x = 0; x < width; ++x) visibility_row[x] = std::clamp(sum[x] * scale, 0.0f, 1.0f);
}

// Heights relative to the lowest point, as OpenCV's float image: a flat map
// becomes exactly zero and stays so through the blur, and large offsets lose
// no float precision.
// The heights minus their lowest (so a flat map is exactly level and large
// offsets lose no float precision), the cavity's buffer until it is filled.
ImageF RelativeToLowest(const ImageF& height_mm) {
  const float lowest = *std::min_element(height_mm.data(), height_mm.data() + height_mm.size());
  ImageF relative(height_mm.width(), height_mm.height(), 1);
  for (int y = 0; y < height_mm.height(); ++y) {
    const float* in = height_mm.row(y);
    float* rel = relative.row(y);
    for (int x = 0; x < height_mm.width(); ++x) rel[x] = in[x] - lowest;
  }
  return relative;
}

// Gaussian weights of a tap row: taps[k] for fine pixel first + k, centred
// at `centre` (fine pixels), sigma `sigma`, normalised to sum 1.
struct TapRow {
  int first = 0;
  std::vector<float> weights;
};

TapRow GaussianTaps(double centre, double sigma, int radius) {
  TapRow taps;
  taps.first = static_cast<int>(std::floor(centre)) - radius;
  const int count = 2 * radius + 2;
  taps.weights.resize(count);
  double sum = 0;
  std::vector<double> exact(count);
  for (int k = 0; k < count; ++k) {
    const double d = taps.first + k - centre;
    exact[k] = std::exp(-d * d / (2 * sigma * sigma));
    sum += exact[k];
  }
  for (int k = 0; k < count; ++k) taps.weights[k] = static_cast<float>(exact[k] / sum);
  return taps;
}

// The largest integer f with sigma_px / f >= min_coarse_sigma_px; 1 for 0.
int CoarseFactor(double sigma_px, double min_coarse_sigma_px) {
  if (!(min_coarse_sigma_px > 0)) return 1;
  return std::max(1, static_cast<int>(std::floor(sigma_px / min_coarse_sigma_px)));
}

// Catmull-Rom weights of the four nodes around t in [0, 1) (nodes -1, 0, 1,
// 2): the cubic that reproduces polynomials up to the quadratic, so its error
// is third order in the node spacing. (cv::resize's bicubic is Keys' a = -0.75,
// first order: a gradient came back shifted, 0.01 of cavity at 4 px.)
std::array<float, 4> CatmullRom(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {static_cast<float>((-t3 + 2 * t2 - t) / 2), static_cast<float>((3 * t3 - 5 * t2 + 2) / 2),
          static_cast<float>((-3 * t3 + 4 * t2 + t) / 2), static_cast<float>((t3 - t2) / 2)};
}

// The Gaussian-weighted mean (sigma_px, replicated border) of `relative`, a
// row at a time.
//
// With factor 1 it is cv::GaussianBlur of the whole image. With factor > 1 it
// is sampled on a grid `factor` times coarser and interpolated back: a
// Gaussian of sigma0 = factor px (evaluated only at the coarse points, taps on
// the replicated fine pixels) takes the field to the coarse grid, a Gaussian
// of sqrt(sigma_px^2 - sigma0^2) / factor coarse px blurs it there (the two
// compose to sigma_px), and a Catmull-Rom cubic brings each row back. The
// first Gaussian passes exp(-2 pi^2) = 3e-9 of the frequencies that alias
// onto the low ones the second keeps, and a field blurred by sigma_px >>
// factor is smooth on the coarse grid, so the cubic follows it. The coarse
// grid runs past the image by the coarse kernel's reach plus the cubic's, so
// the replicated border is the fine image's, as with the full-resolution
// Gaussian. Cost: about 8 factor + 2 taps per fine pixel against 16 sigma_px.
class NeighbourhoodMean {
 public:
  NeighbourhoodMean(const cv::Mat& relative, double sigma_px, int factor)
      : width_(relative.cols), factor_(factor) {
    if (factor <= 1) {
      cv::GaussianBlur(relative, mean_, cv::Size(0, 0), sigma_px, sigma_px, cv::BORDER_REPLICATE);
      return;
    }
    const int rows = relative.rows;
    const double sigma0 = factor;
    const int radius0 = static_cast<int>(std::ceil(4 * sigma0));
    const double coarse_sigma = std::sqrt(sigma_px * sigma_px - sigma0 * sigma0) / factor;
    // cv::GaussianBlur's own reach for a float image (4 sigma), plus the cubic's 2.
    margin_ = static_cast<int>(std::ceil(4 * coarse_sigma)) + 3;
    const int coarse_width = (width_ + factor - 1) / factor + 2 * margin_;
    const int coarse_rows = (rows + factor - 1) / factor + 2 * margin_;
    std::vector<TapRow> column_taps(coarse_width), row_taps(coarse_rows);
    for (int i = 0; i < coarse_width; ++i) column_taps[i] = GaussianTaps(CentreOf(i), sigma0, radius0);
    for (int j = 0; j < coarse_rows; ++j) row_taps[j] = GaussianTaps(CentreOf(j), sigma0, radius0);

    // Across the rows first (every fine row, coarse columns), then down.
    cv::Mat across(rows, coarse_width, CV_32F);
    for (int y = 0; y < rows; ++y) {
      const float* in = relative.ptr<float>(y);
      float* out = across.ptr<float>(y);
      for (int i = 0; i < coarse_width; ++i) {
        const TapRow& taps = column_taps[i];
        const int count = static_cast<int>(taps.weights.size());
        float sum = 0;
        if (taps.first >= 0 && taps.first + count <= width_) {
          const float* p = in + taps.first;
          for (int k = 0; k < count; ++k) sum += taps.weights[k] * p[k];
        } else {
          for (int k = 0; k < count; ++k) sum += taps.weights[k] * in[std::clamp(taps.first + k, 0, width_ - 1)];
        }
        out[i] = sum;
      }
    }
    cv::Mat coarse(coarse_rows, coarse_width, CV_32F);
    for (int j = 0; j < coarse_rows; ++j) {
      const TapRow& taps = row_taps[j];
      float* out = coarse.ptr<float>(j);
      std::fill(out, out + coarse_width, 0.0f);
      for (int k = 0; k < static_cast<int>(taps.weights.size()); ++k) {
        const float* in = across.ptr<float>(std::clamp(taps.first + k, 0, rows - 1));
        const float w = taps.weights[k];
        for (int i = 0; i < coarse_width; ++i) out[i] += w * in[i];
      }
    }
    across.release();
    cv::GaussianBlur(coarse, mean_, cv::Size(0, 0), coarse_sigma, coarse_sigma, cv::BORDER_REPLICATE);

    x_node_.resize(width_);
    x_weights_.resize(width_);
    for (int x = 0; x < width_; ++x) {
      const double u = CoarseCoordinate(x);
      x_node_[x] = static_cast<int>(std::floor(u)) - 1;
      x_weights_[x] = CatmullRom(u - std::floor(u));
    }
    column_.resize(coarse_width);
    row_.resize(width_);
  }

  // The mean of fine row y; valid until the next call.
  const float* Row(int y) {
    if (factor_ <= 1) return mean_.ptr<float>(y);
    const double v = CoarseCoordinate(y);
    const int node = static_cast<int>(std::floor(v)) - 1;
    const std::array<float, 4> w = CatmullRom(v - std::floor(v));
    const float* r0 = mean_.ptr<float>(node);
    const float* r1 = mean_.ptr<float>(node + 1);
    const float* r2 = mean_.ptr<float>(node + 2);
    const float* r3 = mean_.ptr<float>(node + 3);
    for (size_t i = 0; i < column_.size(); ++i) column_[i] = w[0] * r0[i] + w[1] * r1[i] + w[2] * r2[i] + w[3] * r3[i];
    for (int x = 0; x < width_; ++x) {
      const float* c = column_.data() + x_node_[x];
      const std::array<float, 4>& wx = x_weights_[x];
      row_[x] = wx[0] * c[0] + wx[1] * c[1] + wx[2] * c[2] + wx[3] * c[3];
    }
    return row_.data();
  }

 private:
  // Coarse index i stands for fine coordinate factor (i - margin) + (factor - 1) / 2.
  double CentreOf(int i) const { return factor_ * (i - margin_) + (factor_ - 1) / 2.0; }
  double CoarseCoordinate(int fine) const { return (fine - (factor_ - 1) / 2.0) / factor_ + margin_; }

  int width_ = 0, factor_ = 1, margin_ = 0;
  cv::Mat mean_;  // factor 1: the fine mean; else the coarse one
  std::vector<int> x_node_;
  std::vector<std::array<float, 4>> x_weights_;
  std::vector<float> column_, row_;
};

}  // namespace

void AmbientOcclusionOptions::Check() const {
  const char* where = "AmbientOcclusionOptions";
  SCANBENCH_REQUIRE_FINITE_GT(where, "mm_per_pixel", mm_per_pixel, 0);
  SCANBENCH_REQUIRE_FINITE_GT(where, "radius_mm", radius_mm, 0);
  if (radius_mm / mm_per_pixel > 100000) {
    throw FieldError(where, "radius_mm", radius_mm,
                     "must be at most 100000 pixels (mm_per_pixel = " + std::to_string(mm_per_pixel) + ")");
  }
  if (num_directions < 4 || num_directions > 1024) {
    throw FieldError(where, "num_directions", num_directions, "must be in [4, 1024]");
  }
  if (max_steps < 1 || max_steps > 4096) throw FieldError(where, "max_steps", max_steps, "must be in [1, 4096]");
  if (num_threads < 0 || num_threads > 256) {
    throw FieldError(where, "num_threads", num_threads, "must be in [0, 256]");
  }
}

void CavityOptions::Check() const {
  const char* where = "CavityOptions";
  SCANBENCH_REQUIRE_FINITE_GT(where, "mm_per_pixel", mm_per_pixel, 0);
  SCANBENCH_REQUIRE_FINITE_GT(where, "radius_mm", radius_mm, 0);
  if (radius_mm / mm_per_pixel > 1000) {
    throw FieldError(where, "radius_mm", radius_mm,
                     "must be at most 1000 pixels (mm_per_pixel = " + std::to_string(mm_per_pixel) + ")");
  }
  SCANBENCH_REQUIRE_FINITE_GT(where, "depth_scale_mm", depth_scale_mm, 0);
  if (!(min_coarse_sigma_px == 0 || min_coarse_sigma_px >= 2) || !std::isfinite(min_coarse_sigma_px)) {
    throw FieldError(where, "min_coarse_sigma_px", min_coarse_sigma_px, "must be 0 or finite and >= 2");
  }
}

std::string OcclusionSummary::BriefReport() const {
  std::string name = map_name.empty() ? "Occlusion" : map_name;
  name[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(name[0])));
  std::string report = name + ": " + TerminationName(termination) + ", mean " + Fixed(mean, 3) + ", min " +
                       Fixed(min, 3) + ", max " + Fixed(max, 3) + ", radius " + Fixed(radius_px, 1) + " px";
  if (steps_per_direction > 0) report += " (" + std::to_string(steps_per_direction) + " steps per direction)";
  report += ", " + Fixed(seconds, 2) + " s";
  if (termination != Termination::kSuccess) report += " (" + message + ")";
  return report;
}

OcclusionSummary AmbientOcclusionFromHeight(const AmbientOcclusionOptions& options, const ImageF& height_mm,
                                            ImageF* visibility, const ProgressCallback& progress) {
  options.Check();
  CheckFiniteHeight(height_mm, "AmbientOcclusionFromHeight");
  CheckOutput(visibility, "AmbientOcclusionFromHeight", "visibility");
  const auto start = std::chrono::steady_clock::now();
  OcclusionSummary summary;
  summary.map_name = "ambient occlusion";

  const AzimuthMarches marches = PlanMarches(options);
  const int width = height_mm.width(), rows = height_mm.height();
  ImageF map(width, rows, 1);
  const int threads = ResolveThreadCount(options.num_threads);
  const bool finished = RunRows(rows, std::min(threads, rows), progress,
                                [&](int y) { VisibilityRow(height_mm, y, marches, options, map.row(y)); });

  summary.steps_per_direction = marches.steps;
  summary.radius_px = marches.radius_px;
  summary.seconds = SecondsSince(start);
  if (!finished) {
    summary.SetCancelled("ambient occlusion cancelled by the progress callback");
    *visibility = ImageF();
    return summary;
  }
  FillFigures(map, &summary);
  summary.termination = Termination::kSuccess;
  std::ostringstream text;
  text << "ambient occlusion of " << width << "x" << rows << " px around the "
       << (options.around_pixel_normal ? "pixel" : "table") << " normal: " << options.num_directions
       << " directions x " << marches.steps << " steps out to " << options.radius_mm << " mm (" << marches.radius_px
       << " px); visibility mean " << summary.mean << ", min " << summary.min << ", max " << summary.max << "; "
       << Significant(summary.seconds) << " s";
  summary.message = text.str();
  *visibility = std::move(map);
  return summary;
}

OcclusionSummary CavityFromHeight(const CavityOptions& options, const ImageF& height_mm, ImageF* cavity,
                                  const ProgressCallback& progress) {
  options.Check();
  CheckFiniteHeight(height_mm, "CavityFromHeight");
  CheckOutput(cavity, "CavityFromHeight", "cavity");
  const auto start = std::chrono::steady_clock::now();
  OcclusionSummary summary;
  summary.map_name = "cavity";
  const double sigma_px = options.radius_mm / options.mm_per_pixel;
  summary.radius_px = sigma_px;
  auto cancelled = [&](double fraction) {
    if (!progress || progress(fraction)) return false;
    summary.seconds = SecondsSince(start);
    summary.SetCancelled("cavity cancelled by the progress callback");
    *cavity = ImageF();
    return true;
  };
  if (cancelled(0.0)) return summary;

  const int width = height_mm.width(), rows = height_mm.height();
  // The map is made in the relative heights' buffer, a row at a time: the
  // mean of a row no longer needs the row itself.
  ImageF map = RelativeToLowest(height_mm);
  const cv::Mat relative(rows, width, CV_32F, map.data());
  const int factor = CoarseFactor(sigma_px, options.min_coarse_sigma_px);
  NeighbourhoodMean mean(relative, sigma_px, factor);
  if (cancelled(0.9)) return summary;

  const float inv_scale = static_cast<float>(1.0 / options.depth_scale_mm);
  for (int y = 0; y < rows; ++y) {
    const float* neighbourhood = mean.Row(y);
    float* row = map.row(y);  // relative height in, cavity out
    for (int x = 0; x < width; ++x) {
      const float depth = neighbourhood[x] - row[x];
      row[x] = std::clamp(1.0f - depth * inv_scale, 0.0f, 1.0f);
    }
  }
  FillFigures(map, &summary);
  summary.seconds = SecondsSince(start);
  summary.termination = Termination::kSuccess;
  std::ostringstream text;
  text << "cavity of " << width << "x" << rows << " px: Gaussian sigma " << options.radius_mm << " mm ("
       << sigma_px << " px), 0 at " << options.depth_scale_mm << " mm deep; mean " << summary.mean << ", min "
       << summary.min << ", max " << summary.max << "; " << Significant(summary.seconds) << " s";
  summary.message = text.str();
  *cavity = std::move(map);
  if (progress) progress(1.0);
  return summary;
}

ImageF AdjustOcclusionForAlbedo(const ImageF& visibility, const ImageF& albedo) {
  const char* where = "AdjustOcclusionForAlbedo";
  if (visibility.empty() || visibility.channels() != 1) {
    throw std::invalid_argument(std::string(where) + ": visibility is " + ShapeText(visibility) +
                                ", must be a non-empty 1 channel image");
  }
  if (!albedo.SameSize(visibility) || (albedo.channels() != 1 && albedo.channels() != 3)) {
    throw std::invalid_argument(std::string(where) + ": albedo is " + ShapeText(albedo) + ", must be " +
                                std::to_string(visibility.width()) + "x" + std::to_string(visibility.height()) +
                                " with 1 or 3 channels like visibility " + ShapeText(visibility));
  }
  const int width = visibility.width(), rows = visibility.height();
  ImageF adjusted(width, rows, 1);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < width; ++x) {
      const float a = visibility(x, y);
      // Rec. 709 luminance of linear RGB.
      const float rho = albedo.channels() == 3 ? 0.2126f * albedo(x, y, 0) + 0.7152f * albedo(x, y, 1) +
                                                     0.0722f * albedo(x, y, 2)
                                               : albedo(x, y, 0);
      if (!std::isfinite(a) || !std::isfinite(rho)) {
        std::ostringstream text;
        text << where << ": visibility(" << x << ", " << y << ") = " << a << ", albedo luminance = " << rho
             << "; both must be finite";
        throw std::invalid_argument(text.str());
      }
      const float ac = std::clamp(a, 0.0f, 1.0f), rc = std::clamp(rho, 0.0f, 1.0f);
      // denominator - A = (1 - rho)(1 - A) >= 0, so A' <= 1; it is 0 only for
      // A = 0 and rho = 1, where a white furnace of perfect reflectors gives 1.
      const float denominator = 1.0f - rc + rc * ac;
      adjusted(x, y) = denominator > 0 ? std::clamp(ac / denominator, 0.0f, 1.0f) : 1.0f;
    }
  }
  return adjusted;
}

}  // namespace scanbench
