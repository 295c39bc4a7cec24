#include "solver/coherent_sheen.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "core/field_error.h"
#include "core/format.h"
#include "solver/block_refiner.h"
#include "solver/pixel_fit_internal.h"
#include "solver/pixel_solvers.h"
#include "solver/span_kernels.h"
#include "solver/tile_lights.h"
#include "solver/tiled_solve.h"

namespace scanbench {
namespace {

constexpr const char* kOptions = "CoherentSheenOptions";
constexpr int kMinSamples = 6;  // per pixel: 3 unknowns of its own and spares
// The width search: a ladder of this many log-spaced widths over [min_width,
// max_width], then a golden-section search of this many steps between the
// best rung's neighbours.
constexpr int kWidthLadder = 8;
constexpr int kGoldenSteps = 8;
// Fixed-point steps of a pixel's re-solve under a given sheen (the sheen
// moves with the normal only slightly: a few per cent of the reading), and
// the relative change of the scaled normal that ends them.
constexpr int kResolveIterations = 8;
constexpr double kResolveConverged = 1e-7;
// Residual floor of the model selection, relative to the albedo (as
// FitDiffuseSheen's): below about the quantisation of a 14-bit reading.
constexpr double kResidualFloor = 1e-3;
// A fitted width within this fraction of the log width range of either bound
// is not taken (see RefineGroup).
constexpr double kWidthMargin = 0.05;
// The fit pixels: the candidates on every kFitRowStep-th row of the block
// (only those rows' samples are gathered unless the group takes the sheen).
constexpr int kFitRowStep = 4;
// The gate's widths: max_width, then each 1/sqrt(3) of the one before down to
// min_width (2, 1.15, 0.67, 0.38 by default), so that each rung's
// exp(-cot^2 / a^2) is the cube of the one before: one exp per sample.
constexpr int kMaxGateWidths = 8;
// Fewest usable pixels on the gate's rows to judge an albedo group by (and
// the block: fewer in all, it is left alone).
constexpr int kGateMinPixels = 8;
// The gate looks at up to this many rows of a block: the fullest row of each
// half, then the fullest others until they hold a block width of candidates.
constexpr int kMaxGateRows = 4;

struct Cell {
  int x = 0, y = 0;
};

// One candidate pixel and its samples (a range of the block's sample arrays).
struct Pixel {
  int x = 0, y = 0;
  int first = 0, count = 0;
  Eigen::Matrix3d gram_inverse = Eigen::Matrix3d::Identity();  // (sum l l^T)^-1
  Eigen::Vector3d m_ls = Eigen::Vector3d::Zero();              // least-squares scaled normal (luminance)
  Eigen::Vector3d m = Eigen::Vector3d::Zero();                 // under the current sheen
  double rss_ls = 0, rss = 0;                                  // sums of squared luminance residuals
};

struct Counts {
  size_t candidates = 0, gated = 0, passed = 0, tried = 0, taken = 0, refined = 0;
  double f0_sum = 0, width_sum = 0;
};

// Two-means on albedo chromaticities (r, g of rgb / sum) into *cluster (0 or
// 1 each): all 0 when the two centres are within `split`.
void SplitInTwo(const std::vector<Eigen::Vector2d>& chroma, double split, std::vector<int>* cluster) {
  const size_t count = chroma.size();
  cluster->assign(count, 0);
  if (count == 0) return;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& c : chroma) mean += c;
  mean /= double(count);
  size_t far_a = 0, far_b = 0;
  for (size_t i = 0; i < count; ++i) {
    if ((chroma[i] - mean).squaredNorm() > (chroma[far_a] - mean).squaredNorm()) far_a = i;
  }
  for (size_t i = 0; i < count; ++i) {
    if ((chroma[i] - chroma[far_a]).squaredNorm() > (chroma[far_b] - chroma[far_a]).squaredNorm()) far_b = i;
  }
  Eigen::Vector2d centre[2] = {chroma[far_a], chroma[far_b]};
  if (!((centre[0] - centre[1]).norm() > split)) return;
  for (int iteration = 0; iteration < 8; ++iteration) {
    Eigen::Vector2d sum[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
    int members[2] = {0, 0};
    for (size_t i = 0; i < count; ++i) {
      const int c = (chroma[i] - centre[1]).squaredNorm() < (chroma[i] - centre[0]).squaredNorm();
      (*cluster)[i] = c;
      sum[c] += chroma[i];
      ++members[c];
    }
    for (int c = 0; c < 2; ++c) {
      if (members[c] > 0) centre[c] = sum[c] / members[c];
    }
  }
  if (!((centre[0] - centre[1]).norm() > split)) std::fill(cluster->begin(), cluster->end(), 0);
}

// One pixel of the gate: its projected sums per gate width and its residual.
struct GatePixel {
  int candidate = 0;  // index in the block's candidates
  double a[kMaxGateWidths] = {}, b[kMaxGateWidths] = {};
  double rss = 0;
};

class BlockRefiner {
 public:
  BlockRefiner(const CoherentSheenOptions& options, const tiled::SolveJob& job)
      : options_(options),
        solver_(*job.options),
        job_(job),
        rgb_(!job.bayer && job.with_albedo && !job.solution->albedo.empty()),
        buffers_(job.num_lights, options.block_size),
        lights_(job),
        accumulate_exact_(tiled::ChooseAccumulator(job.bayer, rgb_, false)),
        accumulate_uniform_(tiled::ChooseAccumulator(job.bayer, rgb_, true)),
        accumulate_luminance_exact_(tiled::ChooseAccumulator(job.bayer, false, false)),
        accumulate_luminance_uniform_(tiled::ChooseAccumulator(job.bayer, false, true)),
        samples_(job.num_lights),
        gate_scratch_(7 * static_cast<size_t>(job.num_lights)) {}

