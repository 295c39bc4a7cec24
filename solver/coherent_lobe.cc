#include "solver/coherent_lobe.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "core/field_error.h"
#include "core/format.h"
#include "solver/block_refiner.h"
#include "solver/levenberg_marquardt.h"
#include "solver/pixel_fit_internal.h"
#include "solver/pixel_solvers.h"
#include "solver/tile_lights.h"
#include "solver/tiled_solve.h"

namespace scanbench {
namespace {

using pixel_fit::AmplitudeSums;
using pixel_fit::kMadToSigma;
using pixel_fit::kMinViewCosine;
using pixel_fit::kTukeyWidth;
using pixel_fit::kUsedWeight;
using pixel_fit::MedianAbs;
using pixel_fit::TangentBasis;
using pixel_fit::TukeyWeight;
using pixel_fit::UnitViewOrZ;

constexpr const char* kOptions = "CoherentLobeOptions";
constexpr int kMinSamples = 6;             // per pixel: 3 or 4 parameters and spares
// Levenberg-Marquardt steps of one pixel's re-solve: 4 would save 6 % of the
// pass for satin +0.002 deg and bear at 10 lights +0.01 (docs/solver.md).
constexpr int kNormalIterations = 6;
constexpr double kNormalConverged = 1e-4;  // rad: a smaller normal step has converged
constexpr double kDerivativeStep = 1e-5;   // rad, forward differences of the lobe by the normal
// The shape grid of the first fit: the azimuth over [0, pi) (the lobe is
// symmetric under a half turn) and alpha_t <= alpha_b (the other order is the
// azimuth turned by pi / 2).
constexpr int kAzimuthSteps = 8;
constexpr double kAlphaGrid[] = {0.03, 0.06, 0.12, 0.25, 0.5};
constexpr int kPatternEvaluations = 40;    // shape evaluations of one pattern search
// A group takes the Fresnel-transmitted diffuse term only where it leaves at
// most this fraction of the Lambertian fit's residual: with 10 lights its
// steeper falloff can lower the residual by bending the normals (without the
// highlight weighting, margin 1: satin 1.318 deg, but DiLiGenT bear at 10
// ring lights 5.567 -> 5.966; 0.85: 1.400, bear 5.588; 0.7: 1.517, bear
// 5.569. With it (highlight_weight 30, the group's pixels taking its
// result): 0.85: satin 1.072, bear 5.471; 0.7: 1.209, bear 5.417).
constexpr double kFresnelMargin = 0.85;

// The diffuse term's cosine factor under the shared lobe: Lambert's n . l,
// or with `fresnel` the light that crosses a Schlick-Fresnel interface on
// the way in, (1 - F(n . l)) / (1 - F0) = 1 - (1 - n . l)^5 (independent of
// F0; the way out, 1 - F(n . v), is one factor per pixel and goes into rho_d).
double DiffuseCosine(double nl, bool fresnel) {
  if (!(nl > 0)) return 0.0;
  if (!fresnel) return nl;
  const double m = 1 - nl, m2 = m * m;
  return nl * (1 - m2 * m2 * m);
}
// Its derivative by n . l.
double DiffuseCosineDerivative(double nl, bool fresnel) {
  if (!(nl > 0)) return 0.0;
  if (!fresnel) return 1.0;
  const double m = 1 - nl, m2 = m * m;
  return (1 - m2 * m2 * m) + 5 * nl * m2 * m2;
}

double Clamp01Alpha(double alpha, const CoherentLobeOptions& o) { return std::clamp(alpha, o.min_alpha, o.max_alpha); }

// The lobe shape shared by a group.
struct Shape {
  double log_alpha_t = 0, log_alpha_b = 0, azimuth = 0;
  Eigen::Vector3d along = Eigen::Vector3d::UnitX();  // (cos, sin, 0) of the azimuth, kept with it

  void SetAzimuth(double radians) {
    azimuth = radians;
    along = Eigen::Vector3d(std::cos(radians), std::sin(radians), 0.0);
  }
};

// Tangent t: the unit vector `along` (in the table plane) projected into n's
// tangent plane; b = n x t.
void TangentFrame(const Eigen::Vector3d& n, const Eigen::Vector3d& along, Eigen::Vector3d* t, Eigen::Vector3d* b) {
  Eigen::Vector3d projected = along - along.dot(n) * n;
  double length = projected.norm();
  if (!(length > 1e-6)) {  // n along the azimuth (a grazing normal): any tangent
    const Eigen::Vector3d helper = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    projected = helper - helper.dot(n) * n;
    length = projected.norm();
  }
  *t = projected / length;
  *b = n.cross(*t);
}

// Smith's Lambda of the anisotropic GGX distribution for direction w in the
// frame (t, b, n) (Heitz 2014, eq. 86).
double SmithLambda(double wt, double wb, double wn, double alpha_t, double alpha_b) {
  const double wn2 = std::max(wn * wn, 1e-12);
  const double a2_tan2 = (alpha_t * alpha_t * wt * wt + alpha_b * alpha_b * wb * wb) / wn2;
  return 0.5 * (std::sqrt(1.0 + a2_tan2) - 1.0);
}

// S of the header comment; `masking` multiplies it by the height-correlated
// Smith masking-shadowing G = 1 / (1 + Lambda(l) + Lambda(v)) (the shared
// lobe's model; FitDiffuseLobe's per-pixel one has no G).
double ShapeTerm(const Eigen::Vector3d& n, const Eigen::Vector3d& t, const Eigen::Vector3d& b,
                 const Eigen::Vector3d& h, const Eigen::Vector3d& l, const Eigen::Vector3d& view, double alpha_t,
                 double alpha_b, bool masking = true) {
  const double nv = std::max(n.dot(view), kMinViewCosine);
  const double ht = h.dot(t) / alpha_t, hb = h.dot(b) / alpha_b, hn = h.dot(n);
  const double q = ht * ht + hb * hb + hn * hn;  // >= 1 for alphas <= 1 and unit h
  const double s = 1.0 / (4 * nv * alpha_t * alpha_b * q * q);
  if (!masking) return s;
  const double g = 1.0 / (1.0 + SmithLambda(l.dot(t), l.dot(b), std::max(n.dot(l), 0.0), alpha_t, alpha_b) +
                          SmithLambda(view.dot(t), view.dot(b), nv, alpha_t, alpha_b));
  return s * g;
}

// Weighted least squares b ~ d a + s c with s >= 0 (diffuse and lobe
// amplitudes): s from both, clamped at 0, then d given s (not
// SolveAmplitudes' re-solve of d alone at the bound). False when singular.
bool NonNegativeLobeAmplitudes(const AmplitudeSums& sums, double* d, double* s) {
  const double aa = sums.aa, ac = sums.ac, cc = sums.cc, ab = sums.ab, cb = sums.cb;
  if (!(aa > 0)) return false;
  const double det = aa * cc - ac * ac;
  *s = det > 1e-12 * aa * cc ? (aa * cb - ac * ab) / det : 0.0;
  if (!(*s > 0)) *s = 0;
  *d = (ab - *s * ac) / aa;
  return std::isfinite(*d) && std::isfinite(*s);
}

// One supported pixel of a block and its samples (a range of the block's
// sample arrays).
struct Pixel {
  int x = 0, y = 0;
  int first = 0, count = 0;
  Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // current estimate
  double rho_d = 0, rho_s = 0;                        // current amplitudes (luminance)
  Eigen::Vector2d chroma = Eigen::Vector2d::Zero();   // r, g of the albedo / its sum
  // The per-pixel result it came with (what BIC compares against).
  Eigen::Vector3d own_normal = Eigen::Vector3d::UnitZ();
  double own_alpha = 0;  // its isotropic lobe's alpha; 0 = Lambertian
  // Its own raw CFA samples (with lobe mosaics): a second range of the
  // block's sample arrays, each value its channel's intensity-divided sample.
  int bayer_first = 0, bayer_count = 0;
};

// Everything one worker needs per block; reused between blocks.
class BlockRefiner {
 public:
  // `bayer_job`: the raw mosaics of the same frames (job.bayer), whose
  // solution takes the Bayer-domain re-solves; null = none.
  BlockRefiner(const CoherentLobeOptions& options, const PhotometricSolverOptions& solver_options,
               const tiled::SolveJob& job, const tiled::SolveJob* bayer_job)
      : options_(options),
        solver_(solver_options),
        job_(job),
        bayer_job_(bayer_job),
        buffers_(job.num_lights, options.block_size),
        lights_(job),
        accumulate_exact_(tiled::ChooseAccumulator(false, true, false)),
        accumulate_uniform_(tiled::ChooseAccumulator(false, true, true)),
        samples_(job.num_lights),
        width_(solver_options.robust_loss_width > 0 ? solver_options.robust_loss_width : kTukeyWidth) {
    if (bayer_job_ != nullptr) {
      bayer_buffers_ = std::make_unique<tiled::SpanBuffers>(job.num_lights, options.block_size);
      bayer_lights_ = std::make_unique<tiled::TileLightSampler>(*bayer_job_);
    }
  }

