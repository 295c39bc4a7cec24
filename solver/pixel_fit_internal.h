// The pieces the per-pixel fits' files share (pixel_solvers.cc: least
// squares; robust_fits.cc; diffuse_lobe_fit.cc; diffuse_sheen_fit.cc; the
// shared lobe's and sheen's per-pixel steps). Not part of the solver's
// interface: include solver/pixel_solvers.h instead.
// Inline: the per-pixel loops call them once or more per pixel.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "solver/levenberg_marquardt.h"
#include "solver/pixel_solvers.h"

namespace scanbench::pixel_fit {

using Matrix34d = Eigen::Matrix<double, 3, 4>;

constexpr double kTukeyWidth = 4.685;   // 95 % efficiency under Gaussian noise
constexpr double kCauchyWidth = 2.385;  // 95 % efficiency under Gaussian noise
constexpr double kMadToSigma = 1.4826;  // median absolute deviation -> standard deviation
constexpr double kUsedWeight = 0.01;    // a sample with a larger weight counts as used
constexpr double kConverged = 1e-5;     // relative change of the scaled normal that ends an iteration
// n . v floor of the lobe and the sheen: near-grazing views only rescale their amplitude.
constexpr double kMinViewCosine = 0.1;
static_assert(kMinViewCosine == kVelvetSheenMinViewCosine, "the sheen's n . v floor is the lobe's");

inline double ClampForStorage(double value) {
  return std::isfinite(value) ? value : double(std::numeric_limits<float>::max());
}

// Fills normal, albedo and status from the scaled normals (columns luminance,
// R, G, B). The residual is the caller's.
inline void FinishFit(const Matrix34d& scaled, bool with_albedo, const PixelFitLimits& limits, PixelFit* fit) {
  const double length = scaled.col(0).norm();
  if (!std::isfinite(length) || !(length >= limits.min_albedo) || length == 0) {
    fit->status = PixelStatus::kNoSignal;
    return;
  }
  const Eigen::Vector3d normal = scaled.col(0) / length;
  if (!(normal.z() > 0)) {
    fit->status = PixelStatus::kFacingAway;
    return;
  }
  fit->status = PixelStatus::kSolved;
  fit->normal = normal;
  fit->luminance_albedo = length;
  if (with_albedo) {
    for (int c = 0; c < 3; ++c) {
      const double value = scaled.col(1 + c).norm();
      fit->albedo[c] = std::isfinite(value) ? value : 0.0;
    }
  }
}

// Weighted normal equations: gram = sum w l l^T, rhs = sum w l v^T.
inline void WeightedSystem(const PixelSamples& samples, const double* weights, int num_rhs, Eigen::Matrix3d* gram,
                           Matrix34d* rhs, int* used) {
  double g[6] = {0, 0, 0, 0, 0, 0};
  double b[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  int count = 0;
  const double* l = samples.light_data();
  const double* v = samples.value_data();
  for (int k = 0; k < samples.count(); ++k, l += 3, v += 4) {
    const double w = weights[k];
    if (!(w > 0)) continue;
    const double w0 = w * l[0], w1 = w * l[1], w2 = w * l[2];
    g[0] += w0 * l[0], g[1] += w0 * l[1], g[2] += w0 * l[2];
    g[3] += w1 * l[1], g[4] += w1 * l[2], g[5] += w2 * l[2];
    for (int j = 0; j < num_rhs; ++j) {
      b[3 * j] += w0 * v[j], b[3 * j + 1] += w1 * v[j], b[3 * j + 2] += w2 * v[j];
    }
    count += w > kUsedWeight;
  }
  *gram << g[0], g[1], g[2], g[1], g[3], g[4], g[2], g[4], g[5];
  for (int j = 0; j < 4; ++j) rhs->col(j) << b[3 * j], b[3 * j + 1], b[3 * j + 2];
  *used = count;
}

// Solves the weighted system; false when it is too small or ill-conditioned.
// `condition` is exact when `exact_condition`; otherwise it is only known to
// be within the limit (the cheap Frobenius bound ||G|| ||G^-1|| >= cond(G)
// decides whenever it can), which is all the iterations of a robust fit need.
inline bool SolveWeighted(const PixelSamples& samples, const std::vector<double>& weights, int num_rhs,
                          const PixelFitLimits& limits, Matrix34d* scaled, double* condition, int* used,
                          bool exact_condition = true) {
  Eigen::Matrix3d gram;
  Matrix34d rhs;
  WeightedSystem(samples, weights.data(), num_rhs, &gram, &rhs, used);
  if (*used < std::max(3, limits.min_lights)) {
    *condition = ConditionNumberFromGram(gram);
    return false;
  }
  const Eigen::Matrix3d inverse = gram.inverse();
  const double bound = std::sqrt(gram.norm() * inverse.norm());  // >= cond(L) = sqrt(cond(G))
  if (exact_condition || !(bound <= limits.max_condition_number)) {
    *condition = ConditionNumberFromGram(gram);
    if (!(*condition <= limits.max_condition_number)) return false;
  } else {
    *condition = bound;
  }
  scaled->setZero();
  scaled->leftCols(num_rhs) = inverse * rhs.leftCols(num_rhs);
  return scaled->allFinite();
}

// Weights 1 for the samples the robust fits may use at all (dark_fraction).
inline void BaseWeights(const PixelSamples& samples, double dark_fraction, std::vector<double>* weights) {
  const int m = samples.count();
  weights->assign(m, 1.0);
  if (!(dark_fraction > 0) || m == 0) return;
  const auto values = samples.values();
  const double brightest = values.col(0).maxCoeff();
  for (int k = 0; k < m; ++k) (*weights)[k] = values(k, 0) >= dark_fraction * brightest ? 1.0 : 0.0;
}

inline double MedianAbs(std::vector<double>* values) {
  if (values->empty()) return 0;
  const size_t mid = values->size() / 2;
  std::nth_element(values->begin(), values->begin() + mid, values->end());
  return (*values)[mid];
}

inline double TukeyWeight(double r, double width_scale) {
  const double u = r / width_scale;
  const double t = 1 - u * u;
  return t > 0 ? t * t : 0.0;
}

// ---- the diffuse + one-term fits (FitDiffuseLobe, FitDiffuseSheen) -------
//
// Both fit b_k = rho_d (n . l_k) + rho_s S_k(n, shape) in the same five
// phases: 1. the samples (half vectors; which samples the term can use),
// 2. the start (the best of a few shapes at the start normal, amplitudes by
// linear least squares), 3. Levenberg-Marquardt over the normal (two tangent
// angles), both amplitudes and the shape (solver/levenberg_marquardt.h),
// 4. the selection (the term kept only where BIC prefers it to the Lambertian
// fit of the same samples), 5. the result (normal, amplitudes, shape, and the
// colour albedo with the term fixed). What they share is below, the phases'
// order first.

// Phases 2 to 5 of `fit` (phase 1 is its constructor); `start` wherever the
// term is not kept. A TermFit provides
//   bool Start(const PixelFit& start);   // false: no usable start
//   static LevenbergMarquardtOptions RefinementOptions();
//   Linearize, Trial and Take (the functor of solver/levenberg_marquardt.h)
//   bool Selected(const PixelFitLimits& limits);
//   PixelFit Result(const PixelFit& start, bool with_albedo) const;
template <typename TermFit>
PixelFit FitDiffuseAndTerm(TermFit* fit, const PixelFit& start, const PixelFitLimits& limits, bool with_albedo) {
  if (!fit->Start(start)) return start;
  SolveLevenbergMarquardt(TermFit::RefinementOptions(), fit);
  if (!fit->Selected(limits)) return start;
  return fit->Result(start, with_albedo);
}

// The view direction made unit; +z when it is not usable.
inline Eigen::Vector3d UnitViewOrZ(const Eigen::Vector3d& view) {
  return view.allFinite() && view.norm() > 0 ? view.normalized() : Eigen::Vector3d::UnitZ();
}

// Phase 1: each sample's half vector normalize(l + v) into *halves; where
// there is none (a light opposite the camera) the view, and its weight in
// *usable (one per sample, filled by the caller) set to 0.
inline void HalfVectors(const PixelSamples& samples, const Eigen::Vector3d& view,
                        std::vector<Eigen::Vector3d>* halves, std::vector<double>* usable) {
  const int m = samples.count();
  const double* l = samples.light_data();
  halves->resize(m);
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d sum = Eigen::Vector3d(l[3 * k], l[3 * k + 1], l[3 * k + 2]) + view;
    const double length = sum.norm();
    if (length > 1e-6) {
      (*halves)[k] = sum / length;
    } else {
      (*halves)[k] = view, (*usable)[k] = 0;
    }
  }
}

inline Eigen::Vector3d LightOf(const PixelSamples& samples, int k) {
  const double* l = samples.light_data();
  return Eigen::Vector3d(l[3 * k], l[3 * k + 1], l[3 * k + 2]);
}

// Unit vectors t1, t2 completing n to an orthonormal basis: the two tangent
// angles of the normal in phase 3.
inline void TangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d* t1, Eigen::Vector3d* t2) {
  const Eigen::Vector3d helper = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *t1 = n.cross(helper).normalized();
  *t2 = n.cross(*t1);
}

