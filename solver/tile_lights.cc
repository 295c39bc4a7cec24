#include "solver/tile_lights.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace scanbench::tiled {
namespace {

// Node coordinates from first to last (both included), kLightCell apart.
void GridNodes(int first, int last, std::vector<int>* nodes) {
  nodes->clear();
  for (int v = first; v < last; v += kLightCell) nodes->push_back(v);
  nodes->push_back(last);
}

}  // namespace

TileLightSampler::TileLightSampler(const SolveJob& job)
    : job_(job), options_(*job.options), num_lights_(job.num_lights) {
  Resize(&centre_);
  Resize(&interpolated_);
  Resize(&truth_);
  shared_.dir.assign(3 * num_lights_, 0.0f);
  shared_.inv.assign(3 * num_lights_, 0.0f);
}

void TileLightSampler::Resize(LightProbe* probe) const {
  probe->dirs.assign(3 * num_lights_, 0.0f);
  probe->intensities.assign(3 * num_lights_, 0.0f);
  probe->inv.assign(3 * num_lights_, 0.0f);
}

void TileLightSampler::Probe(int x, int y, LightProbe* probe) const {
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

TileLights TileLightSampler::Classify(LightSharing sharing, int x0, int y0, int x1, int y1) {
  if (sharing == LightSharing::kNever) return TileLights::kExact;
  Probe((x0 + x1 - 1) / 2, (y0 + y1 - 1) / 2, &centre_);
  if (!centre_.finite) return TileLights::kExact;
  if (job_.field->IsUniform() || sharing == LightSharing::kAlways) return ShareCentreLights();
  if (!(options_.light_tolerance > 0) || !centre_.usable) return TileLights::kExact;
  if (!ProbeNodes(x0, y0, x1 - 1, y1 - 1)) return TileLights::kExact;
  if (NodesMatchCentre()) return ShareCentreLights();
  if (!InterpolationHolds()) return TileLights::kExact;
  ComputeNodeConditions();
  return TileLights::kInterpolated;
}

// The centre's lights for the whole tile, and the light matrix of every light
// usable in all three channels.
TileLights TileLightSampler::ShareCentreLights() {
  shared_.dir = centre_.dirs;
  shared_.inv = centre_.inv;
  ++shared_.generation;
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  shared_.usable = 0;
  bool partly_usable = false;
  for (int k = 0; k < num_lights_; ++k) {
    const float* inv = &shared_.inv[3 * k];
    const int lit = (inv[0] > 0) + (inv[1] > 0) + (inv[2] > 0);
    // Bayer pixels use a light lit in their own channel only: the shared
    // matrix then would not match every pixel's set of lights.
    partly_usable = partly_usable || (lit > 0 && lit < 3);
    if (lit < 3) continue;
    const Eigen::Vector3d d(shared_.dir[3 * k], shared_.dir[3 * k + 1], shared_.dir[3 * k + 2]);
    gram += d * d.transpose();
    ++shared_.usable;
  }
  shared_.condition = ConditionNumberFromGram(gram);
  shared_.inverse = gram.inverse();
  if (!shared_.inverse.allFinite() || (job_.bayer && partly_usable)) shared_.usable = -1;  // never shared
  return TileLights::kUniform;
}

// The light field at the nodes of [xa, xb] x [ya, yb] (both included); false
// when it is not finite or not usable at one of them.
bool TileLightSampler::ProbeNodes(int xa, int ya, int xb, int yb) {
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
      if (!node.finite || !node.usable) return false;
    }
  }
  return true;
}

// Whether two samples of the lights differ by more than light_tolerance:
// direction in radians (small angle), intensity relative to `a`'s.
bool TileLightSampler::Differs(const LightProbe& a, const std::vector<float>& dirs,
                               const std::vector<float>& inv) const {
  const double tolerance = options_.light_tolerance;
  for (int j = 0; j < 3 * num_lights_; j += 3) {
    const double dx = a.dirs[j] - dirs[j], dy = a.dirs[j + 1] - dirs[j + 1], dz = a.dirs[j + 2] - dirs[j + 2];
    if (!(std::sqrt(dx * dx + dy * dy + dz * dz) <= tolerance)) return true;
    for (int c = 0; c < 3; ++c) {
      if (!(std::abs(a.inv[j + c] - inv[j + c]) <= tolerance * a.inv[j + c])) return true;
    }
  }
  return false;
}

bool TileLightSampler::NodesMatchCentre() const {
  const size_t num_nodes = node_x_.size() * node_y_.size();
  for (size_t q = 0; q < num_nodes; ++q) {
    if (Differs(centre_, nodes_[q].dirs, nodes_[q].inv)) return false;
  }
  return true;
}

// Bilinear interpolation between the nodes, checked against the exact field
// in every cell: at its centre and the middle of its top and left edges (and
// of the bottom and right edges of the last row and column of cells).
bool TileLightSampler::InterpolationHolds() {
  const int nx = static_cast<int>(node_x_.size()), ny = static_cast<int>(node_y_.size());
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
        if (!truth_.finite || !truth_.usable || Differs(truth_, interpolated_.dirs, interpolated_.inv)) return false;
      }
    }
  }
  return true;
}

