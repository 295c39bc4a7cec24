#include "solver/photometric_solver.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <Eigen/Dense>

#include "solver/pixel_solvers.h"

namespace scanbench {
namespace {

using Method = PhotometricSolverOptions::Method;

std::invalid_argument OptionError(const std::string& field, const std::string& value, const std::string& rule) {
  return std::invalid_argument("PhotometricSolverOptions." + field + " = " + value + " " + rule);
}

std::invalid_argument InputError(const std::string& what) {
  return std::invalid_argument("photometric solver input: " + what);
}

std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

std::string NumberText(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void CheckSampleMasks(const std::vector<const ImageU8*>& masks, size_t num_images, int width, int height) {
  if (masks.empty()) return;
  if (masks.size() != num_images) {
    throw InputError(std::to_string(masks.size()) + " sample masks for " + std::to_string(num_images) +
                     " images; give one per image or none");
  }
  for (size_t k = 0; k < masks.size(); ++k) {
    const ImageU8* valid = masks[k];
    if (valid == nullptr || valid->channels() != 1 || !valid->SameSize(width, height)) {
      throw InputError("sample mask " + std::to_string(k) + " must be a 1-channel " + SizeText(width, height) +
                       " image");
    }
  }
}

void CheckLightsAndRegion(const LightField* field, size_t num_images, const ImageU8* region, const char* what) {
  if (field == nullptr) throw InputError("light_field is null");
  if (static_cast<int>(num_images) != field->num_lights()) {
    throw InputError(std::to_string(num_images) + " " + what + " but the light field has " +
                     std::to_string(field->num_lights()) + " lights; they must match");
  }
  if (region != nullptr && (region->channels() != 1 || !region->SameSize(field->width(), field->height()))) {
    throw InputError("region must be a 1-channel " + SizeText(field->width(), field->height()) + " image");
  }
}

void CheckImages(const std::vector<const ImageF*>& images, int channels, const LightField& field, const char* what) {
  for (size_t k = 0; k < images.size(); ++k) {
    const ImageF* image = images[k];
    if (image == nullptr) throw InputError(std::string(what) + " " + std::to_string(k) + " is null");
    if (image->channels() != channels) {
      throw InputError(std::string(what) + " " + std::to_string(k) + " has " + std::to_string(image->channels()) +
                       " channels; " + std::to_string(channels) + (channels == 3 ? " (RGB)" : "") + " required");
    }
    if (!image->SameSize(field.width(), field.height())) {
      throw InputError(std::string(what) + " " + std::to_string(k) + " is " +
                       SizeText(image->width(), image->height()) + " but the light field is " +
                       SizeText(field.width(), field.height()));
    }
  }
}

// ---------------------------------------------------------------------------
// What a worker needs to know about the job.
struct Job {
  const PhotometricSolverOptions* options = nullptr;
  const LightField* field = nullptr;
  const std::vector<const ImageF*>* images = nullptr;  // RGB images or mosaics
  const std::vector<const ImageU8*>* sample_valid = nullptr;
  const ImageU8* region = nullptr;
  bool bayer = false;
  std::array<int, 4> cfa_channels{};
  int num_lights = 0;
  bool with_albedo = true;   // RGB albedo solves (never in Bayer mode: the mosaic albedo is the luminance one)
  bool with_confidence = true;
  PhotometricSolution* solution = nullptr;
  ImageF* albedo_mosaic = nullptr;  // Bayer mode: the albedo of each raw pixel's own channel
};

enum class TileLights { kUniform, kInterpolated, kExact };

// Spacing of the nodes the light field is interpolated between, pixels. The
// bilinear error shrinks with its square: 16 px keeps the near-field rig's
// lights within 1e-4 at a quarter of the sensor's resolution.
constexpr int kLightCell = 16;

// Node coordinates from first to last (both included), kLightCell apart.
void GridNodes(int first, int last, std::vector<int>* nodes) {
  nodes->clear();
  for (int v = first; v < last; v += kLightCell) nodes->push_back(v);
  nodes->push_back(last);
}

// Samples of the light field at one point: 3K directions, 3K inverse intensities.
struct LightProbe {
  std::vector<float> dirs, intensities;
  std::vector<float> inv;  // 1 / intensity, 0 where the light is unusable
  bool finite = true;
  bool usable = true;      // every light usable (positive, above min_light_intensity)
};

// Accumulator rows (per pixel) of the normal equations.
enum Acc : int {
  kG00, kG01, kG02, kG11, kG12, kG22,  // Gram matrix
  kB0, kB1, kB2,                       // L^T luminance
  kR0, kR1, kR2, kGr0, kGr1, kGr2, kBl0, kBl1, kBl2,  // L^T red, green, blue
  kCount,
  kNumAcc
};

struct TileResult {
  std::array<size_t, kNumSolvePaths> pixels_by_path{};
};

class TileWorker {
 public:
  explicit TileWorker(const Job& job)
      : job_(job), options_(*job.options), num_lights_(job.num_lights), n_(options_.tile_size) {
    const size_t k3n = static_cast<size_t>(3) * num_lights_ * n_;
    const size_t kn = static_cast<size_t>(num_lights_) * n_;
    dir_.assign(k3n, 0.0f);
    inv_.assign(k3n, 0.0f);
    lum_.assign(kn, 0.0f);
    rgb_.assign(k3n, 0.0f);
    ok_.assign(kn, 0.0f);
    ones_.assign(n_, 1);
    planes_.assign(static_cast<size_t>(4) * n_, 0.0f);
    all_lights_condition_.assign(n_, 0.0);
    acc_.assign(static_cast<size_t>(kNumAcc) * n_, 0.0);
    scaled_.assign(static_cast<size_t>(3) * n_, 0.0);
    residual2_.assign(n_, 0.0);
    light_bad_.assign(n_, 0);
    clipped_.assign(n_, 0.0f);
    uniform_dir_.assign(3 * num_lights_, 0.0f);
    uniform_inv_.assign(3 * num_lights_, 0.0f);
    Resize(&probe_);
    Resize(&interpolated_);
    Resize(&truth_);
    samples_.Reserve(num_lights_);
  }

  void SolveTile(int x0, int y0, int x1, int y1, TileResult* result);

 private:
  void Resize(LightProbe* probe) const {
    probe->dirs.assign(3 * num_lights_, 0.0f);
    probe->intensities.assign(3 * num_lights_, 0.0f);
    probe->inv.assign(3 * num_lights_, 0.0f);
  }
  void Probe(int x, int y, LightProbe* probe) const;
  TileLights ClassifyTile(int x0, int y0, int x1, int y1);
  void FillLights(TileLights mode, int x0, int x1, int y);
  template <bool kUniform, bool kBayer, bool kAlbedo>
  void Accumulate(int x0, int count, int y);
  void SolveSpan(TileLights mode, int x0, int count, int y, TileResult* result);
  void GatherSamples(TileLights mode, int i, int x);
  void StoreFit(const PixelFit& fit, int x, int y, SolvePath path, TileResult* result);

  const Job& job_;
  const PhotometricSolverOptions& options_;
  const int num_lights_;
  const int n_;
  // Per light, per pixel of the span: [(3k + c) * n + i] or [k * n + i].
  std::vector<float> dir_, inv_, lum_, rgb_;
  std::vector<float> ok_;          // 1 where the sample is used, else 0
  std::vector<uint8_t> ones_;      // stands in for a missing sample mask
  std::vector<float> planes_;      // one light's R, G, B and validity for the span, planar
  std::vector<double> acc_;        // [a * n + i]
  std::vector<double> scaled_;     // luminance scaled normal, [c * n + i]
  std::vector<double> residual2_;  // sum of squared residuals
  std::vector<uint8_t> light_bad_; // non-finite light at the pixel
  std::vector<float> clipped_;     // 1 where a sample was marked invalid (clipped)
  std::vector<float> uniform_dir_, uniform_inv_;
  // Interpolated tiles: the light field at a grid of nodes kLightCell apart.
  std::vector<int> node_x_, node_y_;
  std::vector<LightProbe> nodes_;
  std::vector<double> node_condition_;        // condition number of all lights at each node
  std::vector<double> all_lights_condition_;  // interpolated along the span's row
  LightProbe probe_, interpolated_, truth_;
  std::vector<PixelFit> fits_;
  // Uniform tile: the shared light matrix when every usable light is used.
  int uniform_usable_ = 0;
  Eigen::Matrix3d uniform_inverse_ = Eigen::Matrix3d::Identity();
  double uniform_condition_ = 0;
  PixelSamples samples_;
};

void TileWorker::Probe(int x, int y, LightProbe* probe) const {
  job_.field->Evaluate(x, y, probe->dirs.data(), probe->intensities.data());
  const auto& w = options_.luminance_weights;
  probe->finite = true;
  probe->usable = true;
  for (int k = 0; k < num_lights_; ++k) {
    const float* d = &probe->dirs[3 * k];
    const float* in = &probe->intensities[3 * k];
    bool finite = true;
    for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(d[c]) && std::isfinite(in[c]);
    const double luminance_intensity = w[0] * in[0] + w[1] * in[1] + w[2] * in[2];
    bool usable = finite && luminance_intensity >= options_.min_light_intensity;
    if (job_.bayer) {
      // Each raw pixel needs only its own channel; a light dark in one channel
      // is still unusable there (checked per channel below).
      usable = finite;
    } else {
      usable = usable && in[0] > 0 && in[1] > 0 && in[2] > 0;
    }
    for (int c = 0; c < 3; ++c) {
      const bool channel_usable = usable && in[c] > 0 && in[c] >= options_.min_light_intensity;
      probe->inv[3 * k + c] = channel_usable ? 1.0f / in[c] : 0.0f;
      probe->usable = probe->usable && channel_usable;
    }
    probe->finite = probe->finite && finite;
  }
}

TileLights TileWorker::ClassifyTile(int x0, int y0, int x1, int y1) {
  const Method method = options_.method;
  const bool may_share = method == Method::kAdaptive || method == Method::kUniformPseudoInverse;
  if (!may_share) return TileLights::kExact;
  const int xa = x0, xb = x1 - 1, ya = y0, yb = y1 - 1;
  const int xm = (xa + xb) / 2, ym = (ya + yb) / 2;
  Probe(xm, ym, &probe_);
  if (!probe_.finite) return TileLights::kExact;
  if (job_.field->IsUniform() || method == Method::kUniformPseudoInverse) {
    uniform_dir_ = probe_.dirs;
    uniform_inv_ = probe_.inv;
    return TileLights::kUniform;
  }
  const double tolerance = options_.light_tolerance;
  if (!(tolerance > 0) || !probe_.usable) return TileLights::kExact;
  GridNodes(xa, xb, &node_x_);
  GridNodes(ya, yb, &node_y_);
  const int nx = static_cast<int>(node_x_.size()), ny = static_cast<int>(node_y_.size());
  if (static_cast<int>(nodes_.size()) < nx * ny) {
    nodes_.resize(nx * ny);
    for (LightProbe& node : nodes_) {
      if (node.dirs.size() != static_cast<size_t>(3 * num_lights_)) Resize(&node);
    }
  }
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      LightProbe& node = nodes_[j * nx + i];
      Probe(node_x_[i], node_y_[j], &node);
      if (!node.finite || !node.usable) return TileLights::kExact;
    }
  }
  // Difference of two probes: direction (radians, small angle) and relative intensity.
  auto differs = [&](const LightProbe& a, const std::vector<float>& dirs, const std::vector<float>& inv) {
    for (int j = 0; j < 3 * num_lights_; j += 3) {
      const double dx = a.dirs[j] - dirs[j], dy = a.dirs[j + 1] - dirs[j + 1], dz = a.dirs[j + 2] - dirs[j + 2];
      if (!(std::sqrt(dx * dx + dy * dy + dz * dz) <= tolerance)) return true;
      for (int c = 0; c < 3; ++c) {
        if (!(std::abs(a.inv[j + c] - inv[j + c]) <= tolerance * a.inv[j + c])) return true;
      }
    }
    return false;
  };
  bool uniform = true;
  for (int n = 0; n < nx * ny && uniform; ++n) uniform = !differs(probe_, nodes_[n].dirs, nodes_[n].inv);
  if (uniform) {
    uniform_dir_ = probe_.dirs;
    uniform_inv_ = probe_.inv;
    return TileLights::kUniform;
  }
  // Bilinear interpolation between the nodes, checked against the exact field
  // in every cell: at its centre and the middle of its top and left edges
  // (and of the bottom and right edges of the last row and column of cells).
  for (int j = 0; j + 1 < std::max(2, ny); ++j) {
    for (int i = 0; i + 1 < std::max(2, nx); ++i) {
      const int i1 = std::min(i + 1, nx - 1), j1 = std::min(j + 1, ny - 1);
      const int cx0 = node_x_[i], cx1 = node_x_[i1], cy0 = node_y_[j], cy1 = node_y_[j1];
      const int mx = (cx0 + cx1) / 2, my = (cy0 + cy1) / 2;
      int points[5][2] = {{mx, my}, {mx, cy0}, {cx0, my}, {-1, -1}, {-1, -1}};
      if (j1 == ny - 1) points[3][0] = mx, points[3][1] = cy1;
      if (i1 == nx - 1) points[4][0] = cx1, points[4][1] = my;
      const LightProbe* corner[4] = {&nodes_[j * nx + i], &nodes_[j * nx + i1], &nodes_[j1 * nx + i],
                                     &nodes_[j1 * nx + i1]};
      for (const auto& point : points) {
        if (point[0] < 0) continue;
        const double fx = cx1 > cx0 ? double(point[0] - cx0) / (cx1 - cx0) : 0.0;
        const double fy = cy1 > cy0 ? double(point[1] - cy0) / (cy1 - cy0) : 0.0;
        const double weights[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
        for (int q = 0; q < 3 * num_lights_; ++q) {
          double dir = 0, inv = 0;
          for (int c = 0; c < 4; ++c) {
            dir += weights[c] * corner[c]->dirs[q];
            inv += weights[c] * corner[c]->inv[q];
          }
          interpolated_.dirs[q] = static_cast<float>(dir);
          interpolated_.inv[q] = static_cast<float>(inv);
        }
        Probe(point[0], point[1], &truth_);
        if (!truth_.finite || !truth_.usable || differs(truth_, interpolated_.dirs, interpolated_.inv)) {
          return TileLights::kExact;
        }
      }
    }
  }
  // The condition number of all lights at each node: pixels that use every
  // light take it interpolated (it varies as smoothly as the lights do).
  node_condition_.resize(nx * ny);
  for (int q = 0; q < nx * ny; ++q) {
    double g[6] = {0, 0, 0, 0, 0, 0};
    const std::vector<float>& d = nodes_[q].dirs;
    for (int k = 0; k < num_lights_; ++k) {
      const double x = d[3 * k], y = d[3 * k + 1], z = d[3 * k + 2];
      g[0] += x * x, g[1] += x * y, g[2] += x * z, g[3] += y * y, g[4] += y * z, g[5] += z * z;
    }
    node_condition_[q] = ConditionNumberFromGram(g[0], g[1], g[2], g[3], g[4], g[5]);
  }
  return TileLights::kInterpolated;
}

void TileWorker::FillLights(TileLights mode, int x0, int x1, int y) {
  const int count = x1 - x0;
  std::fill(light_bad_.begin(), light_bad_.begin() + count, 0);
  if (mode == TileLights::kUniform) return;
  const int n = n_;
  if (mode == TileLights::kInterpolated) {
    // Between two node rows bilinear interpolation is linear in x within
    // each cell: fill every cell's stretch of the row from its two ends.
    const int nx = static_cast<int>(node_x_.size()), ny = static_cast<int>(node_y_.size());
    int j = 0;
    while (j + 2 < ny && node_y_[j + 1] <= y) ++j;
    const int j1 = std::min(j + 1, ny - 1);
    const double fy = node_y_[j1] > node_y_[j] ? double(y - node_y_[j]) / (node_y_[j1] - node_y_[j]) : 0.0;
    for (int i = 0; i + 1 < std::max(2, nx); ++i) {
      const int i1 = std::min(i + 1, nx - 1);
      const int xa = node_x_[i], xb = node_x_[i1];
      const int end = i1 == nx - 1 ? xb + 1 : xb;  // the last cell includes its right node
      const double step_scale = xb > xa ? 1.0 / (xb - xa) : 0.0;
      const LightProbe& top_left = nodes_[j * nx + i];
      const LightProbe& top_right = nodes_[j * nx + i1];
      const LightProbe& bottom_left = nodes_[j1 * nx + i];
      const LightProbe& bottom_right = nodes_[j1 * nx + i1];
      {
        const double left = (1 - fy) * node_condition_[j * nx + i] + fy * node_condition_[j1 * nx + i];
        const double right = (1 - fy) * node_condition_[j * nx + i1] + fy * node_condition_[j1 * nx + i1];
        double* __restrict condition = &all_lights_condition_[xa - x0];
        for (int t = 0; t < end - xa; ++t) condition[t] = left + (right - left) * step_scale * t;
      }
      for (int q = 0; q < 3 * num_lights_; ++q) {
        const double dir_left = (1 - fy) * top_left.dirs[q] + fy * bottom_left.dirs[q];
        const double dir_right = (1 - fy) * top_right.dirs[q] + fy * bottom_right.dirs[q];
        const double inv_left = (1 - fy) * top_left.inv[q] + fy * bottom_left.inv[q];
        const double inv_right = (1 - fy) * top_right.inv[q] + fy * bottom_right.inv[q];
        const float dir_step = static_cast<float>((dir_right - dir_left) * step_scale);
        const float inv_step = static_cast<float>((inv_right - inv_left) * step_scale);
        const float dir_start = static_cast<float>(dir_left), inv_start = static_cast<float>(inv_left);
        float* __restrict dir = &dir_[static_cast<size_t>(q) * n + (xa - x0)];
        float* __restrict inv = &inv_[static_cast<size_t>(q) * n + (xa - x0)];
        for (int t = 0; t < end - xa; ++t) {
          dir[t] = dir_start + dir_step * static_cast<float>(t);
          inv[t] = inv_start + inv_step * static_cast<float>(t);
        }
      }
    }
    return;
  }
  for (int i = 0; i < count; ++i) {
    Probe(x0 + i, y, &probe_);
    if (!probe_.finite) light_bad_[i] = 1;
    for (int j = 0; j < 3 * num_lights_; ++j) {
      const bool good = probe_.finite;
      dir_[static_cast<size_t>(j) * n + i] = good ? probe_.dirs[j] : 0.0f;
      inv_[static_cast<size_t>(j) * n + i] = good ? probe_.inv[j] : 0.0f;
    }
  }
}

// Per-light constants of the hot loop (uniform lights, weights, threshold).
struct SpanConstants {
  float w0, w1, w2;                 // luminance weights
  float threshold;                  // shadow level; -infinity keeps every finite sample
  float ud0, ud1, ud2;              // uniform tile: light direction
  float ui0, ui1, ui2;              // uniform tile: 1 / intensity per channel
  float ui_even, ui_odd;            // uniform tile, Bayer: 1 / intensity of even / odd columns
};

// The hot loop for one light over a span of pixels: divide the samples by the
// light, decide whether they are usable and add them to the normal equations.
// A free function with restrict-qualified parameters and no branches (selects
// only), so that the compiler proves the arrays independent and vectorises.
template <bool kUniform, bool kBayer, bool kAlbedo>
void AccumulateLightSpan(int count, const SpanConstants c, const float* __restrict plane0,
                         const float* __restrict plane1, const float* __restrict plane2,
                         const float* __restrict valid, const float* __restrict dx, const float* __restrict dy,
                         const float* __restrict dz, const float* __restrict i0, const float* __restrict i1,
                         const float* __restrict i2, const float* __restrict i_even, const float* __restrict i_odd,
                         float* __restrict clipped, float* __restrict lum, float* __restrict ok,
                         float* __restrict red, float* __restrict green, float* __restrict blue,
                         double* __restrict g00, double* __restrict g01, double* __restrict g02,
                         double* __restrict g11, double* __restrict g12, double* __restrict g22,
                         double* __restrict b0, double* __restrict b1, double* __restrict b2,
                         double* __restrict used, double* __restrict rr0, double* __restrict rr1,
                         double* __restrict rr2, double* __restrict gg0, double* __restrict gg1,
                         double* __restrict gg2, double* __restrict bb0, double* __restrict bb1,
                         double* __restrict bb2) {
  for (int i = 0; i < count; ++i) {
    const float d0 = kUniform ? c.ud0 : dx[i];
    const float d1 = kUniform ? c.ud1 : dy[i];
    const float d2 = kUniform ? c.ud2 : dz[i];
    float raw, divided, r = 0, g = 0, b = 0;
    float usable;  // 1 or 0
    if constexpr (kBayer) {
      const float sample = plane0[i];
      const float odd = static_cast<float>(i & 1);
      const float inverse =
          kUniform ? c.ui_even + odd * (c.ui_odd - c.ui_even) : i_even[i] + odd * (i_odd[i] - i_even[i]);
      raw = sample;
      divided = sample * inverse;
      usable = (sample - sample == 0.0f && inverse > 0.0f) ? 1.0f : 0.0f;
    } else {
      const float s0 = plane0[i], s1 = plane1[i], s2 = plane2[i];
      const float v0 = kUniform ? c.ui0 : i0[i];
      const float v1 = kUniform ? c.ui1 : i1[i];
      const float v2 = kUniform ? c.ui2 : i2[i];
      r = s0 * v0;
      g = s1 * v1;
      b = s2 * v2;
      raw = c.w0 * s0 + c.w1 * s1 + c.w2 * s2;
      divided = c.w0 * r + c.w1 * g + c.w2 * b;
      usable = (raw - raw == 0.0f && v0 > 0.0f && v1 > 0.0f && v2 > 0.0f) ? 1.0f : 0.0f;
    }
    const float marked_valid = valid[i];
    clipped[i] = std::max(clipped[i], 1.0f - marked_valid);
    const float weight = raw > c.threshold ? usable * marked_valid : 0.0f;
    const float lum_used = weight > 0.0f ? divided : 0.0f;
    const double wd0 = weight * d0, wd1 = weight * d1, wd2 = weight * d2;
    g00[i] += wd0 * d0;
    g01[i] += wd0 * d1;
    g02[i] += wd0 * d2;
    g11[i] += wd1 * d1;
    g12[i] += wd1 * d2;
    g22[i] += wd2 * d2;
    b0[i] += double(d0) * lum_used;
    b1[i] += double(d1) * lum_used;
    b2[i] += double(d2) * lum_used;
    used[i] += weight;
    lum[i] = lum_used;
    ok[i] = weight;
    if constexpr (kAlbedo) {
      const float r_used = weight > 0.0f ? r : 0.0f, g_used = weight > 0.0f ? g : 0.0f;
      const float b_used = weight > 0.0f ? b : 0.0f;
      red[i] = r_used;
      green[i] = g_used;
      blue[i] = b_used;
      rr0[i] += double(d0) * r_used;
      rr1[i] += double(d1) * r_used;
      rr2[i] += double(d2) * r_used;
      gg0[i] += double(d0) * g_used;
      gg1[i] += double(d1) * g_used;
      gg2[i] += double(d2) * g_used;
      bb0[i] += double(d0) * b_used;
      bb1[i] += double(d1) * b_used;
      bb2[i] += double(d2) * b_used;
    }
  }
}

// All lights of one span: planar copies of each light's samples (the hot loop
// then reads unit-stride floats only), then the hot loop.
template <bool kUniform, bool kBayer, bool kAlbedo>
void TileWorker::Accumulate(int x0, int count, int y) {
  const int n = n_;
  std::fill(acc_.begin(), acc_.end(), 0.0);
  std::fill(clipped_.begin(), clipped_.begin() + count, 0.0f);
  SpanConstants c{};
  c.w0 = static_cast<float>(options_.luminance_weights[0]);
  c.w1 = static_cast<float>(options_.luminance_weights[1]);
  c.w2 = static_cast<float>(options_.luminance_weights[2]);
  // With no shadow level every finite sample counts (also 0 and negatives).
  c.threshold = options_.min_sample_value > 0 ? static_cast<float>(options_.min_sample_value)
                                              : -std::numeric_limits<float>::infinity();
  // Bayer: the colour channel of even and odd columns of this row.
  const int even_channel = job_.cfa_channels[(y & 1) * 2 + (x0 & 1)];
  const int odd_channel = job_.cfa_channels[(y & 1) * 2 + ((x0 + 1) & 1)];
  // The next row of every light's span is a separate short run in memory,
  // too short for the hardware prefetcher: ask for it now, use it next row.
  if (y + 1 < job_.field->height()) {
    const size_t bytes = static_cast<size_t>(count) * (kBayer ? 1 : 3) * sizeof(float);
    for (int k = 0; k < num_lights_; ++k) {
      const char* next = reinterpret_cast<const char*>((*job_.images)[k]->row(y + 1) + static_cast<size_t>(x0) * (kBayer ? 1 : 3));
      for (size_t offset = 0; offset < bytes; offset += 64) __builtin_prefetch(next + offset);
    }
  }
  double* acc = acc_.data();
  float* plane0 = planes_.data();
  float* plane1 = planes_.data() + n;
  float* plane2 = planes_.data() + 2 * n;
  float* valid = planes_.data() + 3 * n;
  for (int k = 0; k < num_lights_; ++k) {
    const float* pixels = (*job_.images)[k]->row(y) + static_cast<size_t>(x0) * (kBayer ? 1 : 3);
    const uint8_t* marks = job_.sample_valid->empty() ? ones_.data() : (*job_.sample_valid)[k]->row(y) + x0;
    if constexpr (kBayer) {
      std::copy(pixels, pixels + count, plane0);
    } else {
      for (int i = 0; i < count; ++i) {
        plane0[i] = pixels[3 * i];
        plane1[i] = pixels[3 * i + 1];
        plane2[i] = pixels[3 * i + 2];
      }
    }
    for (int i = 0; i < count; ++i) valid[i] = marks[i] != 0 ? 1.0f : 0.0f;
    c.ud0 = uniform_dir_[3 * k], c.ud1 = uniform_dir_[3 * k + 1], c.ud2 = uniform_dir_[3 * k + 2];
    c.ui0 = uniform_inv_[3 * k], c.ui1 = uniform_inv_[3 * k + 1], c.ui2 = uniform_inv_[3 * k + 2];
    c.ui_even = uniform_inv_[3 * k + even_channel], c.ui_odd = uniform_inv_[3 * k + odd_channel];
    auto light = [&](int channel) { return &dir_[static_cast<size_t>(3 * k + channel) * n]; };
    auto inverse = [&](int channel) { return &inv_[static_cast<size_t>(3 * k + channel) * n]; };
    auto rgb = [&](int channel) { return &rgb_[static_cast<size_t>(3 * k + channel) * n]; };
    auto sum = [&](int row) { return acc + static_cast<size_t>(row) * n; };
    AccumulateLightSpan<kUniform, kBayer, kAlbedo>(
        count, c, plane0, plane1, plane2, valid, light(0), light(1), light(2), inverse(0), inverse(1), inverse(2),
        inverse(even_channel), inverse(odd_channel), clipped_.data(), &lum_[static_cast<size_t>(k) * n],
        &ok_[static_cast<size_t>(k) * n], rgb(0), rgb(1), rgb(2), sum(kG00), sum(kG01), sum(kG02), sum(kG11),
        sum(kG12), sum(kG22), sum(kB0), sum(kB1), sum(kB2), sum(kCount), sum(kR0), sum(kR1), sum(kR2), sum(kGr0),
        sum(kGr1), sum(kGr2), sum(kBl0), sum(kBl1), sum(kBl2));
  }
}

void TileWorker::GatherSamples(TileLights mode, int i, int x) {
  const int n = n_;
  samples_.Clear();
  const bool with_rgb = job_.with_albedo && !job_.bayer;
  for (int k = 0; k < num_lights_; ++k) {
    const size_t at = static_cast<size_t>(k) * n + i;
    if (!(ok_[at] > 0)) continue;
    double d[3];
    for (int c = 0; c < 3; ++c) {
      d[c] = mode == TileLights::kUniform ? uniform_dir_[3 * k + c] : dir_[static_cast<size_t>(3 * k + c) * n + i];
    }
    const double value = lum_[at];
    double rgb[3] = {0, 0, 0};
    if (with_rgb) {
      for (int c = 0; c < 3; ++c) rgb[c] = rgb_[static_cast<size_t>(3 * k + c) * n + i];
    }
    samples_.Add(d[0], d[1], d[2], value, rgb[0], rgb[1], rgb[2]);
  }
  (void)x;
}

void TileWorker::StoreFit(const PixelFit& fit, int x, int y, SolvePath path, TileResult* result) {
  PhotometricSolution& s = *job_.solution;
  for (int c = 0; c < 3; ++c) s.normal_in_table(x, y, c) = static_cast<float>(fit.normal[c]);
  const bool solved = fit.status == PixelStatus::kSolved;
  if (job_.bayer) {
    (*job_.albedo_mosaic)(x, y) = solved ? static_cast<float>(fit.luminance_albedo) : 0.0f;
  } else if (job_.with_albedo) {
    for (int c = 0; c < 3; ++c) s.albedo(x, y, c) = solved ? static_cast<float>(fit.albedo[c]) : 0.0f;
  }
  s.status(x, y) = static_cast<uint8_t>(fit.status);
  s.lights_used(x, y) = static_cast<uint8_t>(std::clamp(fit.lights_used, 0, 255));
  if (job_.with_confidence) {
    s.condition_number(x, y) = static_cast<float>(std::min(fit.condition_number, double(std::numeric_limits<float>::max())));
    s.residual(x, y) = solved ? static_cast<float>(std::min(fit.residual, 1e30)) : 0.0f;
  }
  const SolvePath stored = solved ? path : SolvePath::kNone;
  s.solve_path(x, y) = static_cast<uint8_t>(stored);
  ++result->pixels_by_path[static_cast<int>(stored)];
}

void TileWorker::SolveSpan(TileLights mode, int x0, int count, int y, TileResult* result) {
  const int n = n_;
  const Method method = options_.method;
  const PixelFitLimits limits{options_.min_lights, options_.max_condition_number, options_.min_albedo};
  const bool with_albedo = job_.with_albedo && !job_.bayer;
  const uint8_t* region = job_.region != nullptr ? job_.region->row(y) + x0 : nullptr;
  const SolvePath light_path = mode == TileLights::kUniform        ? SolvePath::kSharedLights
                               : mode == TileLights::kInterpolated ? SolvePath::kInterpolatedLights
                                                                   : SolvePath::kExactLights;
  RobustFitOptions robust;
  robust.loss = options_.robust_loss;
  robust.width = options_.robust_loss_width;
  robust.min_scale = options_.robust_min_scale;
  robust.max_iterations = options_.robust_max_iterations;
  robust.dark_fraction = options_.robust_dark_fraction;

  const bool dense = method == Method::kJacobiSvd || method == Method::kQr || method == Method::kRobustIrls ||
                     method == Method::kSparseBayesian;
  if (dense) {
    for (int i = 0; i < count; ++i) {
      const int x = x0 + i;
      if (region != nullptr && region[i] == 0) continue;
      PixelFit fit;
      if (light_bad_[i]) {
        fit.status = PixelStatus::kInvalidInput;
      } else {
        GatherSamples(mode, i, x);
        switch (method) {
          case Method::kJacobiSvd: fit = FitLeastSquares(DenseMethod::kJacobiSvd, samples_, with_albedo, limits); break;
          case Method::kQr: fit = FitLeastSquares(DenseMethod::kQr, samples_, with_albedo, limits); break;
          case Method::kRobustIrls: fit = FitRobustIrls(samples_, with_albedo, limits, robust); break;
          default: fit = FitSparseBayesian(samples_, with_albedo, limits, robust); break;
        }
      }
      const bool robust_path = method == Method::kRobustIrls || method == Method::kSparseBayesian;
      StoreFit(fit, x, y, robust_path ? SolvePath::kRobust : light_path, result);
    }
    return;
  }

  // Normal equations from the accumulators, pixel by pixel.
  const double* acc = acc_.data();
  std::vector<PixelFit>& fits = fits_;
  fits.assign(count, PixelFit());
  for (int i = 0; i < count; ++i) {
    PixelFit& fit = fits[i];
    scaled_[i] = scaled_[n + i] = scaled_[2 * n + i] = 0;
    if (region != nullptr && region[i] == 0) continue;
    if (light_bad_[i]) {
      fit.status = PixelStatus::kInvalidInput;
      continue;
    }
    const int used = static_cast<int>(acc[kCount * n + i]);
    fit.lights_used = used;
    if (used < std::max(3, options_.min_lights)) {
      fit.status = PixelStatus::kTooFewLights;
      continue;
    }
    const double g00 = acc[kG00 * n + i], g01 = acc[kG01 * n + i], g02 = acc[kG02 * n + i];
    const double g11 = acc[kG11 * n + i], g12 = acc[kG12 * n + i], g22 = acc[kG22 * n + i];
    Eigen::Matrix3d inverse;
    if (mode == TileLights::kUniform && used == uniform_usable_) {
      fit.condition_number = uniform_condition_;
      inverse = uniform_inverse_;
    } else {
      // Interpolated tiles have every light usable: a pixel using them all
      // has the interpolated condition number of the nodes.
      fit.condition_number = mode == TileLights::kInterpolated && used == num_lights_
                                 ? all_lights_condition_[i]
                                 : ConditionNumberFromGram(g00, g01, g02, g11, g12, g22);
      if (fit.condition_number <= options_.max_condition_number) {
        // Closed-form inverse through the cofactors.
        const double c00 = g11 * g22 - g12 * g12, c01 = g02 * g12 - g01 * g22, c02 = g01 * g12 - g02 * g11;
        const double c11 = g00 * g22 - g02 * g02, c12 = g01 * g02 - g00 * g12, c22 = g00 * g11 - g01 * g01;
        const double det = g00 * c00 + g01 * c01 + g02 * c02;
        const double inv_det = 1.0 / det;
        inverse << c00, c01, c02, c01, c11, c12, c02, c12, c22;
        inverse *= inv_det;
      }
    }
    if (!(fit.condition_number <= options_.max_condition_number)) {
      fit.status = PixelStatus::kIllConditioned;
      fit.condition_number = std::min(fit.condition_number, double(std::numeric_limits<float>::max()));
      continue;
    }
    const Eigen::Vector3d scaled = inverse * Eigen::Vector3d(acc[kB0 * n + i], acc[kB1 * n + i], acc[kB2 * n + i]);
    const double length = scaled.norm();
    if (!std::isfinite(length) || !(length >= options_.min_albedo) || length == 0) {
      fit.status = PixelStatus::kNoSignal;
      continue;
    }
    if (!(scaled.z() > 0)) {
      fit.status = PixelStatus::kFacingAway;
      continue;
    }
    fit.status = PixelStatus::kSolved;
    fit.normal = scaled / length;
    fit.luminance_albedo = length;
    for (int c = 0; c < 3; ++c) scaled_[c * n + i] = scaled[c];
    if (with_albedo) {
      for (int c = 0; c < 3; ++c) {
        const int row = kR0 + 3 * c;
        const Eigen::Vector3d channel =
            inverse * Eigen::Vector3d(acc[row * n + i], acc[(row + 1) * n + i], acc[(row + 2) * n + i]);
        fit.albedo[c] = channel.norm();
      }
    }
  }

  // Residuals: a second pass over the samples (exact, no cancellation).
  const bool adaptive = method == Method::kAdaptive;
  if (job_.with_confidence || adaptive) {
    std::fill(residual2_.begin(), residual2_.begin() + count, 0.0);
    const double* s0 = &scaled_[0];
    const double* s1 = &scaled_[n];
    const double* s2 = &scaled_[2 * n];
    double* __restrict residual2 = residual2_.data();
    for (int k = 0; k < num_lights_; ++k) {
      const float* lum = &lum_[static_cast<size_t>(k) * n];
      const float* ok = &ok_[static_cast<size_t>(k) * n];
      const float* dx = &dir_[static_cast<size_t>(3 * k + 0) * n];
      const float* dy = &dir_[static_cast<size_t>(3 * k + 1) * n];
      const float* dz = &dir_[static_cast<size_t>(3 * k + 2) * n];
      const double ud0 = uniform_dir_[3 * k], ud1 = uniform_dir_[3 * k + 1], ud2 = uniform_dir_[3 * k + 2];
      if (mode == TileLights::kUniform) {
        for (int i = 0; i < count; ++i) {
          const double r = ud0 * s0[i] + ud1 * s1[i] + ud2 * s2[i] - lum[i];
          residual2[i] += ok[i] * (r * r);
        }
      } else {
        for (int i = 0; i < count; ++i) {
          const double r = dx[i] * s0[i] + dy[i] * s1[i] + dz[i] * s2[i] - lum[i];
          residual2[i] += ok[i] * (r * r);
        }
      }
    }
    for (int i = 0; i < count; ++i) {
      PixelFit& fit = fits[i];
      if (fit.status != PixelStatus::kSolved) continue;
      fit.residual = std::sqrt(residual2_[i] / std::max(1, fit.lights_used)) / fit.luminance_albedo;
    }
  }

  for (int i = 0; i < count; ++i) {
    if (region != nullptr && region[i] == 0) continue;
    const int x = x0 + i;
    PixelFit& fit = fits[i];
    const bool wants_robust = adaptive && !light_bad_[i] &&
                              (clipped_[i] > 0 || (fit.status == PixelStatus::kSolved &&
                                               fit.residual > options_.adaptive_robust_residual));
    if (wants_robust) {
      GatherSamples(mode, i, x);
      const PixelFit refit = FitRobustIrls(samples_, with_albedo, limits, robust);
      if (refit.status == PixelStatus::kSolved || fit.status != PixelStatus::kSolved) {
        StoreFit(refit, x, y, SolvePath::kRobust, result);
        continue;
      }
    }
    StoreFit(fit, x, y, light_path, result);
  }
}

void TileWorker::SolveTile(int x0, int y0, int x1, int y1, TileResult* result) {
  const TileLights mode = ClassifyTile(x0, y0, x1, y1);
  if (mode == TileLights::kUniform) {
    // The shared light matrix of every usable light.
    Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
    uniform_usable_ = 0;
    bool partly_usable = false;
    for (int k = 0; k < num_lights_; ++k) {
      const int lit = (uniform_inv_[3 * k] > 0) + (uniform_inv_[3 * k + 1] > 0) + (uniform_inv_[3 * k + 2] > 0);
      // Bayer pixels use a light lit in their own channel only: the shared
      // matrix then would not match every pixel's set of lights.
      partly_usable = partly_usable || (lit > 0 && lit < 3);
      if (lit < 3) continue;
      const Eigen::Vector3d d(uniform_dir_[3 * k], uniform_dir_[3 * k + 1], uniform_dir_[3 * k + 2]);
      gram += d * d.transpose();
      ++uniform_usable_;
    }
    uniform_condition_ = ConditionNumberFromGram(gram);
    uniform_inverse_ = gram.inverse();
    if (!uniform_inverse_.allFinite() || (job_.bayer && partly_usable)) uniform_usable_ = -1;  // never shared
  }
  for (int y = y0; y < y1; ++y) {
    // Rows of the tile with no pixel in the region cost nothing.
    if (job_.region != nullptr) {
      const uint8_t* row = job_.region->row(y);
      if (std::all_of(row + x0, row + x1, [](uint8_t v) { return v == 0; })) continue;
    }
    FillLights(mode, x0, x1, y);
    const int count = x1 - x0;
    const bool uniform = mode == TileLights::kUniform;
    if (job_.bayer) {
      uniform ? Accumulate<true, true, false>(x0, count, y) : Accumulate<false, true, false>(x0, count, y);
    } else if (job_.with_albedo) {
      uniform ? Accumulate<true, false, true>(x0, count, y) : Accumulate<false, false, true>(x0, count, y);
    } else {
      uniform ? Accumulate<true, false, false>(x0, count, y) : Accumulate<false, false, false>(x0, count, y);
    }
    SolveSpan(mode, x0, count, y, result);
  }
}

// ---------------------------------------------------------------------------
// Bilinear demosaic of the per-raw-pixel albedo: a pixel's own channel is its
// own value; the others average the solved neighbours of that channel in the
// 3x3 window (0 when none is solved).
void DemosaicAlbedo(const ImageF& mosaic, const ImageU8& status, const std::array<int, 4>& cfa, ImageF* albedo) {
  const int width = mosaic.width(), height = mosaic.height();
  *albedo = ImageF(width, height, 3, 0.0f);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (status(x, y) != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
      double sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
          if (status(xx, yy) != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
          const int c = cfa[(yy & 1) * 2 + (xx & 1)];
          sum[c] += mosaic(xx, yy);
          ++count[c];
        }
      }
      const int own = cfa[(y & 1) * 2 + (x & 1)];
      for (int c = 0; c < 3; ++c) {
        (*albedo)(x, y, c) = c == own ? mosaic(x, y) : (count[c] > 0 ? static_cast<float>(sum[c] / count[c]) : 0.0f);
      }
    }
  }
}