  struct Counts {
    size_t supported = 0, groups = 0, refined = 0, kept = 0, fresnel_groups = 0, bayer = 0;
    double anisotropy_sum = 0;
  };

  // ---- the steps of RefineBlock (solver/block_refiner.h) ----------------

  // The block's solved pixels and their samples, where it has min_pixels
  // lobe pixels.
  bool CollectBlock(int x0, int y0, int x1, int y1, Counts* counts) {
    int lobe_pixels = 0;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) lobe_pixels += HasLobe(x, y);
    }
    counts->supported += lobe_pixels;
    return lobe_pixels >= options_.min_pixels && Collect(x0, y0, x1, y1);
  }

  int GroupByAlbedo() {
    SplitByAlbedo();
    return num_clusters_;
  }

  // The group's own pixels must show the lobe: a lobe pixel of one colour
  // does not make one for a neighbour of another.
  bool GatherGroup(int g) {
    group_.clear();
    int group_lobes = 0;
    for (size_t i = 0; i < pixels_.size(); ++i) {
      if (cluster_[i] != g) continue;
      group_.push_back(static_cast<int>(i));
      group_lobes += pixels_[i].own_alpha > 0;
    }
    return !(2 * group_lobes < options_.min_pixels || static_cast<int>(group_.size()) < options_.min_pixels);
  }

  // The group's lobe (shape, F0, diffuse term) and every pixel's normal and
  // amplitudes under it; false when the group shows no lobe.
  bool FitGroup(Counts* counts) {
    ChooseFitPixels();
    if (!ChooseDiffuseTerm(&group_shape_, &group_rho_s_)) return false;
    if (options_.iterations == 1) {
      for (int index : group_) SolvePixel(&pixels_[index], group_shape_, group_rho_s_);
    }
    for (int iteration = 1; iteration < options_.iterations; ++iteration) {
      group_shape_ = FitShape(group_shape_, false, &group_rho_s_);
      if (!options_.per_pixel_amplitude && !(group_rho_s_ > 0)) return false;  // no lobe for the group
      // Only the pixels the shape is fitted on need their normals before the
      // last alternation.
      const bool last = iteration + 1 == options_.iterations;
      for (int index : last ? group_ : fit_) SolvePixel(&pixels_[index], group_shape_, group_rho_s_);
    }
    ++counts->groups;
    counts->fresnel_groups += fresnel_;
    counts->anisotropy_sum += std::exp(std::abs(group_shape_.log_alpha_b - group_shape_.log_alpha_t));
    return true;
  }

  // Each pixel takes the group's lobe where Select prefers it.
  void WriteGroup(Counts* counts) {
    for (int index : group_) {
      if (Select(pixels_[index], group_shape_)) {
        ++counts->refined;
        if (bayer_job_ != nullptr) counts->bayer += ResolveBayer(pixels_[index], group_shape_, group_rho_s_);
      } else {
        ++counts->kept;
      }
    }
  }

 private:
  // The supported pixels of the block and their samples; false when none.
  bool Collect(int x0, int y0, int x1, int y1) {
    const PhotometricSolution& s = *job_.solution;
    pixels_.clear();
    lights_k_.clear(), halves_.clear(), values_.clear(), weights_.clear();
    bool any = false;
    for (int y = y0; y < y1 && !any; ++y) {
      for (int x = x0; x < x1 && !any; ++x) any = Supported(x, y);
    }
    if (!any) return false;
    const tiled::TileLights kind = lights_.Classify(LightSharing::kWithinTolerance, x0, y0, x1, y1);
    const tiled::AccumulateSpanFn accumulate =
        kind == tiled::TileLights::kUniform ? accumulate_uniform_ : accumulate_exact_;
    tiled::Span span;
    span.lights = kind;
    span.x0 = x0;
    span.count = x1 - x0;
    span.buffers = &buffers_;
    span.shared = &lights_.shared();
    // The same pixels' raw samples: the light field is the same, the layout
    // one CFA channel per pixel.
    tiled::Span bayer_span = span;
    tiled::AccumulateSpanFn bayer_accumulate = nullptr;
    if (bayer_job_ != nullptr) {
      bayer_span.lights = bayer_lights_->Classify(LightSharing::kWithinTolerance, x0, y0, x1, y1);
      bayer_span.buffers = bayer_buffers_.get();
      bayer_span.shared = &bayer_lights_->shared();
      bayer_accumulate = tiled::ChooseAccumulator(true, false, bayer_span.lights == tiled::TileLights::kUniform);
    }
    for (int y = y0; y < y1; ++y) {
      bool row_any = false;
      for (int x = x0; x < x1 && !row_any; ++x) row_any = Supported(x, y);
      if (!row_any) continue;
      lights_.FillRow(kind, x0, x1, y, &buffers_);
      accumulate(job_, lights_.shared(), x0, span.count, y, &buffers_);
      span.y = y;
      if (bayer_job_ != nullptr) {
        bayer_lights_->FillRow(bayer_span.lights, x0, x1, y, bayer_buffers_.get());
        bayer_accumulate(*bayer_job_, bayer_lights_->shared(), x0, span.count, y, bayer_buffers_.get());
        bayer_span.y = y;
      }
      for (int x = x0; x < x1; ++x) {
        if (!Supported(x, y) || buffers_.light_bad[x - x0]) continue;
        tiled::GatherSamples(span, x - x0, true, &samples_);
        if (samples_.count() < kMinSamples) continue;
        Pixel p;
        p.x = x, p.y = y;
        float view[3];
        job_.field->ViewDirection(x, y, view);
        p.view = Eigen::Vector3d(view[0], view[1], view[2]);
        p.view = UnitViewOrZ(p.view);
        p.own_normal = Eigen::Vector3d(s.normal_in_table(x, y, 0), s.normal_in_table(x, y, 1),
                                       s.normal_in_table(x, y, 2)).normalized();
        p.normal = p.own_normal;
        p.own_alpha = s.specular_status(x, y) == static_cast<uint8_t>(SpecularStatus::kEstimated) ? s.specular(x, y, 1) : 0.0f;
        const Eigen::Vector3d albedo = s.albedo.empty()
                                           ? Eigen::Vector3d::Ones()
                                           : Eigen::Vector3d(s.albedo(x, y, 0), s.albedo(x, y, 1), s.albedo(x, y, 2));
        const double sum = albedo.sum();
        p.chroma = sum > 0 ? Eigen::Vector2d(albedo[0] / sum, albedo[1] / sum) : Eigen::Vector2d(1.0 / 3, 1.0 / 3);
        p.first = static_cast<int>(lights_k_.size());
        p.count = samples_.count();
        const double* l = samples_.light_data();
        const double* v = samples_.value_data();
        for (int k = 0; k < p.count; ++k) {
          const Eigen::Vector3d light(l[3 * k], l[3 * k + 1], l[3 * k + 2]);
          const Eigen::Vector3d sum_lv = light + p.view;
          const double length = sum_lv.norm();
          lights_k_.push_back(light);
          halves_.push_back(length > 1e-6 ? Eigen::Vector3d(sum_lv / length) : p.view);
          values_.emplace_back(v[4 * k], v[4 * k + 1], v[4 * k + 2], v[4 * k + 3]);
          weights_.push_back(length > 1e-6 && light.dot(p.normal) > 0 ? 1.0 : 0.0);
        }
        if (bayer_job_ != nullptr && !bayer_buffers_->light_bad[x - x0]) {
          tiled::GatherSamples(bayer_span, x - x0, false, &samples_);
          p.bayer_first = static_cast<int>(lights_k_.size());
          p.bayer_count = samples_.count();
          const double* bl = samples_.light_data();
          const double* bv = samples_.value_data();
          for (int k = 0; k < p.bayer_count; ++k) {
            const Eigen::Vector3d light(bl[3 * k], bl[3 * k + 1], bl[3 * k + 2]);
            const Eigen::Vector3d sum_lv = light + p.view;
            const double length = sum_lv.norm();
            lights_k_.push_back(light);
            halves_.push_back(length > 1e-6 ? Eigen::Vector3d(sum_lv / length) : p.view);
            values_.emplace_back(bv[4 * k], 0.0, 0.0, 0.0);
            weights_.push_back(0.0);
          }
        }
        pixels_.push_back(p);
      }
    }
    return !pixels_.empty();
  }

  // Solved pixels of the region: the candidates of a block with lobe pixels.
  bool Supported(int x, int y) const {
    if (job_.region != nullptr && (*job_.region)(x, y) == 0) return false;
    return job_.solution->status(x, y) == static_cast<uint8_t>(PixelStatus::kSolved);
  }
  bool HasLobe(int x, int y) const {
    return Supported(x, y) &&
           job_.solution->specular_status(x, y) == static_cast<uint8_t>(SpecularStatus::kEstimated);
  }