  using Counts = scanbench::Counts;

  // ---- the steps of RefineBlock (solver/block_refiner.h) ----------------

  // The block's candidates, where the block passes the gate.
  bool CollectBlock(int x0, int y0, int x1, int y1, Counts* counts) {
    x0_ = x0, y0_ = y0, x1_ = x1, y1_ = y1;
    classified_ = false;
    if (!Scan()) return false;
    counts->candidates += candidates_.size();
    ++counts->gated;
    if (!Gate()) return false;
    ++counts->passed;
    return true;
  }

  // Two-means on the albedo chromaticity (RGB input); one cluster when the
  // centres are within albedo_split.
  int GroupByAlbedo() {
    cluster_.assign(candidates_.size(), 0);
    if (rgb_) {
      chroma_.clear();
      for (const Cell& cell : candidates_) chroma_.push_back(Chromaticity(cell.x, cell.y));
      SplitInTwo(chroma_, options_.albedo_split, &cluster_);
    }
    return 2;
  }

  // The group's candidates, where they are enough and pass the gate once
  // more on their own pixels of the gate's rows (where they are too few to
  // judge, the fit decides).
  bool GatherGroup(int g) {
    group_.clear();
    for (size_t i = 0; i < candidates_.size(); ++i) {
      if (cluster_[i] == g) group_.push_back(candidates_[i]);
    }
    if (static_cast<int>(group_.size()) < options_.min_pixels) return false;
    return !(GateRatio(cluster_, g, true) < options_.gate_ratio);
  }

  // The group's sheen (width, F0) on its fit pixels; true where it pays.
  bool FitGroup(Counts* counts) {
    ++counts->tried;
    ChooseFitCells();
    Gather(fit_cells_);
    if (static_cast<int>(pixels_.size()) < std::min(options_.min_pixels, options_.max_fit_pixels) / 2) return false;
    PrepareGeometry();
    double rss_ls_fit = 0;
    for (const Pixel& p : pixels_) rss_ls_fit += p.rss_ls;
    if (!FitPixelsPassTheGate(rss_ls_fit)) return false;
    group_width_ = 1, group_f0_ = 0;
    for (int iteration = 0; iteration < options_.iterations; ++iteration) {
      if (iteration > 0) PrepareGeometry();
      const double gain = FitShared(&group_width_, &group_f0_);
      if (!(group_f0_ > 0)) return false;
      if (iteration == 0 && gain < options_.gate_ratio * rss_ls_fit) return false;
      for (Pixel& p : pixels_) Resolve(&p, group_width_, group_f0_);
    }
    if (!SheenPays(group_width_)) return false;
    ++counts->taken;
    counts->f0_sum += group_f0_, counts->width_sum += group_width_;
    return true;
  }

  // Every candidate of the group under the group's sheen.
  void WriteGroup(Counts* counts) {
    Gather(group_);
    for (Pixel& p : pixels_) {
      Resolve(&p, group_width_, group_f0_);
      counts->refined += Write(p);
    }
  }

 private:
  // The block's candidates into candidates_ (row order) and mask_: solved
  // least-squares pixels of the region, i.e. no specular lobe (the shared
  // lobe's or the per-pixel one's) and no robust re-solve (its weights left
  // samples out that the sheen fit would take back). False where the block
  // is left alone: too few candidates, or mostly glossy (max_lobe_fraction).
  bool Scan() {
    const PhotometricSolution& s = *job_.solution;
    constexpr uint8_t kSolved = static_cast<uint8_t>(PixelStatus::kSolved);
    constexpr uint8_t kRobust = static_cast<uint8_t>(SolvePath::kRobust);
    constexpr uint8_t kLobe = static_cast<uint8_t>(SpecularStatus::kEstimated);
    const int w = x1_ - x0_;
    mask_.assign(static_cast<size_t>(w) * (y1_ - y0_), 0);
    row_counts_.assign(y1_ - y0_, 0);
    candidates_.clear();
    int lobe_pixels = 0;
    for (int y = y0_; y < y1_; ++y) {
      const uint8_t* region = job_.region != nullptr ? job_.region->row(y) : nullptr;
      const uint8_t* sheen = job_.sheen_pixels != nullptr ? job_.sheen_pixels->row(y) : nullptr;
      const uint8_t* status = s.status.row(y);
      const uint8_t* path = s.solve_path.row(y);
      const uint8_t* specular = s.specular_status.empty() ? nullptr : s.specular_status.row(y);
      int* mask = &mask_[static_cast<size_t>(y - y0_) * w];
      for (int x = x0_; x < x1_; ++x) {
        if ((region != nullptr && region[x] == 0) || status[x] != kSolved) continue;
        if (specular != nullptr && specular[x] == kLobe) {
          ++lobe_pixels;
          continue;
        }
        if ((sheen != nullptr && sheen[x] == 0) || path[x] == kRobust) continue;
        candidates_.push_back({x, y});
        mask[x - x0_] = static_cast<int>(candidates_.size());
        ++row_counts_[y - y0_];
      }
    }
    if (static_cast<int>(candidates_.size()) < options_.min_pixels) return false;
    return !(lobe_pixels > options_.max_lobe_fraction * double(candidates_.size()));
  }

  // The lights of rows [ya, yb) of the block (the gate's rows, or the whole
  // block for the fit): classified once per extent.
  void ClassifyLights(int ya, int yb) {
    if (classified_ && ya >= classified_y0_ && yb <= classified_y1_) return;
    kind_ = lights_.Classify(LightSharing::kWithinTolerance, x0_, ya, x1_, yb);
    classified_ = true;
    classified_y0_ = ya, classified_y1_ = yb;
  }