// The condition number of all lights at each node: pixels that use every
// light take it interpolated (it varies as smoothly as the lights do).
void TileLightSampler::ComputeNodeConditions() {
  const size_t num_nodes = node_x_.size() * node_y_.size();
  node_condition_.resize(num_nodes);
  for (size_t q = 0; q < num_nodes; ++q) {
    double g[6] = {0, 0, 0, 0, 0, 0};
    const std::vector<float>& d = nodes_[q].dirs;
    for (int k = 0; k < num_lights_; ++k) {
      const double x = d[3 * k], y = d[3 * k + 1], z = d[3 * k + 2];
      g[0] += x * x, g[1] += x * y, g[2] += x * z, g[3] += y * y, g[4] += y * z, g[5] += z * z;
    }
    node_condition_[q] = ConditionNumberFromGram(g[0], g[1], g[2], g[3], g[4], g[5]);
  }
}

void TileLightSampler::FillRow(TileLights lights, int x0, int x1, int y, SpanBuffers* buffers) {
  std::fill(buffers->light_bad.begin(), buffers->light_bad.begin() + (x1 - x0), 0);
  if (lights == TileLights::kInterpolated) FillInterpolatedRow(x0, y, buffers);
  if (lights == TileLights::kExact) FillExactRow(x0, x1, y, buffers);
}

// Between two node rows bilinear interpolation is linear in x within each
// cell: every cell's stretch of the row from its two ends, in the per-ISA
// kernel (SpanKernels::interpolate); the condition numbers likewise here.
void TileLightSampler::FillInterpolatedRow(int x0, int y, SpanBuffers* buffers) {
  const int nx = static_cast<int>(node_x_.size()), ny = static_cast<int>(node_y_.size());
  int j = 0;
  while (j + 2 < ny && node_y_[j + 1] <= y) ++j;
  const int j1 = std::min(j + 1, ny - 1);
  const double fy = node_y_[j1] > node_y_[j] ? double(y - node_y_[j]) / (node_y_[j1] - node_y_[j]) : 0.0;
  const int num_cells = std::max(2, nx) - 1;
  const int num_values = 3 * num_lights_;
  cell_begin_.resize(num_cells);
  cell_count_.resize(num_cells);
  cell_scale_.resize(num_cells);
  column_rows_.resize(4 * static_cast<size_t>(nx));
  interpolate_scratch_.resize(2 * static_cast<size_t>(nx) * num_values + 2 * static_cast<size_t>(num_cells) * num_values);
  for (int i = 0; i < num_cells; ++i) {
    const int i1 = std::min(i + 1, nx - 1);
    const int xa = node_x_[i], xb = node_x_[i1];
    const int end = i1 == nx - 1 ? xb + 1 : xb;  // the last cell includes its right node
    const double step_scale = xb > xa ? 1.0 / (xb - xa) : 0.0;
    cell_begin_[i] = xa - x0;
    cell_count_[i] = end - xa;
    cell_scale_[i] = step_scale;
    const double left = (1 - fy) * node_condition_[j * nx + i] + fy * node_condition_[j1 * nx + i];
    const double right = (1 - fy) * node_condition_[j * nx + i1] + fy * node_condition_[j1 * nx + i1];
    double* __restrict condition = &buffers->all_lights_condition[xa - x0];
    for (int t = 0; t < end - xa; ++t) condition[t] = left + (right - left) * step_scale * t;
  }
  const float** top_dirs = column_rows_.data();
  const float** bottom_dirs = top_dirs + nx;
  const float** top_inv = top_dirs + 2 * nx;
  const float** bottom_inv = top_dirs + 3 * nx;
  for (int i = 0; i < nx; ++i) {
    top_dirs[i] = nodes_[j * nx + i].dirs.data();
    bottom_dirs[i] = nodes_[j1 * nx + i].dirs.data();
    top_inv[i] = nodes_[j * nx + i].inv.data();
    bottom_inv[i] = nodes_[j1 * nx + i].inv.data();
  }
  InterpolateArgs a;
  a.num_values = num_values;
  a.num_columns = nx;
  a.num_cells = num_cells;
  a.capacity = buffers->capacity;
  a.fy = fy;
  a.cell_begin = cell_begin_.data();
  a.cell_count = cell_count_.data();
  a.cell_scale = cell_scale_.data();
  a.top_dirs = top_dirs;
  a.bottom_dirs = bottom_dirs;
  a.top_inv = top_inv;
  a.bottom_inv = bottom_inv;
  a.scratch = interpolate_scratch_.data();
  a.dirs = buffers->dir.data();
  a.inv = buffers->inv.data();
  KernelsOf(job_).interpolate(a);
}

// The whole row from the field at once, then Probe's rules per light in the
// per-ISA kernel (the intensities are turned into their inverses in place).
void TileLightSampler::FillExactRow(int x0, int x1, int y, SpanBuffers* buffers) {
  const int n = buffers->capacity, count = x1 - x0;
  job_.field->EvaluateSpan(x0, y, count, n, buffers->dir.data(), buffers->inv.data());
  const auto& w = options_.luminance_weights;
  LightRulesArgs a;
  a.count = count;
  a.num_lights = num_lights_;
  a.stride = n;
  a.bayer = job_.bayer;
  a.w0 = w[0], a.w1 = w[1], a.w2 = w[2];
  a.min_intensity = options_.min_light_intensity;
  a.dirs = buffers->dir.data();
  a.inv = buffers->inv.data();
  a.bad = buffers->light_bad.data();
  KernelsOf(job_).light_rules(a);
  const uint8_t* bad = buffers->light_bad.data();
  for (int i = 0; i < count; ++i) {
    if (!bad[i]) continue;
    for (int j = 0; j < 3 * num_lights_; ++j) {
      buffers->dir[static_cast<size_t>(j) * n + i] = 0.0f;
      buffers->inv[static_cast<size_t>(j) * n + i] = 0.0f;
    }
  }
}

}  // namespace scanbench::tiled