  // The block's pixels in albedo groups (cluster_, num_clusters_): k-means
  // on the albedo chromaticity, k up to max_groups: the
  // centres start at the pixel furthest from the mean, then each next at the
  // pixel furthest from those chosen, while that is more than albedo_split
  // from all of them; then 8 Lloyd steps. One cluster when no two centres
  // are further apart than albedo_split.
  void SplitByAlbedo() {
    KMeansByAlbedo(options_.max_albedo_groups);
    if (num_clusters_ <= 2) return;
    // More groups than warp and weft only where each can be fitted on its
    // own (RefineGroup's rule: min_pixels pixels, half as many with a
    // per-pixel lobe); else the block is split in two as before. Without
    // the rule a third centre is often a few outliers of the albedo
    // (DiLiGenT bear at 10 lights: 5.471 -> 5.557 deg; with it 5.469).
    std::vector<int> members(num_clusters_, 0), lobes(num_clusters_, 0);
    for (size_t i = 0; i < pixels_.size(); ++i) {
      ++members[cluster_[i]];
      lobes[cluster_[i]] += pixels_[i].own_alpha > 0;
    }
    for (int c = 0; c < num_clusters_; ++c) {
      if (members[c] < options_.min_pixels || 2 * lobes[c] < options_.min_pixels) {
        KMeansByAlbedo(std::min(2, options_.max_albedo_groups));
        return;
      }
    }
  }