  // Row y's samples (x0_ to x1_) into buffers_: the lights and the
  // accumulated normal equations (SpanBuffers::acc; with luminance_only not
  // the per-channel sums nor SpanBuffers::rgb). The lights as classified
  // last (ClassifyLights): y must lie in that extent.
  void AccumulateRow(int y, bool luminance_only = false) {
    lights_.FillRow(kind_, x0_, x1_, y, &buffers_);
    const bool uniform = kind_ == tiled::TileLights::kUniform;
    const tiled::AccumulateSpanFn accumulate =
        luminance_only ? (uniform ? accumulate_luminance_uniform_ : accumulate_luminance_exact_)
                       : (uniform ? accumulate_uniform_ : accumulate_exact_);
    accumulate(job_, lights_.shared(), x0_, x1_ - x0_, y, &buffers_);
  }

  // The gate's rows into gate_rows_: the row with the most candidates in
  // each half of the block (nearest its quarter point among equals: a quarter
  // and three quarters down a full block), then the fullest of the others
  // until the rows hold a block width of candidates (kMaxGateRows at most).
  void ChooseGateRows() {
    const int h = y1_ - y0_, w = x1_ - x0_;
    gate_rows_.clear();
    int held = 0;
    auto fullest = [&](int begin, int end, int centre) {
      int best = -1;
      for (int r = begin; r < end; ++r) {
        if (row_counts_[r] == 0 || std::find(gate_rows_.begin(), gate_rows_.end(), y0_ + r) != gate_rows_.end()) continue;
        if (best < 0 || row_counts_[r] > row_counts_[best] ||
            (row_counts_[r] == row_counts_[best] && std::abs(r - centre) < std::abs(best - centre))) {
          best = r;
        }
      }
      if (best >= 0) gate_rows_.push_back(y0_ + best), held += row_counts_[best];
      return best >= 0;
    };
    fullest(0, h / 2, h / 4);
    fullest(h / 2, h, (3 * h) / 4);
    while (held < w && static_cast<int>(gate_rows_.size()) < kMaxGateRows && fullest(0, h, h / 2)) {
    }
  }

  // The gate: does the block's least-squares residual carry a velvet sheen's
  // pattern at all? On the candidates of the gate's rows (ChooseGateRows),
  // at their least-squares scaled normals m (from
  // the accumulated normal equations: no re-solve, no sample copies), the
  // sheen shape S_k of each sample at the gate's widths a; per width, the
  // pixels' scaled normals projected out as in SheenGain,
  //   gain(a) = B^2 / A,  B = sum_p sum_k S_k r_k,  A = sum_p (sum_k S_k^2 - t_p' G_p^-1 t_p),
  //   r_k = b_k - l_k . m,  t_p = sum_k S_k l_k,  G_p = sum_k l_k l_k'
  // (B > 0: a sheen adds light). The block goes on to the fit only where the
  // best width's gain is at least gate_ratio of the rows' residual sum of
  // squares. O(samples), one exp per sample: what a block of a Lambertian
  // scene costs.
  bool Gate() {
    ChooseGateRows();
    if (gate_rows_.empty()) return false;
    num_widths_ = 0;
    for (double a = options_.max_width; a >= options_.min_width * (1 - 1e-9) && num_widths_ < kMaxGateWidths;
         a /= std::sqrt(3.0)) {
      ++num_widths_;
    }
    gate_pixels_.clear();
    gate_chroma_.clear();
    // The lights of the rows' extent only (a quarter to three quarters down
    // a full block): half the light field probes of the whole block's.
    ClassifyLights(*std::min_element(gate_rows_.begin(), gate_rows_.end()),
                   *std::max_element(gate_rows_.begin(), gate_rows_.end()) + 1);
    for (const int y : gate_rows_) GateRow(y);
    // Fewer usable pixels than that on the block's fullest rows (too few
    // samples: the steep rim of an object): the fit would not find the
    // pixels it needs either.
    if (static_cast<int>(gate_pixels_.size()) < kGateMinPixels) return false;
    // Per albedo group of the rows' pixels (as the fit's groups: a sheen on
    // the warp is not cancelled by a weft, or a table, whose residual runs
    // the other way), the best width's gain against the group's residual;
    // the rows' pixels together where neither group has kGateMinPixels.
    if (rgb_) {
      SplitInTwo(gate_chroma_, options_.albedo_split, &gate_cluster_);
    } else {
      gate_cluster_.assign(gate_pixels_.size(), 0);
    }
    if (std::count(gate_cluster_.begin(), gate_cluster_.end(), 0) < kGateMinPixels &&
        std::count(gate_cluster_.begin(), gate_cluster_.end(), 1) < kGateMinPixels) {
      std::fill(gate_cluster_.begin(), gate_cluster_.end(), 0);
    }
    double best_ratio = 0;
    for (int g = 0; g < 2; ++g) best_ratio = std::max(best_ratio, GateRatio(gate_cluster_, g, false));
    return best_ratio >= options_.gate_ratio;
  }