// Weighted 2-parameter least squares b ~ x0 a + x1 c (the diffuse and the
// term's amplitudes for a fixed normal and shape); x1 held >= 0. False when singular.
inline bool SolveAmplitudes(double aa, double ac, double cc, double ab, double cb, double* x0, double* x1) {
  const double det = aa * cc - ac * ac;
  if (det > 1e-12 * aa * cc && aa > 0) {
    *x0 = (cc * ab - ac * cb) / det;
    *x1 = (aa * cb - ac * ab) / det;
    if (*x1 >= 0) return std::isfinite(*x0) && std::isfinite(*x1);
  }
  if (!(aa > 0)) return false;
  *x0 = ab / aa;  // the term's amplitude at its bound: diffuse only
  *x1 = 0;
  return std::isfinite(*x0);
}

// The sums of the amplitudes' least squares, sum w a^2, w a c, w c^2, w a b,
// w c b, w b^2 (a = n . l, c = S, b the reading), and the cost they give.
struct AmplitudeSums {
  double aa = 0, ac = 0, cc = 0, ab = 0, cb = 0, bb = 0;

  // The cost sum w (d a + s c - b)^2 from the sums (>= 0).
  double Cost(double d, double s) const {
    return std::max(0.0, bb - 2 * (d * ab + s * cb) + d * d * aa + 2 * d * s * ac + s * s * cc);
  }
  // Solves both amplitudes (SolveAmplitudes) and returns their cost;
  // infinity when singular.
  double Project(double* d, double* s) const {
    if (!SolveAmplitudes(aa, ac, cc, ab, cb, d, s)) return std::numeric_limits<double>::infinity();
    return Cost(*d, *s);
  }
};