  void KMeansByAlbedo(int max_groups) {
    const size_t count = pixels_.size();
    cluster_.assign(count, 0);
    num_clusters_ = 1;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Pixel& p : pixels_) mean += p.chroma;
    mean /= double(count);
    size_t far_a = 0;
    for (size_t i = 0; i < count; ++i) {
      if ((pixels_[i].chroma - mean).squaredNorm() > (pixels_[far_a].chroma - mean).squaredNorm()) far_a = i;
    }
    std::vector<Eigen::Vector2d> centre = {pixels_[far_a].chroma};
    auto nearest = [&](const Eigen::Vector2d& c, double* distance2) {
      int best = 0;
      *distance2 = std::numeric_limits<double>::infinity();
      for (size_t j = 0; j < centre.size(); ++j) {
        const double d2 = (c - centre[j]).squaredNorm();
        if (d2 < *distance2) *distance2 = d2, best = static_cast<int>(j);
      }
      return best;
    };
    const double split2 = options_.albedo_split * options_.albedo_split;
    while (static_cast<int>(centre.size()) < max_groups) {
      size_t far = 0;
      double far_d2 = -1;
      for (size_t i = 0; i < count; ++i) {
        double d2 = 0;
        nearest(pixels_[i].chroma, &d2);
        if (d2 > far_d2) far_d2 = d2, far = i;
      }
      if (!(far_d2 > split2)) break;
      centre.push_back(pixels_[far].chroma);
    }
    if (centre.size() == 1) return;
    std::vector<Eigen::Vector2d> sum(centre.size());
    std::vector<int> members(centre.size());
    for (int iteration = 0; iteration < 8; ++iteration) {
      std::fill(sum.begin(), sum.end(), Eigen::Vector2d::Zero());
      std::fill(members.begin(), members.end(), 0);
      for (size_t i = 0; i < count; ++i) {
        double d2 = 0;
        const int c = nearest(pixels_[i].chroma, &d2);
        cluster_[i] = c;
        sum[c] += pixels_[i].chroma;
        ++members[c];
      }
      for (size_t c = 0; c < centre.size(); ++c) {
        if (members[c] > 0) centre[c] = sum[c] / members[c];
      }
    }
    double widest2 = 0;
    for (size_t a = 0; a < centre.size(); ++a) {
      for (size_t b = a + 1; b < centre.size(); ++b) widest2 = std::max(widest2, (centre[a] - centre[b]).squaredNorm());
    }
    if (!(widest2 > split2)) {
      std::fill(cluster_.begin(), cluster_.end(), 0);
      return;
    }
    num_clusters_ = static_cast<int>(centre.size());
  }

  // ---- the shared shape, normals held ----------------------------------

  // What ShapeCost needs of one fit pixel's used sample, in the pixel's own
  // terms: the normals and weights are held while the shape is fitted, so
  // the shape's tangent frame enters only through the azimuth's (cos, sin),
  // t . w = (a . w - (a . n)(n . w)) / |a - (a . n) n|, b . w = a . (w x n) / |...|
  // (a the unit azimuth vector in the table plane), and everything else is
  // computed once per fit.
  struct FitSample {
    double w, nl, value;
    double hx, hy, hn, hcx, hcy;  // h: table x, y, along n; (h x n) x, y
    double lx, ly, ln, lcx, lcy;  // l: the same
  };
  struct FitPixel {
    int first = 0, count = 0;  // range of fit_samples_
    double nx = 0, ny = 0, nv = 1, vx = 0, vy = 0, vcx = 0, vcy = 0;
    double aa = 0, a_b = 0, bb = 0;  // shape-free sums
    int index = 0;                   // into pixels_ (the rare fallback of a normal along the azimuth)
  };

  void PrepareFit(const std::vector<int>& fit) {
    fit_pixels_.clear();
    fit_samples_.clear();
    for (int index : fit) {
      const Pixel& p = pixels_[index];
      const Eigen::Vector3d& n = p.normal;
      FitPixel f;
      f.index = index;
      f.first = static_cast<int>(fit_samples_.size());
      f.nx = n.x(), f.ny = n.y();
      f.nv = std::max(n.dot(p.view), kMinViewCosine);
      const Eigen::Vector3d vc = p.view.cross(n);
      f.vx = p.view.x(), f.vy = p.view.y(), f.vcx = vc.x(), f.vcy = vc.y();
      for (int k = p.first; k < p.first + p.count; ++k) {
        const double w = weights_[k];
        if (!(w > 0)) continue;
        FitSample q;
        q.w = w;
        const double raw_nl = std::max(0.0, n.dot(lights_k_[k]));
        q.nl = DiffuseCosine(raw_nl, fresnel_);
        q.value = values_[k][0];
        const Eigen::Vector3d& h = halves_[k];
        const Eigen::Vector3d& l = lights_k_[k];
        const Eigen::Vector3d hc = h.cross(n), lc = l.cross(n);
        q.hx = h.x(), q.hy = h.y(), q.hn = h.dot(n), q.hcx = hc.x(), q.hcy = hc.y();
        q.lx = l.x(), q.ly = l.y(), q.ln = raw_nl, q.lcx = lc.x(), q.lcy = lc.y();
        f.aa += w * q.nl * q.nl, f.a_b += w * q.nl * q.value, f.bb += w * q.value * q.value;
        fit_samples_.push_back(q);
      }
      f.count = static_cast<int>(fit_samples_.size()) - f.first;
      fit_pixels_.push_back(f);
    }
  }

  // The group's cost under `shape` on the prepared fit pixels, amplitudes
  // projected out (per pixel rho_d; rho_s shared or per pixel); the shared
  // F0 into *rho_s. The same value as ShapeTerm's model, term by term.
  double ShapeCost(const Shape& shape, double* shared_rho_s) {
    const double at = std::exp(shape.log_alpha_t), ab = std::exp(shape.log_alpha_b);
    const double ca = shape.along.x(), sa = shape.along.y();
    const double at2 = at * at, ab2 = ab * ab, inv_at = 1 / at, inv_ab = 1 / ab;
    double big_a = 0, big_b = 0, base = 0, own = 0;
    for (const FitPixel& f : fit_pixels_) {
      if (!(f.aa > 0)) continue;
      const double an = ca * f.nx + sa * f.ny;
      const double length2 = 1 - an * an;
      double ac = 0, cc = 0, c_b = 0;
      if (length2 > 1e-12) {
        const double inv_length = 1 / std::sqrt(length2);
        const double vt = (ca * f.vx + sa * f.vy - an * f.nv) * inv_length;
        const double vb = (ca * f.vcx + sa * f.vcy) * inv_length;
        // Smith's Lambda of the view, as SmithLambda with wn = n . v floored.
        const double lambda_v = 0.5 * (std::sqrt(1.0 + (at2 * vt * vt + ab2 * vb * vb) / (f.nv * f.nv)) - 1.0);
        const double scale = 1 / (4 * f.nv * at * ab);
        for (int i = f.first; i < f.first + f.count; ++i) {
          const FitSample& q = fit_samples_[i];
          const double ht = (ca * q.hx + sa * q.hy - an * q.hn) * inv_length * inv_at;
          const double hb = (ca * q.hcx + sa * q.hcy) * inv_length * inv_ab;
          const double qq = ht * ht + hb * hb + q.hn * q.hn;
          const double lt = (ca * q.lx + sa * q.ly - an * q.ln) * inv_length;
          const double lb = (ca * q.lcx + sa * q.lcy) * inv_length;
          const double ln2 = std::max(q.ln * q.ln, 1e-12);
          const double lambda_l = 0.5 * (std::sqrt(1.0 + (at2 * lt * lt + ab2 * lb * lb) / ln2) - 1.0);
          const double s = scale / (qq * qq * (1.0 + lambda_l + lambda_v));
          ac += q.w * q.nl * s, cc += q.w * s * s, c_b += q.w * s * q.value;
        }
      } else {  // the normal along the azimuth: ShapeTerm's own fallback frame
        const Pixel& p = pixels_[f.index];
        Eigen::Vector3d t, b;
        TangentFrame(p.normal, shape.along, &t, &b);
        int i = f.first;
        for (int k = p.first; k < p.first + p.count; ++k) {
          if (!(weights_[k] > 0)) continue;
          const FitSample& q = fit_samples_[i++];
          const double s = ShapeTerm(p.normal, t, b, halves_[k], lights_k_[k], p.view, at, ab);
          ac += q.w * q.nl * s, cc += q.w * s * s, c_b += q.w * s * q.value;
        }
      }
      if (options_.per_pixel_amplitude) {
        const AmplitudeSums sums{f.aa, ac, cc, f.a_b, c_b, f.bb};
        double d = 0, s = 0;
        if (!NonNegativeLobeAmplitudes(sums, &d, &s)) continue;
        own += sums.Cost(d, s);
      } else {
        big_a += cc - ac * ac / f.aa;
        big_b += c_b - ac * f.a_b / f.aa;
        base += f.bb - f.a_b * f.a_b / f.aa;
      }
    }
    if (options_.per_pixel_amplitude) {
      *shared_rho_s = 0;
      return own;
    }
    const double rho_s = big_a > 0 ? std::max(0.0, big_b / big_a) : 0.0;
    *shared_rho_s = rho_s;
    return std::max(0.0, base - 2 * rho_s * big_b + rho_s * rho_s * big_a);
  }

  Shape Canonical(Shape shape) const {
    const double lo = std::log(options_.min_alpha), hi = std::log(options_.max_alpha);
    shape.log_alpha_t = std::clamp(shape.log_alpha_t, lo, hi);
    shape.log_alpha_b = std::clamp(shape.log_alpha_b, lo, hi);
    shape.SetAzimuth(std::remainder(shape.azimuth, std::numbers::pi));  // (-pi/2, pi/2]
    return shape;
  }

  // Grid (first fit) then a pattern search from the best point.
  Shape FitShape(const Shape& start, bool grid, double* best_rho_s) {
    // Within the bounds: a default Shape (alphas 1) is outside them, and
    // the pattern search only clamps its trials, so a start that beat the
    // grid was kept with alpha 1 (sqrt(alpha_t alpha_b) = 1 in the map).
    Shape best = Canonical(start);
    double rho_s = 0;
    PrepareFit(fit_);
    double best_cost = ShapeCost(best, &rho_s);
    *best_rho_s = rho_s;
    if (grid) {
      for (int j = 0; j < kAzimuthSteps; ++j) {
        for (size_t a = 0; a < std::size(kAlphaGrid); ++a) {
          for (size_t b = a; b < std::size(kAlphaGrid); ++b) {
            Shape trial;
            trial.SetAzimuth(j * std::numbers::pi / kAzimuthSteps);
            trial.log_alpha_t = std::log(Clamp01Alpha(kAlphaGrid[a], options_));
            trial.log_alpha_b = std::log(Clamp01Alpha(kAlphaGrid[b], options_));
            if (a == b && j > 0) continue;  // isotropic: the azimuth does not matter
            const double cost = ShapeCost(trial, &rho_s);
            if (cost < best_cost) best_cost = cost, best = trial, *best_rho_s = rho_s;
          }
        }
      }
    }
    double step[3] = {grid ? 0.35 : 0.15, grid ? 0.35 : 0.15, grid ? std::numbers::pi / 16 : std::numbers::pi / 48};
    const double min_step[3] = {0.01, 0.01, 0.003};
    int evaluations = 0;
    while (evaluations < kPatternEvaluations) {
      bool improved = false;
      for (int d = 0; d < 3 && evaluations < kPatternEvaluations; ++d) {
        for (int sign = -1; sign <= 1; sign += 2) {
          Shape trial = best;
          (d == 0 ? trial.log_alpha_t : d == 1 ? trial.log_alpha_b : trial.azimuth) += sign * step[d];
          trial = Canonical(trial);
          const double cost = ShapeCost(trial, &rho_s);
          ++evaluations;
          if (cost < best_cost) {
            best_cost = cost, best = trial, *best_rho_s = rho_s;
            improved = true;
            break;
          }
        }
      }
      if (!improved) {
        bool any = false;
        for (int d = 0; d < 3; ++d) {
          step[d] *= 0.5;
          any |= step[d] >= min_step[d];
        }
        if (!any) break;
      }
    }
    return best;
  }

  // ---- one pixel under the shared shape --------------------------------

  // Model value of sample k of `p` at normal n and amplitudes.
  double Model(const Pixel& p, int k, const Eigen::Vector3d& n, const Eigen::Vector3d& t, const Eigen::Vector3d& b,
               double rho_d, double rho_s, double at, double ab) const {
    const double nl = DiffuseCosine(n.dot(lights_k_[k]), fresnel_);
    return rho_d * nl + rho_s * ShapeTerm(n, t, b, halves_[k], lights_k_[k], p.view, at, ab);
  }

  // n . l (clamped at 0) and S of every sample of `p` at normal n, indexed
  // from p.first: computed once per normal and reused by the fits below.
  struct Terms {
    std::vector<double> nl, s;
  };
  void Evaluate(const Pixel& p, const Eigen::Vector3d& n, const Shape& shape, double at, double ab,
                Terms* terms) const {
    Eigen::Vector3d t, b;
    TangentFrame(n, shape.along, &t, &b);
    terms->nl.resize(p.count), terms->s.resize(p.count);
    // ShapeTerm with its view terms (n . v, Smith's Lambda of v) taken out
    // of the sample loop.
    const double nv = std::max(n.dot(p.view), kMinViewCosine);
    const double lambda_v = SmithLambda(p.view.dot(t), p.view.dot(b), nv, at, ab);
    const double scale = 1.0 / (4 * nv * at * ab);
    const double inv_at = 1 / at, inv_ab = 1 / ab;
    for (int i = 0; i < p.count; ++i) {
      const int k = p.first + i;
      const Eigen::Vector3d& l = lights_k_[k];
      const Eigen::Vector3d& h = halves_[k];
      const double nl = n.dot(l);
      terms->nl[i] = DiffuseCosine(nl, fresnel_);
      const double ht = h.dot(t) * inv_at, hb = h.dot(b) * inv_ab, hn = h.dot(n);
      const double q = ht * ht + hb * hb + hn * hn;
      const double lambda_l = SmithLambda(l.dot(t), l.dot(b), std::max(nl, 0.0), at, ab);
      terms->s[i] = scale / (q * q * (1.0 + lambda_l + lambda_v));
    }
  }

  // Amplitudes of `p` under `weights` (weights_ or normal_weights_; rho_s
  // fixed unless per_pixel_amplitude) and the weighted cost; infinity when
  // unsolvable.
  double ProjectAmplitudes(const Pixel& p, const Terms& terms, const std::vector<double>& weights, double* rho_d,
                           double* rho_s) const {
    AmplitudeSums sums;
    for (int i = 0; i < p.count; ++i) {
      const int k = p.first + i;
      const double w = weights[k];
      if (!(w > 0)) continue;
      const double value = values_[k][0], nl = terms.nl[i], s = terms.s[i];
      sums.bb += w * value * value;
      sums.aa += w * nl * nl, sums.ac += w * nl * s, sums.cc += w * s * s;
      sums.ab += w * nl * value, sums.cb += w * s * value;
    }
    if (!(sums.aa > 0)) return std::numeric_limits<double>::infinity();
    if (options_.per_pixel_amplitude) {
      if (!NonNegativeLobeAmplitudes(sums, rho_d, rho_s)) return std::numeric_limits<double>::infinity();
    } else {
      *rho_d = (sums.ab - *rho_s * sums.ac) / sums.aa;
    }
    return sums.Cost(*rho_d, *rho_s);
  }

  // Tukey weights of `p` at its current model (scale: 1.4826 MAD, floored at
  // robust_min_scale x rho_d) into weights_; samples facing away get 0. The
  // normal fit's weights, normal_weights_, are those divided by 1 +
  // highlight_weight x the sample's lobe fraction rho_s S / (rho_d c + rho_s
  // S): a highlight sample's value is mostly the lobe, whose shared shape
  // fits each pixel's highlight only roughly (fibre-scale variation of the
  // thread direction and roughness), so it steers the normal by its lobe's
  // error; the diffuse samples say where the normal is.
  void Reweight(const Pixel& p, const Terms& terms) {
    abs_residuals_.clear();
    for (int i = 0; i < p.count; ++i) {
      if (!(terms.nl[i] > 0)) continue;
      abs_residuals_.push_back(std::abs(p.rho_d * terms.nl[i] + p.rho_s * terms.s[i] - values_[p.first + i][0]));
    }
    const double scale =
        std::max(kMadToSigma * MedianAbs(&abs_residuals_), solver_.robust_min_scale * std::max(p.rho_d, 1e-6));
    for (int i = 0; i < p.count; ++i) {
      const double r = p.rho_d * terms.nl[i] + p.rho_s * terms.s[i] - values_[p.first + i][0];
      const double w = terms.nl[i] > 0 ? TukeyWeight(r, width_ * scale) : 0.0;
      weights_[p.first + i] = w;
      const double diffuse = std::max(p.rho_d * terms.nl[i], 0.0), lobe = std::max(p.rho_s * terms.s[i], 0.0);
      const double fraction = diffuse + lobe > 0 ? lobe / (diffuse + lobe) : 0.0;
      normal_weights_[p.first + i] = w / (1.0 + options_.highlight_weight * fraction);
    }
  }

  // The derivatives of n . l (clamped) and S of every sample of `p` at its
  // normal n along the unit tangent directions u1, u2 (n' = normalize(n +
  // e u)), into plus_[d].nl and plus_[d].s: with a = the azimuth vector,
  // p = a - (a . n) n, t = p / |p|: dt = (dp - t (t . dp)) / |p|, dp = -(a .
  // u) n - (a . n) u, db = u x t + n x dt; then the chain rule through q,
  // n . v and Smith's Lambda of l and v. False when the normal is (nearly)
  // along the azimuth, where ShapeTerm takes another tangent.
  bool NormalDerivatives(const Pixel& p, const Shape& shape, double at, double ab, const Eigen::Vector3d& u1,
                         const Eigen::Vector3d& u2) {
    const Eigen::Vector3d& n = p.normal;
    const Eigen::Vector3d& a = shape.along;
    const double an = a.dot(n);
    const Eigen::Vector3d projected = a - an * n;
    const double length = projected.norm();
    if (!(length > 1e-3)) return false;
    const Eigen::Vector3d t = projected / length, b = n.cross(t);
    const Eigen::Vector3d u[2] = {u1, u2};
    Eigen::Vector3d dt[2], db[2];
    for (int d = 0; d < 2; ++d) {
      const Eigen::Vector3d dp = -a.dot(u[d]) * n - an * u[d];
      dt[d] = (dp - t * t.dot(dp)) / length;
      db[d] = u[d].cross(t) + n.cross(dt[d]);
    }
    const double at2 = at * at, ab2 = ab * ab;
    const double nv_raw = n.dot(p.view);
    const bool nv_free = nv_raw > kMinViewCosine;
    const double nv = nv_free ? nv_raw : kMinViewCosine;
    // Lambda(w) = (sqrt(1 + X) - 1) / 2, X = (at^2 (w.t)^2 + ab^2 (w.b)^2) / wn^2;
    // its derivative dLambda = dX / (4 sqrt(1 + X)).
    auto lambda_and_derivatives = [&](const Eigen::Vector3d& w, double wn, bool wn_free, double* value,
                                      double derivative[2]) {
      const double wn2 = std::max(wn * wn, 1e-12);
      const double wt = w.dot(t), wb = w.dot(b);
      const double x = (at2 * wt * wt + ab2 * wb * wb) / wn2;
      const double root = std::sqrt(1.0 + x);
      *value = 0.5 * (root - 1.0);
      for (int d = 0; d < 2; ++d) {
        double dx = 2 * (at2 * wt * w.dot(dt[d]) + ab2 * wb * w.dot(db[d])) / wn2;
        if (wn_free && wn * wn > 1e-12) dx -= 2 * x * w.dot(u[d]) / wn;
        derivative[d] = dx / (4 * root);
      }
    };
    double lambda_v = 0, dlambda_v[2];
    lambda_and_derivatives(p.view, nv, nv_free, &lambda_v, dlambda_v);
    double dnv[2];
    for (int d = 0; d < 2; ++d) dnv[d] = nv_free ? p.view.dot(u[d]) : 0.0;
    const double scale = 1.0 / (4 * nv * at * ab);
    for (int d = 0; d < 2; ++d) plus_[d].nl.resize(p.count), plus_[d].s.resize(p.count);
    for (int i = 0; i < p.count; ++i) {
      const int k = p.first + i;
      const Eigen::Vector3d& l = lights_k_[k];
      const Eigen::Vector3d& h = halves_[k];
      const double nl = n.dot(l);
      const double ht = h.dot(t), hb = h.dot(b), hn = h.dot(n);
      const double q = ht * ht / at2 + hb * hb / ab2 + hn * hn;
      double lambda_l = 0, dlambda_l[2];
      lambda_and_derivatives(l, std::max(nl, 0.0), nl > 0, &lambda_l, dlambda_l);
      const double g = 1.0 + lambda_l + lambda_v;
      const double value = scale / (q * q * g);
      for (int d = 0; d < 2; ++d) {
        const double dq = 2 * (ht * h.dot(dt[d]) / at2 + hb * h.dot(db[d]) / ab2 + hn * h.dot(u[d]));
        plus_[d].nl[i] = DiffuseCosineDerivative(nl, fresnel_) * l.dot(u[d]);
        plus_[d].s[i] = value * (-dnv[d] / nv - 2 * dq / q - (dlambda_l[d] + dlambda_v[d]) / g);
      }
    }
    return true;
  }

  // Levenberg-Marquardt on the normal (two tangent angles) with the
  // amplitudes projected out (solver/levenberg_marquardt.h); Tukey weights
  // refreshed every step.
  void SolvePixel(Pixel* p, const Shape& shape, double shared_rho_s) {
    const double at = std::exp(shape.log_alpha_t), ab = std::exp(shape.log_alpha_b);
    if (!options_.per_pixel_amplitude) p->rho_s = shared_rho_s;
    if (normal_weights_.size() < weights_.size()) normal_weights_.resize(weights_.size());
    Evaluate(*p, p->normal, shape, at, ab, &current_);
    ProjectAmplitudes(*p, current_, weights_, &p->rho_d, &p->rho_s);
    NormalFit fit(this, p, shape, at, ab);
    const LevenbergMarquardtSummary summary = SolveLevenbergMarquardt(NormalFitOptions(), &fit);
    if (summary.termination == LevenbergMarquardtSummary::Termination::kLinearizationFailed) return;
    // The amplitudes under the Tukey weights alone: what the shape fit,
    // the model selection and the albedo see.
    Reweight(*p, current_);
    ProjectAmplitudes(*p, current_, weights_, &p->rho_d, &p->rho_s);
  }

  static LevenbergMarquardtOptions NormalFitOptions() {
    LevenbergMarquardtOptions options;
    options.max_iterations = kNormalIterations;
    options.max_step_attempts = 5;
    return options;
  }

  // SolvePixel's functor: the parameters are the normal's two tangent
  // angles, rho_d and (per_pixel_amplitude) rho_s, the pixel's amplitudes
  // re-solved at every trial; the refiner's current_ holds the terms at the
  // current normal.
  class NormalFit {
   public:
    using Hessian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 4, 4>;
    using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 4, 1>;

    NormalFit(BlockRefiner* refiner, Pixel* p, const Shape& shape, double at, double ab)
        : r_(*refiner), p_(*p), shape_(shape), at_(at), ab_(ab), params_(r_.options_.per_pixel_amplitude ? 4 : 3) {}

    bool Linearize(Hessian* jtj, Vector* jtr, double* cost) {
      r_.Reweight(p_, r_.current_);
      *cost = r_.ProjectAmplitudes(p_, r_.current_, r_.normal_weights_, &p_.rho_d, &p_.rho_s);
      if (!std::isfinite(*cost)) return false;
      TangentBasis(p_.normal, &u1_, &u2_);
      // Jacobian columns: the two angles, rho_d, rho_s.
      if (!r_.NormalDerivatives(p_, shape_, at_, ab_, u1_, u2_)) ForwardDifferences();
      Eigen::Matrix4d hessian = Eigen::Matrix4d::Zero();
      Eigen::Vector4d gradient = Eigen::Vector4d::Zero();
      for (int i = 0; i < p_.count; ++i) {
        const double w = r_.normal_weights_[p_.first + i];
        if (!(w > 0)) continue;
        Eigen::Vector4d j;
        j[2] = r_.current_.nl[i];
        j[3] = r_.current_.s[i];
        const double model = p_.rho_d * j[2] + p_.rho_s * j[3];
        for (int d = 0; d < 2; ++d) j[d] = p_.rho_d * r_.plus_[d].nl[i] + p_.rho_s * r_.plus_[d].s[i];
        const double residual = model - r_.values_[p_.first + i][0];
        hessian.noalias() += w * j * j.transpose();
        gradient.noalias() += (w * residual) * j;
      }
      *jtj = hessian.topLeftCorner(params_, params_);
      *jtr = gradient.head(params_);
      return true;
    }

    bool Trial(const Vector& step, double* cost) {
      trial_normal_ = (p_.normal + step[0] * u1_ + step[1] * u2_).normalized();
      if (!trial_normal_.allFinite()) return false;
      r_.Evaluate(p_, trial_normal_, shape_, at_, ab_, &r_.trial_);
      trial_rho_d_ = p_.rho_d, trial_rho_s_ = p_.rho_s;
      const double trial_cost = r_.ProjectAmplitudes(p_, r_.trial_, r_.normal_weights_, &trial_rho_d_, &trial_rho_s_);
      *cost = trial_rho_d_ > 0 ? trial_cost : std::numeric_limits<double>::infinity();
      return true;
    }

    StepVerdict Take(double /*cost*/, double /*trial_cost*/) {
      const double moved = (trial_normal_ - p_.normal).norm();
      p_.normal = trial_normal_, p_.rho_d = trial_rho_d_, p_.rho_s = trial_rho_s_;
      std::swap(r_.current_, r_.trial_);
      return moved < kNormalConverged ? StepVerdict::kTakenConverged : StepVerdict::kTaken;
    }

   private:
    // No tangent frame of its own (the normal along the azimuth): the
    // derivatives by forward differences.
    void ForwardDifferences() {
      r_.Evaluate(p_, (p_.normal + kDerivativeStep * u1_).normalized(), shape_, at_, ab_, &r_.plus_[0]);
      r_.Evaluate(p_, (p_.normal + kDerivativeStep * u2_).normalized(), shape_, at_, ab_, &r_.plus_[1]);
      for (int d = 0; d < 2; ++d) {
        for (int i = 0; i < p_.count; ++i) {
          r_.plus_[d].nl[i] = (r_.plus_[d].nl[i] - r_.current_.nl[i]) / kDerivativeStep;
          r_.plus_[d].s[i] = (r_.plus_[d].s[i] - r_.current_.s[i]) / kDerivativeStep;
        }
      }
    }

    BlockRefiner& r_;
    Pixel& p_;
    const Shape& shape_;
    const double at_, ab_;
    const int params_;
    Eigen::Vector3d u1_, u2_;  // the tangent basis of the last linearization
    Eigen::Vector3d trial_normal_;
    double trial_rho_d_ = 0, trial_rho_s_ = 0;
  };

  // ---- one group ---------------------------------------------------------

  // Each group pixel's diffuse amplitude at its normal, no lobe.
  void InitialDiffuse() {
    for (int index : group_) {
      Pixel& p = pixels_[index];
      double aa = 0, a_b = 0;
      for (int k = p.first; k < p.first + p.count; ++k) {
        const double nl = DiffuseCosine(p.normal.dot(lights_k_[k]), fresnel_);
        aa += weights_[k] * nl * nl, a_b += weights_[k] * nl * values_[k][0];
      }
      p.rho_d = aa > 0 ? a_b / aa : 0.0;
    }
  }

  // Sum of squared residuals of `p` (its normal and amplitudes) under `shape`
  // and the given diffuse term, on the samples both diffuse variants' weights
  // keep (weights_ and chosen_weights_).
  double FitResidual(const Pixel& p, const Shape& shape, double shared_rho_s, bool fresnel) const {
    const double at = std::exp(shape.log_alpha_t), ab = std::exp(shape.log_alpha_b);
    const double rho_s = options_.per_pixel_amplitude ? p.rho_s : shared_rho_s;
    Eigen::Vector3d t, b;
    TangentFrame(p.normal, shape.along, &t, &b);
    double sum = 0;
    for (int k = p.first; k < p.first + p.count; ++k) {
      if (!(weights_[k] > 0) || !(chosen_weights_[k] > 0)) continue;
      const double model = p.rho_d * DiffuseCosine(p.normal.dot(lights_k_[k]), fresnel) +
                           rho_s * ShapeTerm(p.normal, t, b, halves_[k], lights_k_[k], p.view, at, ab);
      const double r = model - values_[k][0];
      sum += r * r;
    }
    return sum;
  }

  // The pixels the shape is fitted on: an even spread of the group's.
  void ChooseFitPixels() {
    fit_.clear();
    const int n = static_cast<int>(group_.size());
    const int fit_count = std::min(n, options_.max_fit_pixels);
    fit_positions_.clear();
    for (int i = 0; i < fit_count; ++i) {
      fit_positions_.push_back(static_cast<size_t>(i) * n / fit_count);
      fit_.push_back(group_[fit_positions_.back()]);
    }
  }

  // Which diffuse term (Lambert's or the Fresnel-transmitted one) the
  // group's samples support: the first alternation (shape grid and the fit
  // pixels' re-solve) under each; the lower residual on the samples both
  // keep wins (the same parameters either way). Its shape and F0 into
  // *shape and *rho_s, fresnel_ set, the pixels and weights its; false when
  // neither shows a lobe.
  bool ChooseDiffuseTerm(Shape* shape, double* rho_s) {
    saved_pixels_.clear();
    for (int index : group_) saved_pixels_.push_back(pixels_[index]);
    saved_weights_ = weights_;
    Shape shapes[2];
    double rho_ss[2] = {0, 0};
    bool has_lobe[2] = {false, false};
    const int variants = options_.fresnel_diffuse ? 2 : 1;
    for (int variant = 0; variant < variants; ++variant) {
      if (variant == 1) {  // keep the Lambertian state, start again from the per-pixel results
        chosen_pixels_.clear();
        for (int index : group_) chosen_pixels_.push_back(pixels_[index]);
        chosen_weights_.swap(weights_);
        for (size_t i = 0; i < group_.size(); ++i) pixels_[group_[i]] = saved_pixels_[i];
        weights_ = saved_weights_;
      }
      fresnel_ = variant == 1;
      InitialDiffuse();
      shapes[variant] = FitShape(Shape(), true, &rho_ss[variant]);
      has_lobe[variant] = options_.per_pixel_amplitude || rho_ss[variant] > 0;
      if (!has_lobe[variant]) continue;
      for (int index : fit_) SolvePixel(&pixels_[index], shapes[variant], rho_ss[variant]);
    }
    double cost[2] = {0, 0};
    for (size_t f = 0; f < fit_.size() && variants == 2; ++f) {
      const size_t i = fit_positions_[f];
      cost[0] += FitResidual(chosen_pixels_[i], shapes[0], rho_ss[0], false);
      cost[1] += FitResidual(pixels_[fit_[f]], shapes[1], rho_ss[1], true);
    }
    if (!has_lobe[0] && !has_lobe[1]) return false;  // no lobe for the group
    const int chosen = !has_lobe[0] ? 1 : !has_lobe[1] ? 0 : cost[1] < kFresnelMargin * cost[0] ? 1 : 0;
    fresnel_ = chosen == 1;
    if (chosen == 0 && variants == 2) {
      for (size_t i = 0; i < group_.size(); ++i) pixels_[group_[i]] = chosen_pixels_[i];
      weights_.swap(chosen_weights_);
    }
    *shape = shapes[chosen];
    *rho_s = rho_ss[chosen];
    return true;
  }

  // Model selection on the pixel's final weighted samples: the shared-lobe
  // model (normal, rho_d, and rho_s when per pixel) against its own per-pixel
  // result (normal and alpha held, its amplitudes re-solved on the same
  // weights: the Lambertian fit or the isotropic lobe). Writes the pixel when
  // the shared lobe wins. In a group that took the Fresnel-transmitted
  // diffuse term every valid pixel takes the group's result: the group won
  // that term by a clear margin on its samples, and the own result (Lambert's
  // cosine, whose falloff the normal was bent to explain) is the model the
  // group rejected; compared pixel by pixel it won where noise favoured it.
  bool Select(const Pixel& p, const Shape& shape) {
    if (!p.normal.allFinite() || !(p.normal.z() > 0) || !(p.normal.dot(p.view) > 0) ||
        !(p.rho_d >= solver_.min_albedo) || !std::isfinite(p.rho_s)) {
      return false;
    }
    const double at = std::exp(shape.log_alpha_t), ab = std::exp(shape.log_alpha_b);
    Eigen::Vector3d t, b;
    TangentFrame(p.normal, shape.along, &t, &b);
    double shared_rss = 0, weight_sum = 0;
    for (int k = p.first; k < p.first + p.count; ++k) {
      if (!(weights_[k] > 0)) continue;
      const double r = Model(p, k, p.normal, t, b, p.rho_d, p.rho_s, at, ab) - values_[k][0];
      shared_rss += weights_[k] * r * r;
      weight_sum += weights_[k];
    }
    if (!(weight_sum >= kMinSamples)) return false;
    if (fresnel_) {
      Write(p, shape, at, ab, shared_rss, weight_sum);
      return true;
    }
    // Its own result under the same weights.
    const bool own_lobe = p.own_alpha > 0;
    const double own_rss = OwnRss(p);
    const double noise = solver_.robust_min_scale * p.rho_d;
    const double noise_rss = weight_sum * noise * noise;
    // The shared lobe must lower the residual, both floored at the noise: BIC
    // would credit it with its fewer per-pixel parameters (3 or 4 against the
    // isotropic lobe's 5) and take it where it fits a little worse, which
    // cost 0.1 deg on a Blinn-Phong sheen (not a GGX lobe: coherent_lobe_test).
    // Against a Lambertian result (as many parameters) a tie goes to the
    // group's lobe: the group's samples support it, this pixel's do not
    // reject it.
    const double shared_floored = std::max(shared_rss, noise_rss), own_floored = std::max(own_rss, noise_rss);
    if (!(shared_floored < own_floored || (!own_lobe && shared_floored <= own_floored))) return false;
    Write(p, shape, at, ab, shared_rss, weight_sum);
    return true;
  }

  // The weighted residual sum of squares of p's own per-pixel result (its
  // normal and alpha held, its amplitudes re-solved on the current weights:
  // the Lambertian fit or the isotropic lobe); infinity when unsolvable.
  double OwnRss(const Pixel& p) const {
    const bool own_lobe = p.own_alpha > 0;
    Eigen::Vector3d ot, ob;
    TangentFrame(p.own_normal, Eigen::Vector3d::UnitX(), &ot, &ob);  // isotropic: any tangent
    const double alpha = own_lobe ? p.own_alpha : 1.0;
    AmplitudeSums sums;
    for (int k = p.first; k < p.first + p.count; ++k) {
      const double w = weights_[k];
      if (!(w > 0)) continue;
      const double value = values_[k][0];
      const double nl = std::max(0.0, p.own_normal.dot(lights_k_[k]));
      const double s =
          own_lobe ? ShapeTerm(p.own_normal, ot, ob, halves_[k], lights_k_[k], p.view, alpha, alpha, false) : 0.0;
      sums.aa += w * nl * nl, sums.ac += w * nl * s, sums.cc += w * s * s;
      sums.ab += w * nl * value, sums.cb += w * s * value;
      sums.bb += w * value * value;
    }
    double d = 0, s = 0;
    if (!(own_lobe ? NonNegativeLobeAmplitudes(sums, &d, &s) : sums.aa > 0)) return std::numeric_limits<double>::infinity();
    if (!own_lobe) d = sums.ab / sums.aa, s = 0;
    return sums.Cost(d, s);
  }

  // The Bayer-domain normal of a pixel that took the group's lobe: its own
  // raw CFA samples (one channel per light, so rho_d is that channel's
  // albedo; the white lobe is the same in every intensity-divided channel)
  // re-solved under the same shape, F0 and diffuse term from its demosaiced
  // normal, written into the Bayer job's solution (normal, kSolved, residual
  // relative to rho_d, lights used) for the blend. True when written.
  bool ResolveBayer(const Pixel& p, const Shape& shape, double shared_rho_s) {
    if (p.bayer_count < kMinSamples) return false;
    Pixel q = p;
    q.first = p.bayer_first, q.count = p.bayer_count;
    for (int k = q.first; k < q.first + q.count; ++k) weights_[k] = lights_k_[k].dot(q.normal) > 0 ? 1.0 : 0.0;
    SolvePixel(&q, shape, shared_rho_s);
    if (!q.normal.allFinite() || !(q.normal.z() > 0) || !(q.normal.dot(q.view) > 0) ||
        !(q.rho_d >= solver_.min_albedo) || !std::isfinite(q.rho_s)) {
      return false;
    }
    const double at = std::exp(shape.log_alpha_t), ab = std::exp(shape.log_alpha_b);
    Eigen::Vector3d t, b;
    TangentFrame(q.normal, shape.along, &t, &b);
    double rss = 0, weight_sum = 0;
    int used = 0;
    for (int k = q.first; k < q.first + q.count; ++k) {
      if (!(weights_[k] > 0)) continue;
      const double r = Model(q, k, q.normal, t, b, q.rho_d, q.rho_s, at, ab) - values_[k][0];
      rss += weights_[k] * r * r;
      weight_sum += weights_[k];
      used += weights_[k] > kUsedWeight;
    }
    if (!(weight_sum >= kMinSamples)) return false;
    PhotometricSolution& s = *bayer_job_->solution;
    for (int c = 0; c < 3; ++c) s.normal_in_table(q.x, q.y, c) = static_cast<float>(q.normal[c]);
    s.status(q.x, q.y) = static_cast<uint8_t>(PixelStatus::kSolved);
    s.lights_used(q.x, q.y) = static_cast<uint8_t>(std::min(used, 255));
    s.residual(q.x, q.y) = static_cast<float>(std::min(std::sqrt(rss / weight_sum) / q.rho_d, 1e30));
    return true;
  }

  void Write(const Pixel& p, const Shape& shape, double at, double ab, double rss, double weight_sum) {
    PhotometricSolution& s = *job_.solution;
    const int x = p.x, y = p.y;
    for (int c = 0; c < 3; ++c) s.normal_in_table(x, y, c) = static_cast<float>(p.normal[c]);
    if (!s.albedo.empty()) {
      // Per channel with the white lobe removed (the samples are divided by
      // each channel's light intensity, so the lobe is the same in each).
      Eigen::Vector3d t, b;
      TangentFrame(p.normal, shape.along, &t, &b);
      double aa = 0, ab_c[3] = {0, 0, 0};
      for (int k = p.first; k < p.first + p.count; ++k) {
        const double w = weights_[k];
        if (!(w > 0)) continue;
        const double nl = DiffuseCosine(p.normal.dot(lights_k_[k]), fresnel_);
        const double lobe = p.rho_s * ShapeTerm(p.normal, t, b, halves_[k], lights_k_[k], p.view, at, ab);
        aa += w * nl * nl;
        for (int c = 0; c < 3; ++c) ab_c[c] += w * nl * (values_[k][1 + c] - lobe);
      }
      for (int c = 0; c < 3; ++c) {
        const double albedo = aa > 0 ? ab_c[c] / aa : 0.0;
        s.albedo(x, y, c) = std::isfinite(albedo) ? static_cast<float>(std::max(0.0, albedo)) : 0.0f;
      }
    }
    int used = 0;
    for (int k = p.first; k < p.first + p.count; ++k) used += weights_[k] > kUsedWeight;
    s.lights_used(x, y) = static_cast<uint8_t>(std::min(used, 255));
    if (!s.residual.empty()) s.residual(x, y) = static_cast<float>(std::min(std::sqrt(rss / weight_sum) / p.rho_d, 1e30));
    s.specular(x, y, 0) = static_cast<float>(std::clamp(p.rho_s, 0.0, 1.0));
    s.specular(x, y, 1) = static_cast<float>(std::sqrt(at * ab));
    s.specular_status(x, y) = static_cast<uint8_t>(SpecularStatus::kEstimated);
  }

  const CoherentLobeOptions& options_;
  const PhotometricSolverOptions& solver_;
  const tiled::SolveJob& job_;
  const tiled::SolveJob* bayer_job_;  // null = no lobe mosaics
  tiled::SpanBuffers buffers_;
  std::unique_ptr<tiled::SpanBuffers> bayer_buffers_;
  std::unique_ptr<tiled::TileLightSampler> bayer_lights_;
  tiled::TileLightSampler lights_;
  const tiled::AccumulateSpanFn accumulate_exact_, accumulate_uniform_;
  PixelSamples samples_;
  const double width_;  // Tukey width in residual scales
  std::vector<Pixel> pixels_;
  std::vector<Eigen::Vector3d> lights_k_, halves_;
  std::vector<Eigen::Vector4d> values_;  // luminance, R, G, B (intensity divided)
  std::vector<double> weights_;
  std::vector<double> normal_weights_;  // weights_ with the highlight samples down-weighted (Reweight)
  std::vector<int> cluster_, group_, fit_;
  int num_clusters_ = 1;  // of the current block (SplitByAlbedo)
  std::vector<size_t> fit_positions_;  // of fit_'s pixels in group_
  bool fresnel_ = false;               // the current group's diffuse term (DiffuseCosine)
  Shape group_shape_;                  // the current group's lobe (FitGroup)
  double group_rho_s_ = 0;             // and its F0 (unless per pixel)
  std::vector<Pixel> saved_pixels_, chosen_pixels_;
  std::vector<double> saved_weights_, chosen_weights_;
  std::vector<FitPixel> fit_pixels_;
  std::vector<FitSample> fit_samples_;
  std::vector<double> abs_residuals_;
  Terms current_, trial_, plus_[2];  // SolvePixel's scratch
};

}  // namespace

