#include "solver/coherent_sheen.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "solver/pixel_solvers.h"
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
// The fit pixels: the candidates on every kFitRowStep-th row of the block
// (only those rows' samples are gathered unless the group takes the sheen).
constexpr int kFitRowStep = 4;

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
  size_t candidates = 0, tried = 0, taken = 0, refined = 0;
  double f0_sum = 0, width_sum = 0;
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
        samples_(job.num_lights) {}

  void Refine(int x0, int y0, int x1, int y1, Counts* counts) {
    x0_ = x0, y0_ = y0, x1_ = x1, y1_ = y1;
    classified_ = false;
    candidates_.clear();
    chroma_.clear();
    const PhotometricSolution& s = *job_.solution;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) {
        if (!Candidate(x, y)) continue;
        candidates_.push_back({x, y});
        if (rgb_) {
          const double r = s.albedo(x, y, 0), g = s.albedo(x, y, 1), b = s.albedo(x, y, 2);
          const double sum = r + g + b;
          chroma_.emplace_back(sum > 0 ? r / sum : 1.0 / 3, sum > 0 ? g / sum : 1.0 / 3);
        }
      }
    }
    if (static_cast<int>(candidates_.size()) < options_.min_pixels) return;
    if (LobePixels(x0, y0, x1, y1) > options_.max_lobe_fraction * double(candidates_.size())) return;
    counts->candidates += candidates_.size();
    SplitByAlbedo();
    for (int g = 0; g < 2; ++g) {
      group_.clear();
      for (size_t i = 0; i < candidates_.size(); ++i) {
        if (cluster_[i] == g) group_.push_back(candidates_[i]);
      }
      if (static_cast<int>(group_.size()) < options_.min_pixels) continue;
      RefineGroup(counts);
    }
  }

 private:
  // Solved least-squares pixels of the region: no specular lobe (the shared
  // lobe's or the per-pixel one's), no robust re-solve (its weights left
  // samples out that the sheen fit would take back).
  bool Candidate(int x, int y) const {
    const PhotometricSolution& s = *job_.solution;
    if (job_.region != nullptr && (*job_.region)(x, y) == 0) return false;
    if (job_.sheen_pixels != nullptr && (*job_.sheen_pixels)(x, y) == 0) return false;
    if (s.status(x, y) != static_cast<uint8_t>(PixelStatus::kSolved)) return false;
    if (s.solve_path(x, y) == static_cast<uint8_t>(SolvePath::kRobust)) return false;
    return s.specular_status.empty() || s.specular_status(x, y) != static_cast<uint8_t>(SpecularStatus::kEstimated);
  }

  // Solved pixels of the block's region with a specular lobe (per pixel or shared).
  int LobePixels(int x0, int y0, int x1, int y1) const {
    const PhotometricSolution& s = *job_.solution;
    if (s.specular_status.empty()) return 0;
    int count = 0;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) {
        if (job_.region != nullptr && (*job_.region)(x, y) == 0) continue;
        count += s.status(x, y) == static_cast<uint8_t>(PixelStatus::kSolved) &&
                 s.specular_status(x, y) == static_cast<uint8_t>(SpecularStatus::kEstimated);
      }
    }
    return count;
  }

  // Two-means on the albedo chromaticity (RGB input); one cluster when the
  // centres are within albedo_split.
  void SplitByAlbedo() {
    const size_t count = candidates_.size();
    cluster_.assign(count, 0);
    if (!rgb_) return;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& c : chroma_) mean += c;
    mean /= double(count);
    size_t far_a = 0, far_b = 0;
    for (size_t i = 0; i < count; ++i) {
      if ((chroma_[i] - mean).squaredNorm() > (chroma_[far_a] - mean).squaredNorm()) far_a = i;
    }
    for (size_t i = 0; i < count; ++i) {
      if ((chroma_[i] - chroma_[far_a]).squaredNorm() > (chroma_[far_b] - chroma_[far_a]).squaredNorm()) far_b = i;
    }
    Eigen::Vector2d centre[2] = {chroma_[far_a], chroma_[far_b]};
    if (!((centre[0] - centre[1]).norm() > options_.albedo_split)) return;
    for (int iteration = 0; iteration < 8; ++iteration) {
      Eigen::Vector2d sum[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
      int members[2] = {0, 0};
      for (size_t i = 0; i < count; ++i) {
        const int c = (chroma_[i] - centre[1]).squaredNorm() < (chroma_[i] - centre[0]).squaredNorm();
        cluster_[i] = c;
        sum[c] += chroma_[i];
        ++members[c];
      }
      for (int c = 0; c < 2; ++c) {
        if (members[c] > 0) centre[c] = sum[c] / members[c];
      }
    }
    if (!((centre[0] - centre[1]).norm() > options_.albedo_split)) std::fill(cluster_.begin(), cluster_.end(), 0);
  }

  // The samples of `cells` (in row order) into pixels_ and the sample
  // arrays, with each pixel's least-squares fit on them.
  void Gather(const std::vector<Cell>& cells) {
    pixels_.clear();
    lights_k_.clear(), halves_.clear(), values_.clear(), views_.clear();
    if (!classified_) {
      kind_ = lights_.Classify(tiled::LightSharing::kWithinTolerance, x0_, y0_, x1_, y1_);
      classified_ = true;
    }
    const tiled::AccumulateSpanFn accumulate =
        kind_ == tiled::TileLights::kUniform ? accumulate_uniform_ : accumulate_exact_;
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
        lights_.FillRow(kind_, x0_, x1_, row, &buffers_);
        accumulate(job_, lights_.shared(), x0_, span.count, row, &buffers_);
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
      view = view.allFinite() && view.norm() > 0 ? view.normalized() : Eigen::Vector3d::UnitZ();
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
  void FitShared(double* width, double* f0) {
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

  // A quick look, at the least-squares normals of the group's candidates on
  // two rows of the block, on every other rung of the width ladder: the
  // residual a sheen can take out of them (their scaled normals projected
  // out) must reach half the drop asked for, or the group keeps its
  // least-squares results without gathering the fit pixels or re-solving
  // any (the cost of a Lambertian scene: 16 MP, 10 LEDs).
  bool QuickLook() {
    row_cells_.clear();
    for (const Cell& c : group_) {
      if (c.y - y0_ == kFitRowStep / 2 || c.y - y0_ == kFitRowStep / 2 + options_.block_size / 2) row_cells_.push_back(c);
    }
    Gather(row_cells_);
    if (pixels_.size() < 8) return true;  // too few to judge: the full fit decides
    PrepareGeometry();
    double best_gain = 0, rss_ls_sum = 0;
    for (const Pixel& p : pixels_) rss_ls_sum += p.rss_ls;
    const double lo = std::log(options_.min_width), hi = std::log(options_.max_width);
    for (int i = 1; i < kWidthLadder; i += 2) {
      double amplitude = 0;
      best_gain = std::max(best_gain, SheenGain(std::exp(lo + (hi - lo) * i / (kWidthLadder - 1)), &amplitude));
    }
    return best_gain >= 0.5 * options_.min_residual_drop * rss_ls_sum;
  }

  void RefineGroup(Counts* counts) {
    ++counts->tried;
    if (!QuickLook()) return;
    ChooseFitCells();
    Gather(fit_cells_);
    if (static_cast<int>(pixels_.size()) < std::min(options_.min_pixels, options_.max_fit_pixels) / 2) return;
    PrepareGeometry();
    double width = 1, f0 = 0;
    for (int iteration = 0; iteration < options_.iterations; ++iteration) {
      if (iteration > 0) PrepareGeometry();
      FitShared(&width, &f0);
      if (!(f0 > 0)) return;
      for (Pixel& p : pixels_) Resolve(&p, width, f0);
    }
    // Model selection on the fit pixels' samples together: the shared sheen
    // (two parameters for the group, the pixels' own three each as before)
    // against their least-squares fits.
    double samples = 0, rss_ls = 0, rss = 0, floor_rss = 0;
    for (const Pixel& p : pixels_) {
      samples += p.count;
      rss_ls += p.rss_ls, rss += p.rss;
      floor_rss += p.count * std::pow(kResidualFloor * p.m_ls.norm(), 2);
    }
    const double lambert = std::max(rss_ls, floor_rss), sheen = std::max(rss, floor_rss);
    const bool pays = samples * std::log(lambert / sheen) > 2 * options_.bic_penalty * std::log(samples);
    const bool drops = rss <= (1 - options_.min_residual_drop) * rss_ls;
    double white_gain = 0, diffuse_gain = 0;
    ColourTest(width, &white_gain, &diffuse_gain);
    // (Not in the Bayer domain: one raw sample per light and pixel carries
    // too little colour to tell, cloth there 0.592 -> 0.61 deg with it.)
    const bool white = !options_.dichromatic || job_.bayer || white_gain >= options_.white_margin * diffuse_gain;
    if (!pays || !drops || !white) return;
    ++counts->taken;
    counts->f0_sum += f0, counts->width_sum += width;
    // Every candidate of the group under the group's sheen.
    Gather(group_);
    for (Pixel& p : pixels_) {
      Resolve(&p, width, f0);
      counts->refined += Write(p);
    }
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
  PixelSamples samples_;
  int x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0;
  bool classified_ = false;
  tiled::TileLights kind_ = tiled::TileLights::kExact;
  std::vector<Cell> candidates_, group_, fit_cells_, row_cells_;
  std::vector<Eigen::Vector2d> chroma_;
  std::vector<int> cluster_;
  std::vector<Pixel> pixels_;
  std::vector<Eigen::Vector3d> lights_k_, halves_, views_;
  std::vector<Eigen::Vector4d> values_;  // luminance, R, G, B (intensity divided)
  std::vector<VelvetSheenGeometry> geometry_;
  std::vector<double> sheen_;
};

}  // namespace

void CoherentSheenOptions::Check() const {
  if (block_size < 4 || block_size > 256) throw FieldError(kOptions, "block_size", block_size, "must lie in [4, 256]");
  if (min_pixels < 8 || min_pixels > 65536) throw FieldError(kOptions, "min_pixels", min_pixels, "must lie in [8, 65536]");
  if (max_fit_pixels < 8 || max_fit_pixels > 65536) {
    throw FieldError(kOptions, "max_fit_pixels", max_fit_pixels, "must lie in [8, 65536]");
  }
  if (iterations < 1 || iterations > 10) throw FieldError(kOptions, "iterations", iterations, "must lie in [1, 10]");
  if (!(min_width > 0) || !(min_width < max_width)) {
    throw FieldError(kOptions, "min_width", min_width, "must be > 0 and below max_width");
  }
  if (!(max_width <= 10)) throw FieldError(kOptions, "max_width", max_width, "must be <= 10");
  if (!(albedo_split >= 0) || std::isnan(albedo_split)) {
    throw FieldError(kOptions, "albedo_split", albedo_split, "must be >= 0");
  }
  if (max_lights < 3 || max_lights > 1000) throw FieldError(kOptions, "max_lights", max_lights, "must lie in [3, 1000]");
  if (!(bic_penalty >= 0) || !std::isfinite(bic_penalty)) {
    throw FieldError(kOptions, "bic_penalty", bic_penalty, "must be finite and >= 0");
  }
  if (!(min_residual_drop >= 0 && min_residual_drop < 1)) {
    throw FieldError(kOptions, "min_residual_drop", min_residual_drop, "must lie in [0, 1)");
  }
  if (!(white_margin > 0) || !std::isfinite(white_margin)) {
    throw FieldError(kOptions, "white_margin", white_margin, "must be finite and > 0");
  }
  if (!(max_lobe_fraction >= 0) || std::isnan(max_lobe_fraction)) {
    throw FieldError(kOptions, "max_lobe_fraction", max_lobe_fraction, "must be >= 0");
  }
  if (num_threads < 0 || num_threads > 256) throw FieldError(kOptions, "num_threads", num_threads, "must lie in [0, 256]");
}

std::string CoherentSheenSummary::BriefReport() const {
  std::ostringstream out;
  out << "Coherent sheen: " << TerminationName(termination) << ", " << pixels_refined << " of " << pixels_candidate
      << " candidate pixels re-solved under a shared velvet sheen in " << groups_taken << " of " << groups_tried
      << " groups (mean F0 " << Fixed(mean_f0, 4) << ", width " << Fixed(mean_width, 3) << "), " << Fixed(seconds, 2)
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
  const int width = job.field->width(), height = job.field->height();
  const int block = options.block_size;
  const int blocks_x = (width + block - 1) / block, blocks_y = (height + block - 1) / block;
  const int num_blocks = blocks_x * blocks_y;
  const int num_threads = std::clamp(ResolveThreadCount(options.num_threads), 1, std::max(1, num_blocks));
  std::vector<std::unique_ptr<BlockRefiner>> workers(num_threads);
  std::vector<Counts> counts(num_threads);
  std::atomic<int> blocks_done{0};
  // Each block writes only its own pixels and reads only its own samples and
  // per-pixel results, so the result does not depend on the thread count.
  const bool finished = ParallelFor(
      num_blocks, num_threads, 4,
      [&](int first, int last, int worker) {
        if (!workers[worker]) workers[worker] = std::make_unique<BlockRefiner>(options, job);
        for (int b = first; b < last; ++b) {
          const int bx = b % blocks_x, by = b / blocks_x;
          workers[worker]->Refine(bx * block, by * block, std::min(width, (bx + 1) * block),
                                  std::min(height, (by + 1) * block), &counts[worker]);
          ++blocks_done;
        }
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(double(done) / num_blocks); })
               : std::function<bool(int)>());
  double f0_sum = 0, width_sum = 0;
  for (const Counts& c : counts) {
    summary.pixels_candidate += c.candidates;
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
  if (!finished) {
    summary.SetCancelled("cancelled after " + std::to_string(blocks_done.load()) + " of " +
                         std::to_string(num_blocks) + " blocks");
  } else {
    summary.termination = Termination::kSuccess;
    if (progress) progress(1.0);
  }
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
  tiled::SolveJob job;
  job.options = &solver_options;
  job.field = input.light_field;
  job.images = &input.images;
  job.sample_valid = &input.sample_valid;
  job.region = input.region;
  job.num_lights = input.light_field->num_lights();
  job.with_albedo = !solution->albedo.empty();
  job.with_confidence = !solution->residual.empty();
  job.solution = solution;
  return tiled::RefineCoherentSheenOfJob(options, job, progress);
}

}  // namespace scanbench
