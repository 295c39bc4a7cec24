// FitDiffuseLobe (solver/pixel_solvers.h): diffuse plus one isotropic GGX
// lobe per pixel, in the five phases of the diffuse + one-term fits
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

// The diffuse-lobe model's settings: fixed, not tuned per data set.
constexpr int kLobeMinSamples = 7;          // 5 parameters and two spare samples at the least
// GGX alpha range of the fit. A sharper lobe needs denser lights than any rig
// has; a broader one hardly falls off over the lights' hemisphere (at 0.5 the
// mirror direction is still 3x brighter than 30 deg off it, at 1 the lobe is
// flat), so it is not identifiable against the diffuse term and would only
// trade with the albedo (seen on the simulated velvet's grazing sheen).
constexpr double kLobeMinAlpha = 0.02;
constexpr double kLobeMaxAlpha = 0.5;
constexpr double kLobeNormalStep = 2e-4;    // rad (0.01 deg): a smaller step of the normal has converged
constexpr double kLobeLogAlphaStep = 1e-2;  // and of log alpha (1 %)
// A lobe fit whose residual (relative to the albedo) is at most this many
// noise floors (robust_min_scale) gives the albedo too.
constexpr double kLobeAlbedoResidual = 2.0;
constexpr double kLobeAlphaStarts[] = {0.04, 0.1, 0.25, 0.5};

struct LobeParams {
  Eigen::Vector3d normal;
  double rho_d = 0, rho_s = 0, log_alpha = 0;
};

// The lobe's shape term S_k (so that b_k = rho_d (n . l_k) + rho_s S_k) and, if
// asked, its derivatives by n (a vector) and by log alpha.
struct LobeTerm {
  double s = 0;
  Eigen::Vector3d ds_dn = Eigen::Vector3d::Zero();
  double ds_dlog_alpha = 0;
};

inline __attribute__((always_inline)) LobeTerm EvaluateLobe(const Eigen::Vector3d& n, const Eigen::Vector3d& h,
                                                            const Eigen::Vector3d& view, double alpha2,
                                                            bool derivatives) {
  LobeTerm t;
  const double raw_nv = n.dot(view);
  const bool nv_clamped = !(raw_nv > kMinViewCosine);
  const double nv = nv_clamped ? kMinViewCosine : raw_nv;
  const double c = n.dot(h);
  const double q = c * c * (alpha2 - 1) + 1;  // in [alpha^2, 1] for c in [0, 1]
  t.s = alpha2 / (4 * nv * q * q);
  if (derivatives) {
    t.ds_dn = t.s * (-4 * c * (alpha2 - 1) / q) * h;
    if (!nv_clamped) t.ds_dn -= (t.s / nv) * view;
    t.ds_dlog_alpha = t.s * (2 - 4 * alpha2 * c * c / q);
  }
  return t;
}

// One pixel's buffers, kept per thread between pixels.
struct LobeScratch {
  std::vector<double> base, weights, abs_residuals, residual_of;
  std::vector<Eigen::Vector3d> halves;
  std::vector<Eigen::Matrix<double, 5, 1>> rows;  // the Jacobian's rows
};

// One pixel's lobe fit: its samples and Tukey weights, the parameters, and
// the Levenberg-Marquardt functor of phase 3 (solver/levenberg_marquardt.h).
class LobeFit {
 public:
  using Hessian = Eigen::Matrix<double, 5, 5>;
  using Vector = Eigen::Matrix<double, 5, 1>;

  // Phase 1: the half vectors and the samples the fit may use (dark_fraction;
  // none without a half vector). `albedo`: the robust Lambertian fit's, for
  // the noise floor.
  LobeFit(const PixelSamples& samples, const Eigen::Vector3d& view, const RobustFitOptions& options, double albedo,
          LobeScratch* scratch)
      : samples_(samples),
        m_(samples.count()),
        v_(samples.value_data()),
        view_(UnitViewOrZ(view)),
        width_(options.width > 0 ? options.width : kTukeyWidth),
        min_scale_(options.min_scale),
        floor_scale_(options.min_scale * albedo),
        s_(*scratch) {
    BaseWeights(samples, options.dark_fraction, &s_.base);
    HalfVectors(samples, view_, &s_.halves, &s_.base);
  }