double AnisotropicLobeShape(const Eigen::Vector3d& n, const Eigen::Vector3d& light, const Eigen::Vector3d& view,
                            double tangent_azimuth, double alpha_t, double alpha_b, bool masking) {
  const Eigen::Vector3d sum = light + view;
  const Eigen::Vector3d h = sum.norm() > 1e-6 ? Eigen::Vector3d(sum.normalized()) : view;
  Eigen::Vector3d t, b;
  TangentFrame(n, Eigen::Vector3d(std::cos(tangent_azimuth), std::sin(tangent_azimuth), 0.0), &t, &b);
  return ShapeTerm(n, t, b, h, light, view, alpha_t, alpha_b, masking);
}

void CoherentLobeOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE(kOptions, "block_size", block_size, 4, 256);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "min_pixels", min_pixels, 4, 65536);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_fit_pixels", max_fit_pixels, 4, 65536);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_lights", max_lights, 3, 1000);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "iterations", iterations, 1, 20);
  if (!(min_alpha > 0) || !(min_alpha < max_alpha)) {
    throw FieldError(kOptions, "min_alpha", min_alpha, "must be > 0 and below max_alpha");
  }
  SCANBENCH_REQUIRE_LE(kOptions, "max_alpha", max_alpha, 1);
  SCANBENCH_REQUIRE_GE(kOptions, "albedo_split", albedo_split, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "highlight_weight", highlight_weight, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_albedo_groups", max_albedo_groups, 1, 8);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "num_threads", num_threads, 0, 256);
}

