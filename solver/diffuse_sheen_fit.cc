// The velvet sheen per pixel (solver/pixel_solvers.h): its shape
// (VelvetSheenShape and its factors), the cheap residual test
// (SheenPatternInResidual) and FitDiffuseSheen, diffuse plus a white velvet
// sheen in the five phases of the diffuse + one-term fits
// (solver/pixel_fit_internal.h).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "solver/levenberg_marquardt.h"
#include "solver/pixel_fit_internal.h"
#include "solver/pixel_solvers.h"

namespace scanbench {
namespace {

using namespace pixel_fit;

// The velvet sheen fit's settings: fixed, not tuned per data set.
constexpr int kSheenMinSamples = 6;  // 4 fitted parameters (and the width) and a spare sample
// Velvet widths a tried (a geometric ladder over the seed's range: at 0.5 the
// sheen has faded into its constant offset at every rig angle, at 1.4 it
// rises from the normal on).
constexpr double kSheenWidths[] = {0.5, 0.7, 1.0, 1.4};
constexpr double kSheenMinWidth = 0.3;     // fitted width range: narrower is a rim no rig angle reaches,
constexpr double kSheenMaxWidth = 2.0;     // broader is flat
constexpr double kSheenTestWidth = 1.0;    // the residual test's width (mid-ladder)
constexpr double kSheenNormalStep = 2e-4;  // rad (0.01 deg): a smaller step of the normal has converged
// Residual floor of the model selection, relative to rho_d: below about the
// quantisation of a 14-bit reading of a mid-grey the residual is not evidence.
constexpr double kSheenResidualFloor = 1e-3;

// S (VelvetSheenShape) and, if asked, dS/dn and dS/d log a.
struct SheenTerm {
  double s = 0;
  Eigen::Vector3d ds_dn = Eigen::Vector3d::Zero();
  double ds_dlog_width = 0;
};

inline SheenTerm EvaluateSheen(const Eigen::Vector3d& n, const Eigen::Vector3d& light, const Eigen::Vector3d& half,
                               const Eigen::Vector3d& view, double width, bool derivatives) {
  SheenTerm t;
  const double nl = n.dot(light);
  if (!(nl > 0)) return t;
  const double raw_nv = n.dot(view);
  const bool nv_clamped = !(raw_nv > kMinViewCosine);
  const double nv = nv_clamped ? kMinViewCosine : std::min(raw_nv, 1.0);
  const double c = std::clamp(n.dot(half), 0.0, 1.0);
  const double s2 = 1 - c * c;
  const double a2 = width * width;
  const double norm = 1 / (1 + kVelvetSheenAmplitude * a2);
  // G = 1 + A exp(-cot^2 / a^2) / sin^4: at th_h -> 0 the exponential wins.
  double g = 1, dg_dc = 0, dg_dlog_width = 0;
  if (s2 > 1e-6) {
    const double cot2 = c * c / s2;
    const double e = std::exp(-cot2 / a2);
    const double inv_s4 = 1 / (s2 * s2);
    g += kVelvetSheenAmplitude * e * inv_s4;
    dg_dc = kVelvetSheenAmplitude * e * c * inv_s4 / s2 * (4 - 2 / (a2 * s2));
    dg_dlog_width = kVelvetSheenAmplitude * e * inv_s4 * 2 * cot2 / a2;
  }
  const double den = nl + nv - nl * nv;  // >= max(nl, nv) > 0
  const double q = nl / (4 * den);
  t.s = norm * g * q;
  if (derivatives) {
    const double inv_den2 = 1 / (4 * den * den);
    t.ds_dn = norm * (dg_dc * q * half + g * nv * inv_den2 * light);
    if (!nv_clamped && raw_nv < 1) t.ds_dn -= norm * g * nl * (1 - nl) * inv_den2 * view;
    t.ds_dlog_width = norm * q * dg_dlog_width - t.s * 2 * kVelvetSheenAmplitude * a2 * norm;
  }
  return t;
}

struct SheenParams {
  Eigen::Vector3d normal;
  double rho_d = 0, rho_s = 0;
};

// One pixel's buffers, kept per thread between pixels.
struct SheenScratch {
  std::vector<Eigen::Vector3d> halves;
  std::vector<double> usable, weights;
};

// One pixel's sheen fit: its samples, the parameters, and the
// Levenberg-Marquardt functor of phase 3 (solver/levenberg_marquardt.h).
// A velvet sheen is smooth and weak, so unlike the lobe's no sample is
// down-weighted.
class SheenFit {
 public:
  using Hessian = Eigen::Matrix<double, 5, 5>;
  using Vector = Eigen::Matrix<double, 5, 1>;