  // The gate pixels of row y (one of the gate's rows) into gate_pixels_ and
  // their chromaticities into gate_chroma_: each candidate's least-squares
  // scaled normal m from the accumulated normal equations, then its sums.
  void GateRow(int y) {
    const int w = x1_ - x0_;
    const int* mask = &mask_[static_cast<size_t>(y - y0_) * w];
    AccumulateRow(y, true);
    const size_t n = static_cast<size_t>(buffers_.capacity);
    const double* acc = buffers_.acc.data();
    for (int i = 0; i < w; ++i) {
      if (mask[i] == 0 || buffers_.light_bad[i]) continue;
      if (!(acc[tiled::kCount * n + i] >= kMinSamples)) continue;
      // G^-1 by its adjugate (G symmetric).
      const double g00 = acc[tiled::kG00 * n + i], g01 = acc[tiled::kG01 * n + i], g02 = acc[tiled::kG02 * n + i];
      const double g11 = acc[tiled::kG11 * n + i], g12 = acc[tiled::kG12 * n + i], g22 = acc[tiled::kG22 * n + i];
      const double c00 = g11 * g22 - g12 * g12, c01 = g02 * g12 - g01 * g22, c02 = g01 * g12 - g02 * g11;
      const double c11 = g00 * g22 - g02 * g02, c12 = g01 * g02 - g00 * g12, c22 = g00 * g11 - g01 * g01;
      const double det = g00 * c00 + g01 * c01 + g02 * c02;
      const double trace = g00 + g11 + g22;
      if (!(det > 1e-9 * trace * trace * trace)) continue;  // far past any max_condition_number
      Eigen::Matrix3d inverse;
      inverse << c00, c01, c02, c01, c11, c12, c02, c12, c22;
      inverse /= det;
      const Eigen::Vector3d m =
          inverse * Eigen::Vector3d(acc[tiled::kB0 * n + i], acc[tiled::kB1 * n + i], acc[tiled::kB2 * n + i]);
      const double length = m.norm();
      if (!(length >= std::max(solver_.min_albedo, 1e-12))) continue;
      GatePixel pixel = GateSums(i, y, inverse, m, length);
      pixel.candidate = mask[i] - 1;
      gate_pixels_.push_back(pixel);
      if (rgb_) gate_chroma_.push_back(Chromaticity(x0_ + i, y));
    }
  }

  // The gate sums of the pixel at span index i of row y (its samples in
  // buffers_, G^-1 `inverse`, least-squares scaled normal m of that length):
  // per gate width a the projected A and B of the header comment, and the
  // residual sum of squares. In stages over the pixel's used samples, each
  // loop free of the one before's latency (the divisions, the exp): the
  // lights and residuals, the sheen geometry, the exps, the sums per width.
  // One kernel whole: the staging is the point of its shape.
  GatePixel GateSums(int i, int y, const Eigen::Matrix3d& inverse, const Eigen::Vector3d& m, double length) {
    const size_t n = static_cast<size_t>(buffers_.capacity);
    const int num_lights = job_.num_lights;
    const bool uniform = kind_ == tiled::TileLights::kUniform;
    const float* shared_dir = lights_.shared().dir.data();
    const float* dir = buffers_.dir.data();
    const double inv_max_width2 = 1 / (options_.max_width * options_.max_width);
    const Eigen::Vector3d normal = m / length;
    float view_f[3];
    job_.field->ViewDirection(x0_ + i, y, view_f);
    Eigen::Vector3d view(view_f[0], view_f[1], view_f[2]);
    view = pixel_fit::UnitViewOrZ(view);
    const double nv = std::clamp(normal.dot(view), kVelvetSheenMinViewCosine, 1.0);
    double* lx = &gate_scratch_[0];
    double* ly = lx + num_lights;
    double* lz = ly + num_lights;
    double* res = lz + num_lights;
    double* q = res + num_lights;
    double* u = q + num_lights;
    double* e = u + num_lights;
    int used = 0;
    double rss_pixel = 0;
    for (int k = 0; k < num_lights; ++k) {
      const size_t at = k * n + i;
      if (!(buffers_.ok[at] > 0)) continue;
      if (uniform) {
        lx[used] = shared_dir[3 * k], ly[used] = shared_dir[3 * k + 1], lz[used] = shared_dir[3 * k + 2];
      } else {
        lx[used] = dir[3 * k * n + i], ly[used] = dir[(3 * k + 1) * n + i], lz[used] = dir[(3 * k + 2) * n + i];
      }
      res[used] = buffers_.lum[at] - (lx[used] * m.x() + ly[used] * m.y() + lz[used] * m.z());
      rss_pixel += res[used] * res[used];
      ++used;
    }
    // S up to its per-width normalisation, which B^2 / A does not see:
    // q (1 + K exp(-cot^2 / a^2) / sin^4), as VelvetSheenOf (0 where
    // n . l <= 0); cos^2 th_h = (n . s)^2 / |s|^2 with s = l + v, no
    // square root.
    const double nvx = normal.dot(view);
    for (int k = 0; k < used; ++k) {
      const double nl = normal.x() * lx[k] + normal.y() * ly[k] + normal.z() * lz[k];
      const double sx = lx[k] + view.x(), sy = ly[k] + view.y(), sz = lz[k] + view.z();
      const double sum2 = sx * sx + sy * sy + sz * sz, ns = nl + nvx;
      const double c2 = !(sum2 > 1e-12) ? nv * nv : ns > 0 ? std::min(ns * ns / sum2, 1.0) : 0.0;
      const double s2 = 1 - c2;
      const double inv_s2 = s2 > 1e-6 ? 1 / s2 : 0.0;
      q[k] = nl > 0 ? nl / (4 * (nl + nv - nl * nv)) : 0.0;
      u[k] = kVelvetSheenAmplitude * q[k] * inv_s2 * inv_s2;
      e[k] = -c2 * inv_s2 * inv_max_width2;
    }
    for (int k = 0; k < used; ++k) e[k] = std::exp(e[k]);
    GatePixel pixel;
    for (int j = 0; j < num_widths_; ++j) {
      Eigen::Vector3d t = Eigen::Vector3d::Zero();
      double ss = 0, sr = 0;
      for (int k = 0; k < used; ++k) {
        const double shape = q[k] + u[k] * e[k];
        t += shape * Eigen::Vector3d(lx[k], ly[k], lz[k]);
        ss += shape * shape;
        sr += shape * res[k];
        e[k] *= e[k] * e[k];
      }
      pixel.a[j] = ss - t.dot(inverse * t);
      pixel.b[j] = sr;
    }
    pixel.rss = rss_pixel;
    return pixel;
  }