  // Phase 2: the robust normal; per alpha start the two amplitudes by plain
  // least squares on the lit samples; the start with the lowest Tukey cost
  // (at the Lambertian fit's residual scale) wins. False when none is usable.
  bool Start(const PixelFit& start) {
    LobeParams lambert;
    lambert.normal = start.normal;
    lambert.rho_d = start.luminance_albedo;
    lambert.log_alpha = std::log(kLobeAlphaStarts[0]);
    const double scale = ScaleOf(lambert);
    double best_cost = std::numeric_limits<double>::infinity();
    for (double alpha : kLobeAlphaStarts) {
      const double alpha2 = alpha * alpha;
      AmplitudeSums sums;
      for (int k = 0; k < m_; ++k) {
        const double nl = start.normal.dot(LightOf(samples_, k));
        if (!(s_.base[k] > 0) || !(nl > 0)) continue;
        const double s = EvaluateLobe(start.normal, s_.halves[k], view_, alpha2, false).s;
        sums.aa += nl * nl, sums.ac += nl * s, sums.cc += s * s, sums.ab += nl * v_[4 * k], sums.cb += s * v_[4 * k];
      }
      LobeParams p = lambert;
      p.log_alpha = std::log(alpha);
      if (!SolveAmplitudes(sums.aa, sums.ac, sums.cc, sums.ab, sums.cb, &p.rho_d, &p.rho_s) || !(p.rho_d > 0)) continue;
      const double rho = TukeyCost(p, alpha2, scale);
      if (rho < best_cost) best_cost = rho, p_ = p;
    }
    if (!std::isfinite(best_cost)) return false;
    s_.residual_of.assign(m_, 0.0);
    s_.weights.assign(m_, 0.0);
    return true;
  }

  // Phase 3: Levenberg-Marquardt from the start (this class its functor).
  // Each linearization's one pass over the samples gives the residuals,
  // their Tukey weights (scale: 1.4826 MAD of the same residuals, floored),
  // the cost and the normal equations; a step is taken when it lowers the
  // cost under those weights.
  static LevenbergMarquardtOptions RefinementOptions() {
    LevenbergMarquardtOptions options;
    options.max_iterations = 30;
    options.max_step_attempts = 6;
    return options;
  }

  // Phase 4: on the final weighted samples the lobe's residual against the
  // Lambertian fit's with the same weights, both floored at the noise level,
  // by BIC (two more parameters).
  bool Selected(const PixelFitLimits& limits) {
    lobe_rss_ = Reweight(p_, ScaleOf(p_));
    double condition = 0, lambert_rss = 0;
    LambertRss(samples_, s_.weights, limits, false, &condition, &lambert_rss, &weight_sum_);
    const double noise_rss = weight_sum_ * floor_scale_ * floor_scale_;
    const double effective = weight_sum_;
    return effective >= kLobeMinSamples && p_.rho_s > 0 && p_.normal.z() > 0 && p_.normal.allFinite() &&
           p_.rho_d >= limits.min_albedo && BicPrefers(effective, lambert_rss, lobe_rss_, noise_rss, 2);
  }

  // Phase 5: the lobe's result over the robust Lambertian `start`.
  PixelFit Result(const PixelFit& start, bool with_albedo) const {
    PixelFit fit = start;
    fit.normal = p_.normal;
    fit.luminance_albedo = p_.rho_d;
    const double alpha = std::exp(p_.log_alpha);
    fit.specular_status = SpecularStatus::kEstimated;
    fit.specular_f0 = std::clamp(p_.rho_s, 0.0, 1.0);
    fit.roughness_alpha = alpha;
    fit.lights_used = 0;
    for (int k = 0; k < m_; ++k) fit.lights_used += s_.weights[k] > kUsedWeight;
    fit.residual = weight_sum_ > 0 ? std::sqrt(lobe_rss_ / weight_sum_) / p_.rho_d : 0.0;
    // The albedo: where the lobe explains the samples to within the noise, per
    // channel with the lobe removed. Elsewhere the one isotropic lobe misfits
    // (an anisotropic satin highlight, a Blinn-Phong tail) and removing it
    // leaks the misfit into the albedo (on the simulated satin the albedo
    // error's p95 went from 0.060 to 0.136), so the albedo stays the robust
    // Lambertian fit's (fit = start): its Tukey weights drop the highlight
    // samples and what is left reads the diffuse colour.
    const bool lobe_fits_to_noise = fit.residual <= kLobeAlbedoResidual * min_scale_;
    if (with_albedo && lobe_fits_to_noise) {
      ColourAlbedo(
          samples_, s_.weights, p_.normal,
          [&](int k) { return EvaluateLobe(p_.normal, s_.halves[k], view_, alpha * alpha, false).s; }, &fit.albedo);
    }
    return fit;
  }