  // Phase 1: the half vectors; every sample with one is usable.
  SheenFit(const PixelSamples& samples, const Eigen::Vector3d& view, SheenScratch* scratch)
      : samples_(samples), m_(samples.count()), v_(samples.value_data()), view_(UnitViewOrZ(view)), s_(*scratch) {
    s_.usable.assign(m_, 1.0);
    HalfVectors(samples, view_, &s_.halves, &s_.usable);
  }

  // Phase 2: the width of the ladder whose linear fit at the start normal
  // leaves the least residual (the fit moves it on). False when none gives
  // a sheen.
  bool Start(const PixelFit& start) {
    width_ = kSheenWidths[0];
    cost_ = std::numeric_limits<double>::infinity();
    for (double a : kSheenWidths) {
      SheenParams trial;
      trial.normal = start.normal;
      const double trial_cost = Project(&trial, a);
      if (trial_cost < cost_) cost_ = trial_cost, p_ = trial, width_ = a;
    }
    return std::isfinite(cost_) && p_.rho_s > 0;
  }

  // Phase 3 (this class its functor): over the normal (two tangent angles),
  // both amplitudes and log a, a step tried with the amplitudes re-solved
  // (variable projection). Gauss-Newton with a light fixed damping (the
  // width is poorly constrained where the sheen is weak); a step is halved
  // until it does not raise the cost.
  static LevenbergMarquardtOptions RefinementOptions() {
    LevenbergMarquardtOptions options;
    options.damping = LevenbergMarquardtOptions::Damping::kFixedWithBacktracking;
    options.max_iterations = 12;
    options.max_step_attempts = 5;
    options.accept_equal_cost = true;
    return options;
  }

  // Phase 4: the Lambertian least squares on the same samples (those lit at
  // the sheen's normal) against the sheen, by BIC (amplitude and width;
  // residuals floored at the quantisation level).
  bool Selected(const PixelFitLimits& limits) {
    if (!(p_.rho_s > 0) || !(p_.rho_d >= limits.min_albedo) || !(p_.normal.z() > 0) || !p_.normal.allFinite()) {
      return false;
    }
    s_.weights.assign(m_, 0.0);
    count_ = 0;
    for (int k = 0; k < m_; ++k) {
      s_.weights[k] = s_.usable[k] > 0 && p_.normal.dot(LightOf(samples_, k)) > 0 ? 1.0 : 0.0;
      count_ += s_.weights[k] > 0;
    }
    if (count_ < kSheenMinSamples) return false;
    double lambert_rss = 0, weight_sum = 0;
    if (!LambertRss(samples_, s_.weights, limits, true, &condition_, &lambert_rss, &weight_sum)) return false;
    sheen_rss_ = 0;
    for (int k = 0; k < m_; ++k) {
      if (!(s_.weights[k] > 0)) continue;
      const Eigen::Vector3d lk = LightOf(samples_, k);
      const double r = p_.rho_d * p_.normal.dot(lk) + p_.rho_s * Shape(lk, k) - v_[4 * k];
      sheen_rss_ += r * r;
    }
    const double floor_rss = count_ * std::pow(kSheenResidualFloor * p_.rho_d, 2);
    return BicPrefers(count_, lambert_rss, sheen_rss_, floor_rss, 2);
  }