  // The gate's ratio of the gate pixels labelled `group` in `labels` (one
  // label per gate pixel, or with by_candidate per candidate of the block):
  // the best width's gain over their residual sum of squares. Fewer than
  // kGateMinPixels: 0 per gate pixel (the block's other group judges it), 1
  // per candidate (a fit group too thin on the gate's rows: the fit decides).
  double GateRatio(const std::vector<int>& labels, int group, bool by_candidate) const {
    double big_a[kMaxGateWidths] = {}, big_b[kMaxGateWidths] = {};
    double rss = 0;
    int pixels = 0;
    for (size_t p = 0; p < gate_pixels_.size(); ++p) {
      const GatePixel& pixel = gate_pixels_[p];
      if (labels[by_candidate ? pixel.candidate : p] != group) continue;
      for (int j = 0; j < num_widths_; ++j) big_a[j] += pixel.a[j], big_b[j] += pixel.b[j];
      rss += pixel.rss;
      ++pixels;
    }
    if (pixels < kGateMinPixels) return by_candidate ? 1.0 : 0.0;
    double best = 0;
    for (int j = 0; j < num_widths_; ++j) {
      if (big_a[j] > 0 && big_b[j] > 0) best = std::max(best, big_b[j] * big_b[j] / big_a[j]);
    }
    return rss > 0 ? best / rss : 0.0;
  }

  // r, g of rgb / sum of the pixel's solved albedo.
  Eigen::Vector2d Chromaticity(int x, int y) const {
    const PhotometricSolution& s = *job_.solution;
    const double r = s.albedo(x, y, 0), g = s.albedo(x, y, 1), b = s.albedo(x, y, 2);
    const double sum = r + g + b;
    return sum > 0 ? Eigen::Vector2d(r / sum, g / sum) : Eigen::Vector2d(1.0 / 3, 1.0 / 3);
  }

  // The samples of `cells` (in row order) into pixels_ and the sample
  // arrays, with each pixel's least-squares fit on them.
  void Gather(const std::vector<Cell>& cells) {
    pixels_.clear();
    lights_k_.clear(), halves_.clear(), values_.clear(), views_.clear();
    ClassifyLights(y0_, y1_);
    tiled::Span span;
    span.lights = kind_;
    span.x0 = x0_;
    span.count = x1_ - x0_;
    span.buffers = &buffers_;
    span.shared = &lights_.shared();
    int row = -1;
    for (const Cell& cell : cells) {
      if (cell.y != row) {
        row = cell.y;
        AccumulateRow(row);
        span.y = row;
      }
      const int i = cell.x - x0_;
      if (buffers_.light_bad[i]) continue;
      tiled::GatherSamples(span, i, rgb_, &samples_);
      if (samples_.count() < kMinSamples) continue;
      Pixel p;
      p.x = cell.x, p.y = cell.y;
      float view_f[3];
      job_.field->ViewDirection(cell.x, cell.y, view_f);
      Eigen::Vector3d view(view_f[0], view_f[1], view_f[2]);
      view = pixel_fit::UnitViewOrZ(view);
      p.first = static_cast<int>(lights_k_.size());
      p.count = samples_.count();
      const double* l = samples_.light_data();
      const double* v = samples_.value_data();
      Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
      Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
      for (int k = 0; k < p.count; ++k) {
        const Eigen::Vector3d light(l[3 * k], l[3 * k + 1], l[3 * k + 2]);
        const Eigen::Vector3d sum = light + view;
        const double length = sum.norm();
        lights_k_.push_back(light);
        views_.push_back(view);
        halves_.push_back(length > 1e-6 ? Eigen::Vector3d(sum / length) : view);
        values_.emplace_back(v[4 * k], v[4 * k + 1], v[4 * k + 2], v[4 * k + 3]);
        gram.noalias() += light * light.transpose();
        rhs += v[4 * k] * light;
      }
      if (!(ConditionNumberFromGram(gram) <= solver_.max_condition_number)) {
        lights_k_.resize(p.first), halves_.resize(p.first), values_.resize(p.first), views_.resize(p.first);
        continue;
      }
      p.gram_inverse = gram.inverse();
      p.m_ls = p.gram_inverse * rhs;
      if (!p.m_ls.allFinite() || !(p.m_ls.norm() >= std::max(solver_.min_albedo, 1e-12))) {
        lights_k_.resize(p.first), halves_.resize(p.first), values_.resize(p.first), views_.resize(p.first);
        continue;
      }
      p.m = p.m_ls;
      for (int k = p.first; k < p.first + p.count; ++k) {
        const double r = lights_k_[k].dot(p.m_ls) - values_[k][0];
        p.rss_ls += r * r;
      }
      p.rss = p.rss_ls;
      pixels_.push_back(p);
    }
  }

  // Every sample's sheen geometry at its pixel's current normal.
  void PrepareGeometry() {
    geometry_.resize(lights_k_.size());
    for (const Pixel& p : pixels_) {
      const Eigen::Vector3d n = p.m.normalized();
      for (int k = p.first; k < p.first + p.count; ++k) {
        geometry_[k] = VelvetSheenGeometryOf(n, lights_k_[k], halves_[k], views_[k]);
      }
    }
  }

  // The group's drop in residual sum of squares from a sheen of width a, each
  // pixel's scaled normal projected out (min over m of |b - L m - F0 S|^2 =
  // |P (b - F0 S)|^2, P the projection off the light matrix's span), F0 in
  // closed form (>= 0) into *f0.
  double SheenGain(double width, double* f0) const {
    double big_a = 0, big_b = 0;
    for (const Pixel& p : pixels_) {
      Eigen::Vector3d t = Eigen::Vector3d::Zero();
      double ss = 0, sb = 0;
      for (int k = p.first; k < p.first + p.count; ++k) {
        const double s = VelvetSheenOf(geometry_[k], width);
        t += s * lights_k_[k];
        ss += s * s, sb += s * values_[k][0];
      }
      big_b += sb - t.dot(p.m_ls);
      big_a += ss - t.dot(p.gram_inverse * t);
    }
    *f0 = big_a > 0 && big_b > 0 ? big_b / big_a : 0.0;
    return *f0 * big_b;
  }