  // ---- the Levenberg-Marquardt functor ----------------------------------

  bool Linearize(Hessian* hessian, Vector* gradient, double* cost) {
    TangentBasis(p_.normal, &t1_, &t2_);
    const double alpha2 = std::exp(2 * p_.log_alpha);
    s_.rows.resize(m_);
    s_.abs_residuals.clear();
    for (int k = 0; k < m_; ++k) {
      const Eigen::Vector3d lk = LightOf(samples_, k);
      const double nl = p_.normal.dot(lk);
      s_.weights[k] = s_.base[k] > 0 && nl > 0 ? 1.0 : 0.0;
      if (!(s_.weights[k] > 0)) continue;
      const LobeTerm t = EvaluateLobe(p_.normal, s_.halves[k], view_, alpha2, true);
      s_.residual_of[k] = p_.rho_d * nl + p_.rho_s * t.s - v_[4 * k];
      s_.abs_residuals.push_back(std::abs(s_.residual_of[k]));
      const Eigen::Vector3d df_dn = p_.rho_d * lk + p_.rho_s * t.ds_dn;
      s_.rows[k] << df_dn.dot(t1_), df_dn.dot(t2_), nl, t.s, p_.rho_s * t.ds_dlog_alpha;
    }
    const double scale = std::max(kMadToSigma * MedianAbs(&s_.abs_residuals), floor_scale_);
    hessian->setZero();
    gradient->setZero();
    *cost = 0;
    int active = 0;
    for (int k = 0; k < m_; ++k) {
      if (!(s_.weights[k] > 0)) continue;
      const double r = s_.residual_of[k];
      const double w = TukeyWeight(r, width_ * scale);
      s_.weights[k] = w;
      if (!(w > 0)) continue;
      const Vector& j = s_.rows[k];
      for (int a = 0; a < 5; ++a) {
        const double wa = w * j[a];
        for (int b = 0; b <= a; ++b) (*hessian)(a, b) += wa * j[b];
      }
      gradient->noalias() += (w * r) * s_.rows[k];
      *cost += w * r * r;
      ++active;
    }
    if (active < kLobeMinSamples) return false;
    for (int a = 0; a < 5; ++a) {
      for (int b = 0; b < a; ++b) (*hessian)(b, a) = (*hessian)(a, b);
    }
    return true;
  }

  bool Trial(const Vector& step, double* cost) {
    trial_ = p_;
    trial_.normal = (p_.normal + step[0] * t1_ + step[1] * t2_).normalized();
    trial_.rho_d = p_.rho_d + step[2];
    trial_.rho_s = std::max(0.0, p_.rho_s + step[3]);
    trial_.log_alpha = std::clamp(p_.log_alpha + step[4], min_log_alpha_, max_log_alpha_);
    const double trial_cost = ProjectedCost(&trial_);
    *cost = trial_.rho_d > 0 && trial_.normal.allFinite() ? trial_cost : std::numeric_limits<double>::infinity();
    return true;
  }

  // Converged: the normal moves by less than 0.01 deg and alpha by less than
  // 1 % (and the cost by less than a millionth: then the step is not taken).
  StepVerdict Take(double cost, double trial_cost) {
    const double change = std::max((trial_.normal - p_.normal).norm() / kLobeNormalStep,
                                   std::abs(trial_.log_alpha - p_.log_alpha) / kLobeLogAlphaStep);
    if (!((cost - trial_cost) > 1e-6 * cost || change > 1)) return StepVerdict::kConverged;
    p_ = trial_;
    return change < 1 ? StepVerdict::kTakenConverged : StepVerdict::kTaken;
  }

 private:
  double Residual(const LobeParams& p, int k, double nl, double alpha2) const {
    return p.rho_d * nl + p.rho_s * EvaluateLobe(p.normal, s_.halves[k], view_, alpha2, false).s - v_[4 * k];
  }