  // Phase 5: the sheen's result over the Lambertian `start`.
  PixelFit Result(const PixelFit& start, bool with_albedo) const {
    PixelFit fit = start;
    fit.normal = p_.normal;
    fit.luminance_albedo = p_.rho_d;
    fit.sheen_f0 = p_.rho_s;
    fit.sheen_width = width_;
    fit.lights_used = count_;
    fit.condition_number = ClampForStorage(condition_);
    fit.residual = std::sqrt(sheen_rss_ / count_) / p_.rho_d;
    if (with_albedo) {
      ColourAlbedo(
          samples_, s_.weights, p_.normal, [&](int k) { return Shape(LightOf(samples_, k), k); }, &fit.albedo);
    }
    return fit;
  }

  // ---- the Levenberg-Marquardt functor ----------------------------------

  bool Linearize(Hessian* hessian, Vector* gradient, double* cost) {
    TangentBasis(p_.normal, &t1_, &t2_);
    hessian->setZero();
    gradient->setZero();
    for (int k = 0; k < m_; ++k) {
      if (!(s_.usable[k] > 0)) continue;
      const Eigen::Vector3d lk = LightOf(samples_, k);
      const double nl = p_.normal.dot(lk);
      if (!(nl > 0)) continue;
      const SheenTerm t = EvaluateSheen(p_.normal, lk, s_.halves[k], view_, width_, true);
      const double r = p_.rho_d * nl + p_.rho_s * t.s - v_[4 * k];
      const Eigen::Vector3d df_dn = p_.rho_d * lk + p_.rho_s * t.ds_dn;
      Vector j;
      j << df_dn.dot(t1_), df_dn.dot(t2_), nl, t.s, p_.rho_s * t.ds_dlog_width;
      hessian->noalias() += j * j.transpose();
      gradient->noalias() += r * j;
    }
    *cost = cost_;  // the projected cost of the current parameters
    return true;
  }

  bool Trial(const Vector& step, double* cost) {
    trial_ = p_;
    trial_.normal = (p_.normal + step[0] * t1_ + step[1] * t2_).normalized();
    trial_width_ = std::clamp(width_ * std::exp(std::clamp(step[4], -1.0, 1.0)), kSheenMinWidth, kSheenMaxWidth);
    const double trial_cost = Project(&trial_, trial_width_);
    *cost = trial_.normal.allFinite() ? trial_cost : std::numeric_limits<double>::infinity();
    return true;
  }

  StepVerdict Take(double /*cost*/, double trial_cost) {
    const double moved = (trial_.normal - p_.normal).norm();
    p_ = trial_, cost_ = trial_cost, width_ = trial_width_;
    return moved < kSheenNormalStep ? StepVerdict::kTakenConverged : StepVerdict::kTaken;
  }

 private:
  // S of sample k (light lk) at the current normal and width.
  double Shape(const Eigen::Vector3d& lk, int k) const {
    return EvaluateSheen(p_.normal, lk, s_.halves[k], view_, width_, false).s;
  }

  // The two amplitudes by least squares for `p.normal` (rho_s >= 0) and the
  // cost; samples with n . l <= 0 there keep their whole reading as residual.
  double Project(SheenParams* p, double width) const {
    AmplitudeSums sums;
    for (int k = 0; k < m_; ++k) {
      if (!(s_.usable[k] > 0)) continue;
      const double b = v_[4 * k];
      sums.bb += b * b;
      const Eigen::Vector3d lk = LightOf(samples_, k);
      const double nl = p->normal.dot(lk);
      if (!(nl > 0)) continue;
      const double s = EvaluateSheen(p->normal, lk, s_.halves[k], view_, width, false).s;
      sums.aa += nl * nl, sums.ac += nl * s, sums.cc += s * s, sums.ab += nl * b, sums.cb += s * b;
    }
    return sums.Project(&p->rho_d, &p->rho_s);
  }