// The largest difference (radians / relative) between the light field at the
// image's corners and centre: how far from uniform it is.
double LightFieldSpread(const LightField& field) {
  const int k3 = 3 * field.num_lights();
  std::vector<float> centre_dirs(k3), centre_int(k3), dirs(k3), intensities(k3);
  const int w = field.width() - 1, h = field.height() - 1;
  field.Evaluate(w / 2, h / 2, centre_dirs.data(), centre_int.data());
  double spread = 0;
  const int points[4][2] = {{0, 0}, {w, 0}, {0, h}, {w, h}};
  for (const auto& point : points) {
    field.Evaluate(point[0], point[1], dirs.data(), intensities.data());
    for (int j = 0; j < k3; ++j) {
      spread = std::max(spread, double(std::abs(dirs[j] - centre_dirs[j])));
      if (centre_int[j] > 0) spread = std::max(spread, std::abs(intensities[j] - centre_int[j]) / double(centre_int[j]));
    }
  }
  return spread;
}

PhotometricSolverSummary RunSolve(const PhotometricSolverOptions& options, Job job, const ProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  const LightField& field = *job.field;
  const int width = field.width();
  const int height = field.height();
  if (options.method == Method::kUniformPseudoInverse && !field.IsUniform()) {
    const double spread = LightFieldSpread(field);
    if (!(spread <= options.light_tolerance)) {
      throw InputError("method uniform_pinv needs a uniform light field (distant lights); this one varies by " +
                       NumberText(spread) + " over the image, more than light_tolerance = " +
                       NumberText(options.light_tolerance) + ": use adaptive or normal_equations");
    }
  }
  PhotometricSolution* solution = job.solution;
  solution->normal_in_table = ImageF(width, height, 3, 0.0f);
  for (size_t i = 0; i < solution->normal_in_table.num_pixels(); ++i) solution->normal_in_table.data()[3 * i + 2] = 1;
  solution->albedo = job.with_albedo ? ImageF(width, height, 3, 0.0f) : ImageF();
  solution->status = ImageU8(width, height, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  solution->lights_used = ImageU8(width, height, 1, 0);
  solution->condition_number = job.with_confidence ? ImageF(width, height, 1, 0.0f) : ImageF();
  solution->residual = job.with_confidence ? ImageF(width, height, 1, 0.0f) : ImageF();
  solution->solve_path = ImageU8(width, height, 1, static_cast<uint8_t>(SolvePath::kNone));
  ImageF albedo_mosaic;
  if (job.bayer && job.with_albedo) {
    albedo_mosaic = ImageF(width, height, 1, 0.0f);
    job.albedo_mosaic = &albedo_mosaic;
  }
  // Raw pixels carry one channel each: only the luminance solve runs per pixel.
  const bool rgb_albedo = job.with_albedo && !job.bayer;
  Job worker_job = job;
  worker_job.with_albedo = rgb_albedo;
  if (job.bayer) worker_job.albedo_mosaic = job.with_albedo ? &albedo_mosaic : nullptr;
  if (job.bayer && !job.with_albedo) {
    // Still needs a place for the per-pixel albedo; it is dropped.
    albedo_mosaic = ImageF(width, height, 1, 0.0f);
    worker_job.albedo_mosaic = &albedo_mosaic;
  }

  PhotometricSolverSummary summary;
  summary.method = PhotometricMethodName(options.method);
  summary.bayer_domain = job.bayer;
  summary.num_lights = job.num_lights;
  summary.num_pixels = static_cast<size_t>(width) * height;

  // Tiles over the region's bounding box; tiles without a region pixel are skipped.
  int box_x0 = 0, box_y0 = 0, box_x1 = width, box_y1 = height;
  if (job.region != nullptr) {
    box_x0 = width, box_y0 = height, box_x1 = 0, box_y1 = 0;
    for (int y = 0; y < height; ++y) {
      const uint8_t* row = job.region->row(y);
      for (int x = 0; x < width; ++x) {
        if (row[x] == 0) continue;
        box_x0 = std::min(box_x0, x), box_x1 = std::max(box_x1, x + 1);
        box_y0 = std::min(box_y0, y), box_y1 = std::max(box_y1, y + 1);
      }
    }
  }
  const int tile = options.tile_size;
  const int tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
  summary.num_tiles = static_cast<size_t>(tiles_x) * tiles_y;
  struct Tile {
    int x0, y0, x1, y1;
  };
  std::vector<Tile> tiles;
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      const Tile t{tx * tile, ty * tile, std::min(width, (tx + 1) * tile), std::min(height, (ty + 1) * tile)};
      const int x0 = std::max(t.x0, box_x0), x1 = std::min(t.x1, box_x1);
      const int y0 = std::max(t.y0, box_y0), y1 = std::min(t.y1, box_y1);
      bool any = x0 < x1 && y0 < y1;
      if (any && job.region != nullptr) {
        any = false;
        for (int y = y0; y < y1 && !any; ++y) {
          const uint8_t* row = job.region->row(y);
          any = std::any_of(row + x0, row + x1, [](uint8_t v) { return v != 0; });
        }
      }
      if (any) tiles.push_back(t);
    }
  }
  summary.tiles_skipped = summary.num_tiles - tiles.size();

  const int hardware_threads = std::max(1u, std::thread::hardware_concurrency());
  const int num_tiles = static_cast<int>(tiles.size());
  summary.num_threads = std::clamp(options.num_threads == 0 ? hardware_threads : options.num_threads, 1,
                                   std::max(1, num_tiles));

  std::atomic<int> next_tile{0};
  std::atomic<int> tiles_done{0};
  std::atomic<bool> stop{false};
  std::mutex merge_mutex;
  std::exception_ptr error;
  auto worker = [&]() {
    try {
      TileWorker tile_worker(worker_job);
      TileResult result;
      for (int t = next_tile++; t < num_tiles && !stop.load(std::memory_order_relaxed); t = next_tile++) {
        tile_worker.SolveTile(tiles[t].x0, tiles[t].y0, tiles[t].x1, tiles[t].y1, &result);
        ++tiles_done;
      }
      std::lock_guard<std::mutex> lock(merge_mutex);
      for (int p = 0; p < kNumSolvePaths; ++p) summary.pixels_by_path[p] += result.pixels_by_path[p];
    } catch (...) {
      std::lock_guard<std::mutex> lock(merge_mutex);
      if (!error) error = std::current_exception();
      stop = true;
    }
  };
  // Asked once before any work, so that a stop already requested is honoured
  // however fast the solve would be.
  if (progress && !progress(0.0)) stop = true;
  std::vector<std::thread> threads;
  for (int t = 1; t < summary.num_threads; ++t) threads.emplace_back(worker);
  if (progress) {
    // The caller's callback runs on the calling thread only.
    threads.emplace_back(worker);
    while (tiles_done.load() < num_tiles && !stop.load()) {
      if (!progress(num_tiles > 0 ? double(tiles_done.load()) / num_tiles : 1.0)) stop = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  } else {
    worker();
  }
  for (std::thread& thread : threads) thread.join();
  if (error) std::rethrow_exception(error);
  const bool cancelled = stop.load() && tiles_done.load() < num_tiles;
  if (!cancelled && job.bayer && job.with_albedo) {
    DemosaicAlbedo(albedo_mosaic, solution->status, job.cfa_channels, &solution->albedo);
  }
  if (progress && !cancelled) progress(1.0);

  for (size_t i = 0; i < solution->status.num_pixels(); ++i) {
    ++summary.pixels_by_status[std::min<int>(solution->status.data()[i], kNumPixelStatuses - 1)];
  }
  summary.pixels_by_path[0] = summary.num_pixels;
  for (int p = 1; p < kNumSolvePaths; ++p) summary.pixels_by_path[0] -= summary.pixels_by_path[p];
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (cancelled) {
    summary.termination = Termination::kCancelled;
    summary.message = "cancelled after " + std::to_string(tiles_done.load()) + " of " + std::to_string(num_tiles) +
                      " tiles";
  } else {
    summary.termination = Termination::kSuccess;
  }
  return summary;
}

}  // namespace