  // The width (ladder, then golden section between the best rung's
  // neighbours, on log a) and F0 of the group's sheen at the current normals.
  double FitShared(double* width, double* f0) {
    const double lo = std::log(options_.min_width), hi = std::log(options_.max_width);
    double best_gain = -1, best_log = lo;
    int best_rung = 0;
    for (int i = 0; i < kWidthLadder; ++i) {
      const double log_a = lo + (hi - lo) * i / (kWidthLadder - 1);
      double amplitude = 0;
      const double gain = SheenGain(std::exp(log_a), &amplitude);
      if (gain > best_gain) best_gain = gain, best_log = log_a, best_rung = i, *f0 = amplitude;
    }
    double a = lo + (hi - lo) * std::max(0, best_rung - 1) / (kWidthLadder - 1);
    double b = lo + (hi - lo) * std::min(kWidthLadder - 1, best_rung + 1) / (kWidthLadder - 1);
    constexpr double kInvPhi = 0.6180339887498949;
    double c = b - kInvPhi * (b - a), d = a + kInvPhi * (b - a);
    double fc = 0, fd = 0;
    double gc = SheenGain(std::exp(c), &fc), gd = SheenGain(std::exp(d), &fd);
    for (int step = 0; step < kGoldenSteps; ++step) {
      if (gc > gd) {
        b = d, d = c, gd = gc, fd = fc;
        c = b - kInvPhi * (b - a);
        gc = SheenGain(std::exp(c), &fc);
      } else {
        a = c, c = d, gc = gd, fc = fd;
        d = a + kInvPhi * (b - a);
        gd = SheenGain(std::exp(d), &fd);
      }
    }
    if (gc > best_gain) best_gain = gc, best_log = c, *f0 = fc;
    if (gd > best_gain) best_gain = gd, best_log = d, *f0 = fd;
    *width = std::exp(best_log);
    return best_gain;
  }

  // Pixel p's scaled normal under a sheen (width, f0): least squares on the
  // samples minus the sheen at the current normal, a few times; its residual
  // sum of squares into p->rss. The sheen of each sample into sheen_ (at
  // the final normal).
  void Resolve(Pixel* p, double width, double f0) {
    sheen_.resize(p->count);
    for (int iteration = 0; iteration < kResolveIterations; ++iteration) {
      const Eigen::Vector3d n = p->m.normalized();
      Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
      for (int i = 0; i < p->count; ++i) {
        const int k = p->first + i;
        const double s = f0 * VelvetSheenOf(VelvetSheenGeometryOf(n, lights_k_[k], halves_[k], views_[k]), width);
        rhs += (values_[k][0] - s) * lights_k_[k];
      }
      const Eigen::Vector3d m = p->gram_inverse * rhs;
      if (!m.allFinite()) break;
      const double change = (m - p->m).norm();
      p->m = m;
      if (change < kResolveConverged * m.norm()) break;
    }
    const Eigen::Vector3d n = p->m.normalized();
    p->rss = 0;
    for (int i = 0; i < p->count; ++i) {
      const int k = p->first + i;
      sheen_[i] = f0 * VelvetSheenOf(VelvetSheenGeometryOf(n, lights_k_[k], halves_[k], views_[k]), width);
      const double r = lights_k_[k].dot(p->m) + sheen_[i] - values_[k][0];
      p->rss += r * r;
    }
  }

  // Is the residual the sheen explains white (a sheen: the same F0 in every
  // intensity-divided channel) or the colour of the diffuse albedo (an error
  // of the diffuse model)? Per colour channel c, the projected sums A_c, B_c
  // of SheenGain at the current normals; the gain of one white F0 against
  // that of F0_c = k rho_c (rho_c the group's mean albedo in channel c).
  void ColourTest(double width, double* white_gain, double* diffuse_gain) {
    double big_a[3] = {0, 0, 0}, big_b[3] = {0, 0, 0}, rho[3] = {0, 0, 0}, members[3] = {0, 0, 0};
    for (const Pixel& p : pixels_) {
      const Eigen::Vector3d n = p.m.normalized();
      Eigen::Vector3d t = Eigen::Vector3d::Zero();
      double ss = 0;
      Eigen::Vector3d sb = Eigen::Vector3d::Zero();
      Eigen::Matrix3d rhs = Eigen::Matrix3d::Zero();  // column c: sum l b_c
      for (int k = p.first; k < p.first + p.count; ++k) {
        const double sk = VelvetSheenOf(VelvetSheenGeometryOf(n, lights_k_[k], halves_[k], views_[k]), width);
        t += sk * lights_k_[k];
        ss += sk * sk;
        for (int c = 0; c < 3; ++c) {
          const double b = rgb_ ? values_[k][1 + c] : values_[k][0];
          sb[c] += sk * b;
          rhs.col(c) += b * lights_k_[k];
        }
      }
      const double a = ss - t.dot(p.gram_inverse * t);
      const Eigen::Matrix3d m = p.gram_inverse * rhs;
      if (rgb_) {
        for (int c = 0; c < 3; ++c) {
          big_a[c] += a, big_b[c] += sb[c] - t.dot(m.col(c));
          rho[c] += m.col(c).norm(), members[c] += 1;
        }
      } else {
        const int c = job_.cfa_channels[(p.y & 1) * 2 + (p.x & 1)];
        big_a[c] += a, big_b[c] += sb[0] - t.dot(m.col(0));
        rho[c] += m.col(0).norm(), members[c] += 1;
      }
    }
    double sa = 0, sb = 0, ra = 0, rb = 0;
    for (int c = 0; c < 3; ++c) {
      if (!(members[c] > 0)) continue;
      const double r = rho[c] / members[c];
      sa += big_a[c], sb += big_b[c];
      ra += r * r * big_a[c], rb += r * big_b[c];
    }
    *white_gain = sa > 0 && sb > 0 ? sb * sb / sa : 0.0;
    *diffuse_gain = ra > 0 && rb > 0 ? rb * rb / ra : 0.0;
  }