  const PixelSamples& samples_;
  const int m_;
  const double* v_;  // the readings, 4 per sample (luminance first)
  const Eigen::Vector3d view_;
  SheenScratch& s_;
  SheenParams p_, trial_;
  double width_ = 0, trial_width_ = 0;
  double cost_ = 0;          // the projected cost of p_ at width_
  Eigen::Vector3d t1_, t2_;  // the tangent basis of the last linearization
  int count_ = 0;            // samples of the selection (lit at the sheen's normal)
  double condition_ = 0, sheen_rss_ = 0;
};

}  // namespace

VelvetSheenGeometry VelvetSheenGeometryOf(const Eigen::Vector3d& n, const Eigen::Vector3d& light,
                                          const Eigen::Vector3d& half, const Eigen::Vector3d& view) {
  VelvetSheenGeometry g;
  const double nl = n.dot(light);
  if (!(nl > 0)) return g;
  const double raw_nv = n.dot(view);
  const double nv = !(raw_nv > kMinViewCosine) ? kMinViewCosine : std::min(raw_nv, 1.0);
  const double c = std::clamp(n.dot(half), 0.0, 1.0);
  const double s2 = 1 - c * c;
  if (s2 > 1e-6) g.cot2 = c * c / s2, g.inv_sin4 = 1 / (s2 * s2);
  g.q = nl / (4 * (nl + nv - nl * nv));
  return g;
}

double VelvetSheenShape(const Eigen::Vector3d& n, const Eigen::Vector3d& light, const Eigen::Vector3d& half,
                        const Eigen::Vector3d& view, double width) {
  if (!(width > 0) || !n.allFinite() || !light.allFinite() || !half.allFinite() || !view.allFinite()) return 0;
  const double s = EvaluateSheen(n, light, half, view, width, false).s;
  return std::isfinite(s) ? s : 0.0;
}

bool SheenPatternInResidual(const PixelSamples& samples, const Eigen::Vector3d& view_in,
                            const PixelFit& least_squares) {
  const int m = samples.count();
  if (least_squares.status != PixelStatus::kSolved || m < kSheenMinSamples) return false;
  const Eigen::Vector3d view = UnitViewOrZ(view_in);
  const Eigen::Vector3d n = least_squares.normal;
  const Eigen::Vector3d scaled = least_squares.luminance_albedo * n;
  const double* v = samples.value_data();
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  Eigen::Vector3d ls = Eigen::Vector3d::Zero();
  double ss = 0, rs = 0, rr = 0;
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d lk = LightOf(samples, k);
    const double r = lk.dot(scaled) - v[4 * k];
    gram.noalias() += lk * lk.transpose();
    rr += r * r;
    const Eigen::Vector3d sum = lk + view;
    const double length = sum.norm();
    if (!(length > 1e-6)) continue;
    const double s = EvaluateSheen(n, lk, sum / length, view, kSheenTestWidth, false).s;
    ls += s * lk, ss += s * s, rs += r * s;
  }
  // A sheen adds light: the residual (model - data) points against it.
  if (!(rs < 0)) return false;
  // The sheen's part outside the Lambertian model's span; the residual is
  // orthogonal to that span already (least squares), so r . S is its projection.
  const double outside = ss - ls.dot(gram.ldlt().solve(ls));
  if (!(outside > 1e-12 * ss)) return false;
  const double gain = rs * rs / outside;
  const double floor_rss = m * std::pow(kSheenResidualFloor * least_squares.luminance_albedo, 2);
  // Liberal: one parameter's BIC penalty (FitDiffuseSheen asks for two).
  return BicPrefers(m, rr, rr - gain, floor_rss, 1);
}

PixelFit FitDiffuseSheen(const PixelSamples& samples, const Eigen::Vector3d& view, bool with_albedo,
                         const PixelFitLimits& limits, const PixelFit& start) {
  if (start.status != PixelStatus::kSolved || samples.count() < kSheenMinSamples) return start;
  thread_local SheenScratch scratch;
  SheenFit sheen(samples, view, &scratch);
  return FitDiffuseAndTerm(&sheen, start, limits, with_albedo);
}

}  // namespace scanbench