  // Robust scale of the residuals of `p` (1.4826 MAD over the lit samples), floored.
  double ScaleOf(const LobeParams& p) {
    s_.abs_residuals.clear();
    const double alpha2 = std::exp(2 * p.log_alpha);
    for (int k = 0; k < m_; ++k) {
      const double nl = p.normal.dot(LightOf(samples_, k));
      if (!(s_.base[k] > 0) || !(nl > 0)) continue;
      s_.abs_residuals.push_back(std::abs(Residual(p, k, nl, alpha2)));
    }
    return std::max(kMadToSigma * MedianAbs(&s_.abs_residuals), floor_scale_);
  }

  // Tukey weights at `p` into the weights, and the weighted squared residual.
  double Reweight(const LobeParams& p, double scale) {
    s_.weights.assign(m_, 0.0);
    const double alpha2 = std::exp(2 * p.log_alpha);
    double cost = 0;
    for (int k = 0; k < m_; ++k) {
      const double nl = p.normal.dot(LightOf(samples_, k));
      if (!(s_.base[k] > 0) || !(nl > 0)) continue;
      const double r = Residual(p, k, nl, alpha2);
      s_.weights[k] = TukeyWeight(r, width_ * scale);
      cost += s_.weights[k] * r * r;
    }
    return cost;
  }

  // Tukey's rho of `p`'s residuals, in units of scale^2 (rejected samples count fully).
  double TukeyCost(const LobeParams& p, double alpha2, double scale) const {
    double rho = 0;
    const double c2 = width_ * width_ * scale * scale / 6;
    for (int k = 0; k < m_; ++k) {
      const double nl = p.normal.dot(LightOf(samples_, k));
      if (!(s_.base[k] > 0) || !(nl > 0)) continue;
      const double r = Residual(p, k, nl, alpha2);
      const double u2 = r * r / (width_ * width_ * scale * scale);
      const double t = 1 - u2;
      rho += u2 < 1 ? c2 * (1 - t * t * t) : c2;
    }
    return rho;
  }

  // The cost of `p` under the current weights, its two amplitudes first
  // re-solved (variable projection: they are linear given n and alpha, and
  // re-solving them keeps the steps out of the long rho_s-alpha valley).
  double ProjectedCost(LobeParams* p) const {
    const double alpha2 = std::exp(2 * p->log_alpha);
    AmplitudeSums sums;
    for (int k = 0; k < m_; ++k) {
      const double w = s_.weights[k];
      if (!(w > 0)) continue;
      const double b = v_[4 * k];
      sums.bb += w * b * b;  // a sample that falls into attached shadow keeps its full residual
      const double nl = p->normal.dot(LightOf(samples_, k));
      if (!(nl > 0)) continue;
      const double s = EvaluateLobe(p->normal, s_.halves[k], view_, alpha2, false).s;
      sums.aa += w * nl * nl, sums.ac += w * nl * s, sums.cc += w * s * s, sums.ab += w * nl * b, sums.cb += w * s * b;
    }
    return sums.Project(&p->rho_d, &p->rho_s);
  }

  const PixelSamples& samples_;
  const int m_;
  const double* v_;  // the readings, 4 per sample (luminance first)
  const Eigen::Vector3d view_;
  const double width_;        // Tukey width in residual scales
  const double min_scale_;    // RobustFitOptions::min_scale
  const double floor_scale_;  // residual scale floor: min_scale x the Lambertian albedo
  LobeScratch& s_;
  const double min_log_alpha_ = std::log(kLobeMinAlpha), max_log_alpha_ = std::log(kLobeMaxAlpha);
  LobeParams p_, trial_;
  Eigen::Vector3d t1_, t2_;   // the tangent basis of the last linearization
  double lobe_rss_ = 0, weight_sum_ = 0;
};

}  // namespace

PixelFit FitDiffuseLobe(const PixelSamples& samples, const Eigen::Vector3d& view, bool with_albedo,
                        const PixelFitLimits& limits, const RobustFitOptions& options) {
  PixelFit start = FitRobustIrls(samples, with_albedo, limits, options);
  start.specular_status = start.status == PixelStatus::kSolved ? SpecularStatus::kUnsupported : SpecularStatus::kNotSolved;
  if (start.status != PixelStatus::kSolved || samples.count() < kLobeMinSamples) return start;
  thread_local LobeScratch scratch;
  LobeFit lobe(samples, view, options, start.luminance_albedo, &scratch);
  return FitDiffuseAndTerm(&lobe, start, limits, with_albedo);
}

}  // namespace scanbench