  // The fit pixels: the group's candidates on every kFitRowStep-th row, at
  // most max_fit_pixels of them, evenly spread.
  void ChooseFitCells() {
    fit_cells_.clear();
    row_cells_.clear();
    for (const Cell& c : group_) {
      if ((c.y - y0_) % kFitRowStep == kFitRowStep / 2) row_cells_.push_back(c);
    }
    const size_t n = row_cells_.size();
    const size_t count = std::min(n, static_cast<size_t>(options_.max_fit_pixels));
    for (size_t i = 0; i < count; ++i) fit_cells_.push_back(row_cells_[i * n / count]);
  }

  // The gate once more, on the fit pixels at their least-squares normals,
  // on every other rung of the width ladder (a quarter of the width search's
  // cost; FitGroup checks the fitted width too): below gate_ratio of their
  // residual no search and no re-solve is spent (a Lambertian group past the
  // gate by chance).
  bool FitPixelsPassTheGate(double rss_ls_fit) const {
    const double lo = std::log(options_.min_width), hi = std::log(options_.max_width);
    double best = 0, amplitude = 0;
    for (int i = 1; i < kWidthLadder; i += 2) {
      best = std::max(best, SheenGain(std::exp(lo + (hi - lo) * i / (kWidthLadder - 1)), &amplitude));
    }
    return !(best < options_.gate_ratio * rss_ls_fit);
  }

  // Model selection on the fit pixels' samples together: the shared sheen
  // (two parameters for the group, the pixels' own three each as before)
  // against their least-squares fits; and the sheen's width and colour.
  bool SheenPays(double width) {
    double samples = 0, rss_ls = 0, rss = 0, floor_rss = 0;
    for (const Pixel& p : pixels_) {
      samples += p.count;
      rss_ls += p.rss_ls, rss += p.rss;
      floor_rss += p.count * std::pow(kResidualFloor * p.m_ls.norm(), 2);
    }
    const double lambert = std::max(rss_ls, floor_rss), sheen = std::max(rss, floor_rss);
    const bool pays = samples * std::log(lambert / sheen) > 2 * options_.bic_penalty * std::log(samples);
    const bool drops = rss <= (1 - options_.min_residual_drop) * rss_ls;
    // A width pinned at (or within kWidthMargin of) a bound of the search is
    // not a velvet sheen's: the fit follows some other smooth residual (a
    // third of the draped Lambertian sample's takes, in its first pass on the
    // table-plane light field; no cloth group, whose widths lie in 0.46-1.48).
    const double log_range = std::log(options_.max_width / options_.min_width);
    const bool interior = std::log(width / options_.min_width) > kWidthMargin * log_range &&
                          std::log(options_.max_width / width) > kWidthMargin * log_range;
    double white_gain = 0, diffuse_gain = 0;
    ColourTest(width, &white_gain, &diffuse_gain);
    // (Not in the Bayer domain: one raw sample per light and pixel carries
    // too little colour to tell, cloth there 0.592 -> 0.61 deg with it.)
    const bool white = !options_.dichromatic || job_.bayer || white_gain >= options_.white_margin * diffuse_gain;
    return pays && drops && white && interior;
  }

  // Writes pixel p (re-solved; sheen_ holds its samples' sheen); false where
  // the re-solve does not give a solved pixel (it keeps its own result).
  bool Write(const Pixel& p) {
    const double length = p.m.norm();
    if (!p.m.allFinite() || !(length >= solver_.min_albedo) || !(p.m.z() > 0)) return false;
    PhotometricSolution& s = *job_.solution;
    const Eigen::Vector3d n = p.m / length;
    const int x = p.x, y = p.y;
    for (int c = 0; c < 3; ++c) s.normal_in_table(x, y, c) = static_cast<float>(n[c]);
    if (rgb_) {
      // The sheen is white: the same F0 S in every intensity-divided channel.
      for (int c = 0; c < 3; ++c) {
        Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
        for (int i = 0; i < p.count; ++i) rhs += (values_[p.first + i][1 + c] - sheen_[i]) * lights_k_[p.first + i];
        const double albedo = (p.gram_inverse * rhs).norm();
        s.albedo(x, y, c) = std::isfinite(albedo) ? static_cast<float>(albedo) : 0.0f;
      }
    } else if (job_.bayer && job_.albedo_mosaic != nullptr && !job_.albedo_mosaic->empty()) {
      (*job_.albedo_mosaic)(x, y) = static_cast<float>(length);
    }
    if (!s.residual.empty()) s.residual(x, y) = static_cast<float>(std::min(std::sqrt(p.rss / p.count) / length, 1e30));
    if (!s.coherent_sheen.empty()) s.coherent_sheen(x, y) = 1;
    return true;
  }