// Phase 4's rule: the term's two more parameters must pay BIC's penalty,
// n log(RSS_lambert / RSS_term) > parameters log n, both RSS floored.
inline bool BicPrefers(double n, double lambert_rss, double term_rss, double floor_rss, int parameters) {
  return n * std::log(std::max(lambert_rss, floor_rss) / std::max(term_rss, floor_rss)) > parameters * std::log(n);
}

// Phase 4: the Lambertian fit of the samples with weight > 0, its weighted
// residual sum of squares into *lambert_rss and the weight sum into
// *weight_sum; `exact_condition` as SolveWeighted's. False when that fit is
// unusable (then *lambert_rss takes the readings as the residuals).
inline bool LambertRss(const PixelSamples& samples, const std::vector<double>& weights, const PixelFitLimits& limits,
                       bool exact_condition, double* condition, double* lambert_rss, double* weight_sum) {
  Matrix34d scaled = Matrix34d::Zero();  // read only where solved
  int used = 0;
  const bool ok = SolveWeighted(samples, weights, 1, limits, &scaled, condition, &used, exact_condition);
  const double* v = samples.value_data();
  *lambert_rss = 0, *weight_sum = 0;
  for (int k = 0; k < samples.count(); ++k) {
    if (!(weights[k] > 0)) continue;
    const double r = ok ? LightOf(samples, k).dot(scaled.col(0)) - v[4 * k] : v[4 * k];
    *lambert_rss += weights[k] * r * r;
    *weight_sum += weights[k];
  }
  return ok;
}

// Phase 5's colour albedo: per channel rho_d,c and that channel's amplitude
// of the term, by weighted least squares with n and the term's shape fixed
// (`term(k)`: S of sample k), into *albedo (0 where unsolvable).
template <typename Term>
void ColourAlbedo(const PixelSamples& samples, const std::vector<double>& weights, const Eigen::Vector3d& normal,
                  const Term& term, Eigen::Vector3d* albedo) {
  const double* v = samples.value_data();
  double aa = 0, ac = 0, cc = 0, ab[3] = {0, 0, 0}, cb[3] = {0, 0, 0};
  for (int k = 0; k < samples.count(); ++k) {
    if (!(weights[k] > 0)) continue;
    const double nl = normal.dot(LightOf(samples, k));
    const double s = term(k);
    const double w = weights[k];
    aa += w * nl * nl, ac += w * nl * s, cc += w * s * s;
    for (int c = 0; c < 3; ++c) ab[c] += w * nl * v[4 * k + 1 + c], cb[c] += w * s * v[4 * k + 1 + c];
  }
  for (int c = 0; c < 3; ++c) {
    double diffuse = 0, amplitude = 0;
    (*albedo)[c] = SolveAmplitudes(aa, ac, cc, ab[c], cb[c], &diffuse, &amplitude) ? std::max(0.0, diffuse) : 0.0;
  }
}

}  // namespace scanbench::pixel_fit