std::string CoherentLobeSummary::BriefReport() const {
  std::ostringstream out;
  const char* how = TerminationName(termination);
  out << "Coherent lobe: " << how << ", " << pixels_refined << " of " << pixels_supported
      << " lobe pixels refined by a shared lobe (" << pixels_kept << " kept their own) in " << groups_fitted
      << " groups (" << groups_fresnel << " with the Fresnel-transmitted diffuse), mean anisotropy " << mean_anisotropy << ", " << Significant(seconds) << " s";
  if (pixels_bayer > 0) out << ", " << pixels_bayer << " re-solved from their raw samples";
  if (!message.empty()) out << " (" << message << ")";
  return out.str();
}

namespace {

// The lobe mosaics (input.lobe_mosaics, with input.lobe_bayer) fit the
// images; *input.lobe_bayer emptied. Throws std::invalid_argument.
void CheckLobeMosaics(const PhotometricSolverInput& input) {
  if ((input.lobe_bayer == nullptr) != (input.lobe_mosaics == nullptr)) {
    throw std::invalid_argument("coherent lobe: lobe_mosaics and lobe_bayer must be given together");
  }
  if (input.lobe_mosaics == nullptr) return;
  const int width = input.light_field->width(), height = input.light_field->height();
  const BayerSolverInput& bayer = *input.lobe_mosaics;
  if (bayer.mosaics.size() != input.images.size()) {
    throw std::invalid_argument("coherent lobe: " + std::to_string(bayer.mosaics.size()) + " lobe mosaics for " +
                                std::to_string(input.images.size()) + " images");
  }
  for (size_t k = 0; k < bayer.mosaics.size(); ++k) {
    if (bayer.mosaics[k] == nullptr || bayer.mosaics[k]->channels() != 1 ||
        !bayer.mosaics[k]->SameSize(width, height)) {
      throw std::invalid_argument("coherent lobe: lobe mosaic " + std::to_string(k) + " must be a 1-channel image of " +
                                  std::to_string(width) + " x " + std::to_string(height));
    }
  }
  if (!bayer.sample_valid.empty() && bayer.sample_valid.size() != bayer.mosaics.size()) {
    throw std::invalid_argument("coherent lobe: " + std::to_string(bayer.sample_valid.size()) +
                                " lobe mosaic sample masks for " + std::to_string(bayer.mosaics.size()) + " mosaics");
  }
  for (int p = 0; p < 4; ++p) {
    if (bayer.cfa_channels[p] < 0 || bayer.cfa_channels[p] > 2) {
      throw std::invalid_argument("coherent lobe: lobe mosaics' cfa_channels[" + std::to_string(p) + "] = " +
                                  std::to_string(bayer.cfa_channels[p]) + " must be 0, 1 or 2");
    }
  }
  *input.lobe_bayer = PhotometricSolution();
}

// The Bayer-domain re-solves' job into *job, its output *input.lobe_bayer
// made: every pixel not solved until one is.
void MakeBayerLobeJob(const PhotometricSolverOptions& solver_options, const PhotometricSolverInput& input,
                      tiled::SolveJob* job) {
  const int width = input.light_field->width(), height = input.light_field->height();
  const BayerSolverInput& bayer = *input.lobe_mosaics;
  PhotometricSolution& out = *input.lobe_bayer;
  out.normal_in_table = ImageF(width, height, 3, 0.0f);
  for (size_t i = 0; i < out.normal_in_table.num_pixels(); ++i) out.normal_in_table.data()[3 * i + 2] = 1;
  out.status = ImageU8(width, height, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  out.lights_used = ImageU8(width, height, 1, uint8_t{0});
  out.residual = ImageF(width, height, 1, 0.0f);
  job->options = &solver_options;
  job->field = input.light_field;
  job->images = &bayer.mosaics;
  job->sample_valid = &bayer.sample_valid;
  job->region = input.region;
  job->bayer = true;
  job->cfa_channels = bayer.cfa_channels;
  job->num_lights = input.light_field->num_lights();
  job->with_albedo = false;
  job->with_confidence = true;
  job->solution = input.lobe_bayer;
}

}  // namespace

CoherentLobeSummary RefineCoherentLobe(const CoherentLobeOptions& options,
                                       const PhotometricSolverOptions& solver_options,
                                       const PhotometricSolverInput& input, PhotometricSolution* solution,
                                       const ProgressCallback& progress) {
  options.Check();
  solver_options.Check();
  const auto start = std::chrono::steady_clock::now();
  CoherentLobeSummary summary;
  tiled::CheckRgbRefinementInput("coherent lobe", input, solution);
  CheckLobeMosaics(input);
  const int width = input.light_field->width(), height = input.light_field->height();
  // The Bayer output maps only where a block may fit a lobe: a Lambertian
  // scene (no or a few lobe pixels) pays a scan of the status map, no allocation.
  const bool may_fit = input.lobe_mosaics != nullptr && !solution->specular_status.empty() &&
                       input.light_field->num_lights() <= options.max_lights &&
                       std::count(solution->specular_status.data(),
                                  solution->specular_status.data() + solution->specular_status.size(),
                                  static_cast<uint8_t>(SpecularStatus::kEstimated)) >= options.min_pixels;
  tiled::SolveJob bayer_job;
  if (may_fit) MakeBayerLobeJob(solver_options, input, &bayer_job);
  if (input.light_field->num_lights() > options.max_lights) {
    summary.termination = Termination::kSuccess;
    summary.skipped_lights = true;
    summary.message = std::to_string(input.light_field->num_lights()) + " lights, more than max_lights = " +
                      std::to_string(options.max_lights) + ": the per-pixel lobes are kept";
    return summary;
  }
  if (solution->specular.empty() || solution->specular_status.empty()) {
    summary.termination = Termination::kSuccess;
    summary.message = "no specular maps: nothing to refine";
    return summary;
  }
  if (!solution->normal_in_table.SameSize(width, height) || !solution->status.SameSize(width, height) ||
      !solution->specular.SameSize(width, height) || !solution->specular_status.SameSize(width, height)) {
    throw std::invalid_argument("coherent lobe: the solution is not the light field's " + std::to_string(width) +
                                " x " + std::to_string(height));
  }

  const tiled::SolveJob job =
      tiled::RgbSolveJob(solver_options, input, solution, /*with_albedo=*/true, !solution->residual.empty());
  const std::vector<BlockRefiner::Counts> counts = tiled::RunBlockRefiners<BlockRefiner>(
      width, height, options.block_size, options.num_threads,
      [&] { return std::make_unique<BlockRefiner>(options, solver_options, job, may_fit ? &bayer_job : nullptr); },
      progress, &summary);
  double anisotropy_sum = 0;
  for (const auto& c : counts) {
    summary.pixels_supported += c.supported;
    summary.groups_fitted += c.groups;
    summary.groups_fresnel += c.fresnel_groups;
    summary.pixels_refined += c.refined;
    summary.pixels_kept += c.kept;
    summary.pixels_bayer += c.bayer;
    anisotropy_sum += c.anisotropy_sum;
  }
  summary.mean_anisotropy = summary.groups_fitted > 0 ? anisotropy_sum / summary.groups_fitted : 0.0;
  summary.seconds = SecondsSince(start);
  return summary;
}

}  // namespace scanbench