  const CoherentSheenOptions& options_;
  const PhotometricSolverOptions& solver_;
  const tiled::SolveJob& job_;
  const bool rgb_;  // RGB samples and albedo (else luminance or raw samples only)
  tiled::SpanBuffers buffers_;
  tiled::TileLightSampler lights_;
  const tiled::AccumulateSpanFn accumulate_exact_, accumulate_uniform_;
  // The same without the per-channel sums (the gate reads the luminance only).
  const tiled::AccumulateSpanFn accumulate_luminance_exact_, accumulate_luminance_uniform_;
  PixelSamples samples_;
  int x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0;
  bool classified_ = false;
  int classified_y0_ = 0, classified_y1_ = 0;  // the rows ClassifyLights classified
  tiled::TileLights kind_ = tiled::TileLights::kExact;
  std::vector<Cell> candidates_, group_, fit_cells_, row_cells_;
  std::vector<int> mask_;  // 1 + index in candidates_ (0: none) at (y - y0_) * width + (x - x0_)
  std::vector<int> row_counts_;  // candidates per row of the block
  std::vector<int> gate_rows_;
  std::vector<GatePixel> gate_pixels_;
  int num_widths_ = 0;  // the gate's widths
  std::vector<double> gate_scratch_;  // 7 per light: the gate's per-sample stages
  std::vector<Eigen::Vector2d> gate_chroma_;
  std::vector<int> gate_cluster_;
  std::vector<Eigen::Vector2d> chroma_;
  std::vector<int> cluster_;
  std::vector<Pixel> pixels_;
  std::vector<Eigen::Vector3d> lights_k_, halves_, views_;
  std::vector<Eigen::Vector4d> values_;  // luminance, R, G, B (intensity divided)
  std::vector<VelvetSheenGeometry> geometry_;
  std::vector<double> sheen_;
  double group_width_ = 1, group_f0_ = 0;  // the current group's sheen (FitGroup)
};

}  // namespace

void CoherentSheenOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE(kOptions, "block_size", block_size, 4, 256);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "min_pixels", min_pixels, 8, 65536);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_fit_pixels", max_fit_pixels, 8, 65536);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "iterations", iterations, 1, 10);
  if (!(min_width > 0) || !(min_width < max_width)) {
    throw FieldError(kOptions, "min_width", min_width, "must be > 0 and below max_width");
  }
  SCANBENCH_REQUIRE_LE(kOptions, "max_width", max_width, 10);
  SCANBENCH_REQUIRE_GE(kOptions, "albedo_split", albedo_split, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_lights", max_lights, 3, 1000);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "bic_penalty", bic_penalty, 0);
  SCANBENCH_REQUIRE_GE_LT(kOptions, "min_residual_drop", min_residual_drop, 0, 1);
  SCANBENCH_REQUIRE_GE_LT(kOptions, "gate_ratio", gate_ratio, 0, 1);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "white_margin", white_margin, 0);
  SCANBENCH_REQUIRE_GE(kOptions, "max_lobe_fraction", max_lobe_fraction, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "num_threads", num_threads, 0, 256);
}

std::string CoherentSheenSummary::BriefReport() const {
  std::ostringstream out;
  out << "Coherent sheen: " << TerminationName(termination) << ", " << pixels_refined << " of " << pixels_candidate
      << " candidate pixels re-solved under a shared velvet sheen in " << groups_taken << " of " << groups_tried
      << " groups fitted in the " << blocks_passed << " of " << blocks_gated << " blocks past the gate (mean F0 " << Fixed(mean_f0, 4) << ", width " << Fixed(mean_width, 3) << "), " << Significant(seconds)
      << " s";
  if (!message.empty()) out << " (" << message << ")";
  return out.str();
}

namespace tiled {

CoherentSheenSummary RefineCoherentSheenOfJob(const CoherentSheenOptions& options, const SolveJob& job,
                                              const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  CoherentSheenSummary summary;
  if (job.num_lights > options.max_lights) {
    summary.termination = Termination::kSuccess;
    summary.skipped_lights = true;
    summary.message = std::to_string(job.num_lights) + " lights, more than max_lights = " +
                      std::to_string(options.max_lights) + ": the least-squares results are kept";
    return summary;
  }
  const std::vector<Counts> counts = RunBlockRefiners<BlockRefiner>(
      job.field->width(), job.field->height(), options.block_size, options.num_threads,
      [&] { return std::make_unique<BlockRefiner>(options, job); }, progress, &summary);
  double f0_sum = 0, width_sum = 0;
  for (const Counts& c : counts) {
    summary.pixels_candidate += c.candidates;
    summary.blocks_gated += c.gated;
    summary.blocks_passed += c.passed;
    summary.groups_tried += c.tried;
    summary.groups_taken += c.taken;
    summary.pixels_refined += c.refined;
    f0_sum += c.f0_sum, width_sum += c.width_sum;
  }
  if (summary.groups_taken > 0) {
    summary.mean_f0 = f0_sum / summary.groups_taken;
    summary.mean_width = width_sum / summary.groups_taken;
  }
  summary.seconds = SecondsSince(start);
  return summary;
}

}  // namespace tiled

CoherentSheenSummary RefineCoherentSheen(const CoherentSheenOptions& options,
                                         const PhotometricSolverOptions& solver_options,
                                         const PhotometricSolverInput& input, PhotometricSolution* solution,
                                         const ProgressCallback& progress) {
  options.Check();
  solver_options.Check();
  tiled::CheckRgbRefinementInput("coherent sheen", input, solution);
  const int width = input.light_field->width(), height = input.light_field->height();
  if (!solution->normal_in_table.SameSize(width, height) || !solution->status.SameSize(width, height) ||
      !solution->solve_path.SameSize(width, height) ||
      (!solution->albedo.empty() && !solution->albedo.SameSize(width, height)) ||
      (!solution->residual.empty() && !solution->residual.SameSize(width, height)) ||
      (!solution->specular_status.empty() && !solution->specular_status.SameSize(width, height))) {
    throw std::invalid_argument("coherent sheen: the solution is not the light field's " + std::to_string(width) +
                                " x " + std::to_string(height));
  }
  const tiled::SolveJob job =
      tiled::RgbSolveJob(solver_options, input, solution, !solution->albedo.empty(), !solution->residual.empty());
  return tiled::RefineCoherentSheenOfJob(options, job, progress);
}

}  // namespace scanbench