const char* PixelStatusName(PixelStatus status) {
  switch (status) {
    case PixelStatus::kSolved: return "solved";
    case PixelStatus::kOutsideRegion: return "outside_region";
    case PixelStatus::kTooFewLights: return "too_few_lights";
    case PixelStatus::kIllConditioned: return "ill_conditioned";
    case PixelStatus::kNoSignal: return "no_signal";
    case PixelStatus::kFacingAway: return "facing_away";
    case PixelStatus::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

const char* SolvePathName(SolvePath path) {
  switch (path) {
    case SolvePath::kNone: return "none";
    case SolvePath::kSharedLights: return "shared_lights";
    case SolvePath::kInterpolatedLights: return "interpolated_lights";
    case SolvePath::kExactLights: return "exact_lights";
    case SolvePath::kRobust: return "robust";
  }
  return "unknown";
}

const char* PhotometricMethodName(Method method) {
  switch (method) {
    case Method::kAdaptive: return "adaptive";
    case Method::kJacobiSvd: return "jacobi_svd";
    case Method::kNormalEquations: return "normal_equations";
    case Method::kQr: return "qr";
    case Method::kUniformPseudoInverse: return "uniform_pinv";
    case Method::kRobustIrls: return "robust_irls";
    case Method::kSparseBayesian: return "sparse_bayesian";
  }
  return "unknown";
}

std::vector<Method> AllPhotometricMethods() {
  return {Method::kAdaptive,      Method::kJacobiSvd,           Method::kNormalEquations, Method::kQr,
          Method::kUniformPseudoInverse, Method::kRobustIrls, Method::kSparseBayesian};
}

Method PhotometricMethodFromName(const std::string& name) {
  std::string names;
  for (Method method : AllPhotometricMethods()) {
    if (name == PhotometricMethodName(method)) return method;
    names += std::string(names.empty() ? "" : ", ") + PhotometricMethodName(method);
  }
  throw std::invalid_argument("photometric method '" + name + "' is not one of " + names);
}

void PhotometricSolverOptions::Check() const {
  double weight_sum = 0;
  for (int c = 0; c < 3; ++c) {
    if (!(luminance_weights[c] >= 0) || !std::isfinite(luminance_weights[c])) {
      throw OptionError("luminance_weights[" + std::to_string(c) + "]", NumberText(luminance_weights[c]),
                        "must be finite and >= 0");
    }
    weight_sum += luminance_weights[c];
  }
  if (!(weight_sum > 0)) throw OptionError("luminance_weights", "all zero", "must sum to > 0");
  if (min_lights < 3 || min_lights > 1000) {
    throw OptionError("min_lights", std::to_string(min_lights), "must lie in [3, 1000]");
  }
  if (!(max_condition_number > 1)) {
    throw OptionError("max_condition_number", NumberText(max_condition_number), "must be > 1");
  }
  if (!(min_sample_value >= 0) || !std::isfinite(min_sample_value)) {
    throw OptionError("min_sample_value", NumberText(min_sample_value), "must be finite and >= 0");
  }
  if (!(min_light_intensity >= 0) || !std::isfinite(min_light_intensity)) {
    throw OptionError("min_light_intensity", NumberText(min_light_intensity), "must be finite and >= 0");
  }
  if (!(min_albedo >= 0) || !std::isfinite(min_albedo)) {
    throw OptionError("min_albedo", NumberText(min_albedo), "must be finite and >= 0");
  }
  if (num_threads < 0 || num_threads > 256) {
    throw OptionError("num_threads", std::to_string(num_threads), "must lie in [0, 256]");
  }
  if (tile_size < 8 || tile_size > 4096) {
    throw OptionError("tile_size", std::to_string(tile_size), "must lie in [8, 4096]");
  }
  if (!(light_tolerance >= 0 && light_tolerance <= 0.1)) {
    throw OptionError("light_tolerance", NumberText(light_tolerance), "must lie in [0, 0.1]");
  }
  if (!(robust_loss_width >= 0) || !std::isfinite(robust_loss_width)) {
    throw OptionError("robust_loss_width", NumberText(robust_loss_width), "must be finite and >= 0");
  }
  if (!(robust_min_scale > 0) || !std::isfinite(robust_min_scale)) {
    throw OptionError("robust_min_scale", NumberText(robust_min_scale), "must be finite and > 0");
  }
  if (robust_max_iterations < 1 || robust_max_iterations > 10000) {
    throw OptionError("robust_max_iterations", std::to_string(robust_max_iterations), "must lie in [1, 10000]");
  }
  if (!(robust_dark_fraction >= 0 && robust_dark_fraction < 1)) {
    throw OptionError("robust_dark_fraction", NumberText(robust_dark_fraction), "must lie in [0, 1)");
  }
  if (!(adaptive_robust_residual >= 0) || std::isnan(adaptive_robust_residual)) {
    throw OptionError("adaptive_robust_residual", NumberText(adaptive_robust_residual), "must be >= 0");
  }
}

std::string PhotometricSolverSummary::BriefReport() const {
  std::ostringstream out;
  const char* how = termination == Termination::kSuccess     ? "success"
                    : termination == Termination::kCancelled ? "cancelled"
                                                             : "failure";
  out << "Photometric solve (" << (method.empty() ? "?" : method) << (bayer_domain ? ", Bayer domain" : "")
      << "): " << how << ", " << num_solved() << " / " << num_pixels << " pixels solved from " << num_lights
      << " lights in " << seconds << " s on " << num_threads << " threads";
  for (int s = 1; s < kNumPixelStatuses; ++s) {
    if (pixels_by_status[s] > 0) {
      out << ", " << pixels_by_status[s] << " " << PixelStatusName(static_cast<PixelStatus>(s));
    }
  }
  out << "; paths:";
  for (int p = 1; p < kNumSolvePaths; ++p) {
    if (pixels_by_path[p] > 0) out << " " << SolvePathName(static_cast<SolvePath>(p)) << " " << pixels_by_path[p];
  }
  if (tiles_skipped > 0) out << "; " << tiles_skipped << " of " << num_tiles << " tiles outside the region";
  if (!message.empty()) out << " (" << message << ")";
  return out.str();
}

PhotometricSolverSummary SolvePhotometricStereo(const PhotometricSolverOptions& options,
                                                const PhotometricSolverInput& input,
                                                PhotometricSolution* solution, const ProgressCallback& progress) {
  options.Check();
  CheckLightsAndRegion(input.light_field, input.images.size(), input.region, "images");
  CheckImages(input.images, 3, *input.light_field, "image");
  CheckSampleMasks(input.sample_valid, input.images.size(), input.light_field->width(), input.light_field->height());
  if (solution == nullptr) throw InputError("solution is null");
  Job job;
  job.options = &options;
  job.field = input.light_field;
  job.images = &input.images;
  job.sample_valid = &input.sample_valid;
  job.region = input.region;
  job.num_lights = input.light_field->num_lights();
  job.with_albedo = options.compute_albedo;
  job.with_confidence = options.compute_confidence;
  job.solution = solution;
  return RunSolve(options, job, progress);
}

PhotometricSolverSummary SolvePhotometricStereoBayer(const PhotometricSolverOptions& options,
                                                     const BayerSolverInput& input, PhotometricSolution* solution,
                                                     const ProgressCallback& progress) {
  options.Check();
  CheckLightsAndRegion(input.light_field, input.mosaics.size(), input.region, "mosaics");
  CheckImages(input.mosaics, 1, *input.light_field, "mosaic");
  CheckSampleMasks(input.sample_valid, input.mosaics.size(), input.light_field->width(), input.light_field->height());
  for (int p = 0; p < 4; ++p) {
    if (input.cfa_channels[p] < 0 || input.cfa_channels[p] > 2) {
      throw InputError("cfa_channels[" + std::to_string(p) + "] = " + std::to_string(input.cfa_channels[p]) +
                       " must be 0 (R), 1 (G) or 2 (B)");
    }
  }
  if (solution == nullptr) throw InputError("solution is null");
  Job job;
  job.options = &options;
  job.field = input.light_field;
  job.images = &input.mosaics;
  job.sample_valid = &input.sample_valid;
  job.region = input.region;
  job.bayer = true;
  job.cfa_channels = input.cfa_channels;
  job.num_lights = input.light_field->num_lights();
  job.with_albedo = options.compute_albedo;
  job.with_confidence = options.compute_confidence;
  job.solution = solution;
  return RunSolve(options, job, progress);
}

}  // namespace scanbench
