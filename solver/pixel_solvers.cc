#include "solver/pixel_solvers.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <Eigen/QR>
#include <Eigen/SVD>

namespace scanbench {
namespace {

using Matrix34d = Eigen::Matrix<double, 3, 4>;

constexpr double kTukeyWidth = 4.685;   // 95 % efficiency under Gaussian noise
constexpr double kCauchyWidth = 2.385;  // 95 % efficiency under Gaussian noise
constexpr double kMadToSigma = 1.4826;  // median absolute deviation -> standard deviation
constexpr double kUsedWeight = 0.01;    // a sample with a larger weight counts as used
constexpr double kConverged = 1e-5;     // relative change of the scaled normal that ends an iteration

double ClampForStorage(double value) {
  return std::isfinite(value) ? value : double(std::numeric_limits<float>::max());
}

// Fills normal, albedo and status from the scaled normals (columns luminance,
// R, G, B). The residual is the caller's.
void FinishFit(const Matrix34d& scaled, bool with_albedo, const PixelFitLimits& limits, PixelFit* fit) {
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
void WeightedSystem(const PixelSamples& samples, const double* weights, int num_rhs, Eigen::Matrix3d* gram,
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
bool SolveWeighted(const PixelSamples& samples, const std::vector<double>& weights, int num_rhs,
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

double WeightedResidual(const PixelSamples& samples, const std::vector<double>& weights,
                        const Eigen::Vector3d& scaled_normal) {
  double sum = 0, total = 0;
  const double* l = samples.light_data();
  const double* v = samples.value_data();
  for (int k = 0; k < samples.count(); ++k, l += 3, v += 4) {
    if (!(weights[k] > 0)) continue;
    const double r = l[0] * scaled_normal[0] + l[1] * scaled_normal[1] + l[2] * scaled_normal[2] - v[0];
    sum += weights[k] * r * r;
    total += weights[k];
  }
  const double length = scaled_normal.norm();
  return total > 0 && length > 0 ? std::sqrt(sum / total) / length : 0.0;
}

// Weights 1 for the samples the robust fits may use at all (dark_fraction).
void BaseWeights(const PixelSamples& samples, double dark_fraction, std::vector<double>* weights) {
  const int m = samples.count();
  weights->assign(m, 1.0);
  if (!(dark_fraction > 0) || m == 0) return;
  const auto values = samples.values();
  const double brightest = values.col(0).maxCoeff();
  for (int k = 0; k < m; ++k) (*weights)[k] = values(k, 0) >= dark_fraction * brightest ? 1.0 : 0.0;
}

double MedianAbs(std::vector<double>* values) {
  if (values->empty()) return 0;
  const size_t mid = values->size() / 2;
  std::nth_element(values->begin(), values->begin() + mid, values->end());
  return (*values)[mid];
}

}  // namespace

void PixelSamples::Reserve(int capacity) {
  if (lights_.rows() < capacity) {
    lights_.conservativeResize(capacity, 3);
    values_.conservativeResize(capacity, 4);
  }
}

void PixelSamples::Add(double dir_x, double dir_y, double dir_z, double luminance, double red, double green,
                       double blue) {
  if (count_ == lights_.rows()) Reserve(std::max(8, 2 * count_));
  lights_.row(count_) << dir_x, dir_y, dir_z;
  values_.row(count_) << luminance, red, green, blue;
  ++count_;
}

double ConditionNumberFromGram(const Eigen::Matrix3d& gram) {
  if (!gram.allFinite()) return std::numeric_limits<double>::infinity();
  return ConditionNumberFromGram(gram(0, 0), gram(0, 1), gram(0, 2), gram(1, 1), gram(1, 2), gram(2, 2));
}

double ConditionNumberFromGram(double g00, double g01, double g02, double g11, double g12, double g22) {
  // The eigenvalues are the roots of q(t) = t^3 - trace t^2 + minors t - det.
  // Newton converges fast to a simple root from the convex / concave side:
  // from an upper bound to the largest, from 0 to the smallest. A ring of
  // lights makes the largest a double root (slow from above) and a narrow
  // cone makes the smallest one double, so both are tried briefly and the
  // one that converged gives the other two through the quadratic left over.
  // Much cheaper than a general eigen solver; plenty accurate for a ratio.
  const double trace = g00 + g11 + g22;
  const double minors = g00 * g11 + g00 * g22 + g11 * g22 - g01 * g01 - g02 * g02 - g12 * g12;
  const double det = g00 * (g11 * g22 - g12 * g12) - g01 * (g01 * g22 - g12 * g02) + g02 * (g01 * g12 - g11 * g02);
  const double infinity = std::numeric_limits<double>::infinity();
  if (!(trace > 0) || !std::isfinite(det)) return infinity;
  const double scale = trace * trace * trace;
  if (!(det > 1e-30 * scale)) return infinity;  // singular to rounding
  auto q = [&](double t) { return ((t - trace) * t + minors) * t - det; };
  auto slope = [&](double t) { return (3 * t - 2 * trace) * t + minors; };
  constexpr double kTolerance = 1e-9;  // relative step that counts as converged
  auto newton = [&](double t, int max_iterations, bool* converged) {
    *converged = false;
    for (int iteration = 0; iteration < max_iterations; ++iteration) {
      const double d = slope(t);
      if (!(d != 0) || !std::isfinite(d)) return t;
      const double step = q(t) / d;
      t -= step;
      if (!(std::abs(step) > kTolerance * std::abs(t))) {
        *converged = true;
        return t;
      }
    }
    return t;
  };
  // The other two roots from one root r: sum trace - r, product det / r.
  auto others = [&](double r, double* low, double* high) {
    const double sum = trace - r, product = det / r;
    const double root = std::sqrt(std::max(0.0, sum * sum - 4 * product));
    *high = 0.5 * (sum + root);
    *low = *high > 0 ? product / *high : 0.0;
  };
  double lambda_min = 0, lambda_max = 0, low = 0, high = 0;
  bool converged = false;
  // Most light rigs (rings, cones around the camera) have a simple largest
  // eigenvalue: try that first.
  const double gershgorin = std::max({g00 + std::abs(g01) + std::abs(g02), std::abs(g01) + g11 + std::abs(g12),
                                      std::abs(g02) + std::abs(g12) + g22});
  const double top = std::min(trace, gershgorin);
  lambda_max = newton(top, 8, &converged);
  if (converged && lambda_max > 0) {
    others(lambda_max, &low, &high);
    lambda_min = low;
  } else {
    lambda_min = newton(0.0, 8, &converged);
    if (converged && lambda_min > 0) {
      others(lambda_min, &low, &high);
      lambda_max = high;
    } else {
      lambda_max = newton(lambda_max, 80, &converged);
      if (!(lambda_max > 0)) return infinity;
      others(lambda_max, &low, &high);
      lambda_min = low;
    }
  }
  if (!(lambda_min > 1e-15 * lambda_max) || !std::isfinite(lambda_max)) return infinity;
  return std::sqrt(lambda_max / lambda_min);
}

PixelFit FitLeastSquares(DenseMethod method, const PixelSamples& samples, bool with_albedo,
                         const PixelFitLimits& limits) {
  PixelFit fit;
  const int m = samples.count();
  fit.lights_used = m;
  if (m < std::max(3, limits.min_lights)) {
    fit.status = PixelStatus::kTooFewLights;
    return fit;
  }
  const int num_rhs = with_albedo ? 4 : 1;
  const auto lights = samples.lights();
  const auto values = samples.values();
  Matrix34d scaled = Matrix34d::Zero();
  switch (method) {
    case DenseMethod::kJacobiSvd: {
      thread_local Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 3>> svd;
      svd.compute(lights, Eigen::ComputeThinU | Eigen::ComputeThinV);
      const Eigen::Vector3d& singular = svd.singularValues();
      fit.condition_number =
          singular[2] > 0 ? singular[0] / singular[2] : std::numeric_limits<double>::infinity();
      if (!(fit.condition_number <= limits.max_condition_number)) break;
      scaled.leftCols(num_rhs) = svd.solve(values.leftCols(num_rhs));
      break;
    }
    case DenseMethod::kQr: {
      thread_local Eigen::HouseholderQR<Eigen::Matrix<double, Eigen::Dynamic, 3>> qr;
      qr.compute(lights);
      const Eigen::Matrix3d r = qr.matrixQR().topRows<3>().triangularView<Eigen::Upper>();
      fit.condition_number = ConditionNumberFromGram(r.transpose() * r);
      if (!(fit.condition_number <= limits.max_condition_number)) break;
      scaled.leftCols(num_rhs) = qr.solve(values.leftCols(num_rhs));
      break;
    }
    case DenseMethod::kNormalEquations: {
      const Eigen::Matrix3d gram = lights.transpose() * lights;
      fit.condition_number = ConditionNumberFromGram(gram);
      if (!(fit.condition_number <= limits.max_condition_number)) break;
      scaled.leftCols(num_rhs) = gram.inverse() * (lights.transpose() * values.leftCols(num_rhs));
      break;
    }
  }
  if (!(fit.condition_number <= limits.max_condition_number)) {
    fit.status = PixelStatus::kIllConditioned;
    fit.condition_number = ClampForStorage(fit.condition_number);
    return fit;
  }
  FinishFit(scaled, with_albedo, limits, &fit);
  if (fit.status != PixelStatus::kSolved) return fit;
  const Eigen::VectorXd residuals = lights * scaled.col(0) - values.col(0);
  fit.residual = std::sqrt(residuals.squaredNorm() / m) / fit.luminance_albedo;
  return fit;
}

namespace {

// The robust fits' last step: the weighted solve with the final weights
// (luminance and, if asked, R, G, B), exact condition number and weighted
// residual; plain least squares when that system is unusable.
PixelFit FitWithFinalWeights(const PixelSamples& samples, const std::vector<double>& weights, bool with_albedo,
                             const PixelFitLimits& limits) {
  Matrix34d scaled;
  double condition = 0;
  int used = 0;
  if (!SolveWeighted(samples, weights, with_albedo ? 4 : 1, limits, &scaled, &condition, &used)) {
    return FitLeastSquares(DenseMethod::kNormalEquations, samples, with_albedo, limits);
  }
  PixelFit fit;
  fit.lights_used = used;
  fit.condition_number = ClampForStorage(condition);
  FinishFit(scaled, with_albedo, limits, &fit);
  if (fit.status == PixelStatus::kSolved) fit.residual = WeightedResidual(samples, weights, scaled.col(0));
  return fit;
}

}  // namespace

PixelFit FitRobustIrls(const PixelSamples& samples, bool with_albedo, const PixelFitLimits& limits,
                       const RobustFitOptions& options) {
  const int m = samples.count();
  if (m < std::max(3, limits.min_lights)) return FitLeastSquares(DenseMethod::kNormalEquations, samples, with_albedo, limits);
  thread_local std::vector<double> base, weights, trial, abs_residuals;
  BaseWeights(samples, options.dark_fraction, &base);
  weights = base;

  Matrix34d scaled;
  double condition = 0;
  int used = 0;
  if (!SolveWeighted(samples, weights, 1, limits, &scaled, &condition, &used, false)) {
    return FitLeastSquares(DenseMethod::kNormalEquations, samples, with_albedo, limits);
  }
  const bool tukey = options.loss == PhotometricSolverOptions::RobustLoss::kTukey;
  const double width = options.width > 0 ? options.width : (tukey ? kTukeyWidth : kCauchyWidth);
  const double* l = samples.light_data();
  const double* v = samples.value_data();
  thread_local std::vector<double> residuals;
  residuals.resize(m);
  Eigen::Vector3d normal = scaled.col(0);
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    abs_residuals.clear();
    for (int k = 0; k < m; ++k) {
      const double shading = l[3 * k] * normal[0] + l[3 * k + 1] * normal[1] + l[3 * k + 2] * normal[2];
      // Attached shadow at this estimate: not Lambertian-observable.
      residuals[k] = shading > 0 ? shading - v[4 * k] : std::numeric_limits<double>::infinity();
      if (base[k] > 0) abs_residuals.push_back(std::abs(shading - v[4 * k]));
    }
    const double scale = std::max(kMadToSigma * MedianAbs(&abs_residuals), options.min_scale * normal.norm());
    const double inverse_width = 1 / (width * scale);
    trial.resize(m);
    for (int k = 0; k < m; ++k) {
      const double u = residuals[k] * inverse_width;  // infinity -> weight 0
      double weight;
      if (tukey) {
        const double t = 1 - u * u;
        weight = t > 0 ? t * t : 0.0;
      } else {
        weight = 1 / (1 + u * u);
      }
      trial[k] = base[k] > 0 && std::isfinite(u) ? weight : 0.0;
    }
    Matrix34d next;
    if (!SolveWeighted(samples, trial, 1, limits, &next, &condition, &used, false)) break;
    const double change = (next.col(0) - normal).norm();
    normal = next.col(0);
    weights.swap(trial);
    if (change <= kConverged * normal.norm()) break;
  }
  return FitWithFinalWeights(samples, weights, with_albedo, limits);
}

PixelFit FitSparseBayesian(const PixelSamples& samples, bool with_albedo, const PixelFitLimits& limits,
                           const RobustFitOptions& options) {
  const int m = samples.count();
  if (m < std::max(3, limits.min_lights)) return FitLeastSquares(DenseMethod::kNormalEquations, samples, with_albedo, limits);
  thread_local std::vector<double> base, gamma, weights;
  BaseWeights(samples, options.dark_fraction, &base);
  Matrix34d scaled;
  double condition = 0;
  int used = 0;
  if (!SolveWeighted(samples, base, 1, limits, &scaled, &condition, &used)) {
    return FitLeastSquares(DenseMethod::kNormalEquations, samples, with_albedo, limits);
  }
  const double* light_data = samples.light_data();
  const double* value_data = samples.value_data();
  Eigen::Vector3d normal = scaled.col(0);
  // Dense noise variance: the residual floor the robust fits share.
  const double noise = std::pow(options.min_scale * std::max(normal.norm(), limits.min_albedo), 2);
  gamma.assign(m, 0.0);
  for (int k = 0; k < m; ++k) {
    const double r = value_data[4 * k] - (light_data[3 * k] * normal[0] + light_data[3 * k + 1] * normal[1] +
                                         light_data[3 * k + 2] * normal[2]);
    gamma[k] = std::max(r * r, noise);
  }
  weights.assign(m, 0.0);
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    // Weights of the marginal likelihood: 1 / (gamma_k + noise).
    for (int k = 0; k < m; ++k) weights[k] = base[k] > 0 ? 1.0 / (gamma[k] + noise) : 0.0;
    Eigen::Matrix3d gram;
    Matrix34d rhs;
    int count = 0;
    WeightedSystem(samples, weights.data(), 1, &gram, &rhs, &count);
    if (!(ConditionNumberFromGram(gram) <= limits.max_condition_number)) break;
    const Eigen::Matrix3d inverse = gram.inverse();
    const Eigen::Vector3d next = inverse * rhs.col(0);
    if (!next.allFinite()) break;
    double largest_change = 0;
    for (int k = 0; k < m; ++k) {
      if (!(base[k] > 0)) continue;
      const Eigen::Vector3d l(light_data[3 * k], light_data[3 * k + 1], light_data[3 * k + 2]);
      const double r = value_data[4 * k] - l.dot(next);
      const double shrink = gamma[k] * weights[k];  // gamma / (gamma + noise)
      const double mean = shrink * r;               // posterior mean of e_k
      const double variance = gamma[k] * (1 - shrink) + shrink * shrink * l.dot(inverse * l);
      const double updated = std::max(mean * mean + variance, 1e-12 * noise);
      largest_change = std::max(largest_change, std::abs(updated - gamma[k]) / (updated + noise));
      gamma[k] = updated;
    }
    const double change = (next - normal).norm();
    normal = next;
    if (largest_change < 1e-4 || change <= kConverged * normal.norm()) break;
  }
  // Final weights in [0, 1]: 1 for a sample with no learned error.
  for (int k = 0; k < m; ++k) weights[k] = base[k] > 0 ? noise / (gamma[k] + noise) : 0.0;
  return FitWithFinalWeights(samples, weights, with_albedo, limits);
}

namespace {

// The diffuse-lobe model's settings: fixed, not tuned per data set.
constexpr int kLobeMinSamples = 7;          // 5 parameters and two spare samples at the least
// GGX alpha range of the fit. A sharper lobe needs denser lights than any rig
// has; a broader one hardly falls off over the lights' hemisphere (at 0.5 the
// mirror direction is still 3x brighter than 30 deg off it, at 1 the lobe is
// flat), so it is not identifiable against the diffuse term and would only
// trade with the albedo (seen on the simulated velvet's grazing sheen).
constexpr double kLobeMinAlpha = 0.02;
constexpr double kLobeMaxAlpha = 0.5;
constexpr double kLobeMinViewCosine = 0.1;  // n . v floor: near-grazing views only rescale rho_s
constexpr int kLobeIterations = 30;         // Levenberg-Marquardt steps (weights refreshed each)
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

inline __attribute__((always_inline)) LobeTerm EvaluateLobe(const Eigen::Vector3d& n, const Eigen::Vector3d& h, const Eigen::Vector3d& view,
                      double alpha2, bool derivatives) {
  LobeTerm t;
  const double raw_nv = n.dot(view);
  const bool nv_clamped = !(raw_nv > kLobeMinViewCosine);
  const double nv = nv_clamped ? kLobeMinViewCosine : raw_nv;
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

double TukeyWeight(double r, double width_scale) {
  const double u = r / width_scale;
  const double t = 1 - u * u;
  return t > 0 ? t * t : 0.0;
}

// Unit vectors t1, t2 completing n to an orthonormal basis.
void TangentBasis(const Eigen::Vector3d& n, Eigen::Vector3d* t1, Eigen::Vector3d* t2) {
  const Eigen::Vector3d helper = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *t1 = n.cross(helper).normalized();
  *t2 = n.cross(*t1);
}

// Weighted 2-parameter least squares b ~ x0 a + x1 c (the diffuse and lobe
// amplitudes for a fixed normal and lobe shape); x1 held >= 0. False when singular.
bool SolveAmplitudes(double aa, double ac, double cc, double ab, double cb, double* x0, double* x1) {
  const double det = aa * cc - ac * ac;
  if (det > 1e-12 * aa * cc && aa > 0) {
    *x0 = (cc * ab - ac * cb) / det;
    *x1 = (aa * cb - ac * ab) / det;
    if (*x1 >= 0) return std::isfinite(*x0) && std::isfinite(*x1);
  }
  if (!(aa > 0)) return false;
  *x0 = ab / aa;  // the lobe's amplitude at its bound: diffuse only
  *x1 = 0;
  return std::isfinite(*x0);
}

}  // namespace

PixelFit FitDiffuseLobe(const PixelSamples& samples, const Eigen::Vector3d& view_in, bool with_albedo,
                        const PixelFitLimits& limits, const RobustFitOptions& options) {
  PixelFit start = FitRobustIrls(samples, with_albedo, limits, options);
  start.specular_status = start.status == PixelStatus::kSolved ? SpecularStatus::kUnsupported : SpecularStatus::kNotSolved;
  const int m = samples.count();
  if (start.status != PixelStatus::kSolved || m < kLobeMinSamples) return start;
  const Eigen::Vector3d view = view_in.allFinite() && view_in.norm() > 0 ? view_in.normalized() : Eigen::Vector3d::UnitZ();
  thread_local std::vector<double> base, weights;
  thread_local std::vector<Eigen::Vector3d> halves;
  BaseWeights(samples, options.dark_fraction, &base);
  halves.resize(m);
  const double* l = samples.light_data();
  const double* v = samples.value_data();
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d sum = Eigen::Vector3d(l[3 * k], l[3 * k + 1], l[3 * k + 2]) + view;
    const double length = sum.norm();
    if (length > 1e-6) {
      halves[k] = sum / length;
    } else {
      halves[k] = view, base[k] = 0;  // light opposite the camera: no half vector
    }
  }
  const double width = options.width > 0 ? options.width : kTukeyWidth;
  const double floor_scale = options.min_scale * start.luminance_albedo;
  auto light = [&](int k) { return Eigen::Vector3d(l[3 * k], l[3 * k + 1], l[3 * k + 2]); };

  // Robust scale of the residuals of `p` (1.4826 MAD over the lit samples), floored.
  thread_local std::vector<double> abs_residuals;
  auto scale_of = [&](const LobeParams& p) {
    abs_residuals.clear();
    const double alpha2 = std::exp(2 * p.log_alpha);
    for (int k = 0; k < m; ++k) {
      const double nl = p.normal.dot(light(k));
      if (!(base[k] > 0) || !(nl > 0)) continue;
      const double f = p.rho_d * nl + p.rho_s * EvaluateLobe(p.normal, halves[k], view, alpha2, false).s;
      abs_residuals.push_back(std::abs(f - v[4 * k]));
    }
    return std::max(kMadToSigma * MedianAbs(&abs_residuals), floor_scale);
  };
  // Tukey weights at `p` into `weights`, and the weighted squared residual.
  auto reweight = [&](const LobeParams& p, double scale) {
    weights.assign(m, 0.0);
    const double alpha2 = std::exp(2 * p.log_alpha);
    double cost = 0;
    for (int k = 0; k < m; ++k) {
      const double nl = p.normal.dot(light(k));
      if (!(base[k] > 0) || !(nl > 0)) continue;
      const double r = p.rho_d * nl + p.rho_s * EvaluateLobe(p.normal, halves[k], view, alpha2, false).s - v[4 * k];
      weights[k] = TukeyWeight(r, width * scale);
      cost += weights[k] * r * r;
    }
    return cost;
  };
  // The cost of `p` under the current weights, its two amplitudes first
  // re-solved (variable projection: they are linear given n and alpha, and
  // re-solving them keeps the steps out of the long rho_s-alpha valley).
  auto projected_cost = [&](LobeParams* p) {
    const double alpha2 = std::exp(2 * p->log_alpha);
    double aa = 0, ac = 0, cc = 0, ab = 0, cb = 0, bb = 0;
    for (int k = 0; k < m; ++k) {
      const double w = weights[k];
      if (!(w > 0)) continue;
      const double b = v[4 * k];
      bb += w * b * b;  // a sample that falls into attached shadow keeps its full residual
      const double nl = p->normal.dot(light(k));
      if (!(nl > 0)) continue;
      const double s = EvaluateLobe(p->normal, halves[k], view, alpha2, false).s;
      aa += w * nl * nl, ac += w * nl * s, cc += w * s * s, ab += w * nl * b, cb += w * s * b;
    }
    if (!SolveAmplitudes(aa, ac, cc, ab, cb, &p->rho_d, &p->rho_s)) return std::numeric_limits<double>::infinity();
    const double d = p->rho_d, sp = p->rho_s;
    return std::max(0.0, bb - 2 * (d * ab + sp * cb) + d * d * aa + 2 * d * sp * ac + sp * sp * cc);
  };

  // Start: the robust normal; per alpha start the two amplitudes by plain
  // least squares on the lit samples; the start with the lowest Tukey cost
  // (at the Lambertian fit's residual scale) wins.
  LobeParams best;
  double best_cost = std::numeric_limits<double>::infinity();
  {
    LobeParams lambert;
    lambert.normal = start.normal;
    lambert.rho_d = start.luminance_albedo;
    lambert.log_alpha = std::log(kLobeAlphaStarts[0]);
    const double scale = scale_of(lambert);
    for (double alpha : kLobeAlphaStarts) {
      const double alpha2 = alpha * alpha;
      double aa = 0, ac = 0, cc = 0, ab = 0, cb = 0;
      for (int k = 0; k < m; ++k) {
        const double nl = start.normal.dot(light(k));
        if (!(base[k] > 0) || !(nl > 0)) continue;
        const double s = EvaluateLobe(start.normal, halves[k], view, alpha2, false).s;
        aa += nl * nl, ac += nl * s, cc += s * s, ab += nl * v[4 * k], cb += s * v[4 * k];
      }
      LobeParams p = lambert;
      p.log_alpha = std::log(alpha);
      if (!SolveAmplitudes(aa, ac, cc, ab, cb, &p.rho_d, &p.rho_s) || !(p.rho_d > 0)) continue;
      // Robust cost: Tukey's rho, in units of scale^2 (rejected samples count fully).
      double rho = 0;
      const double c2 = width * width * scale * scale / 6;
      for (int k = 0; k < m; ++k) {
        const double nl = p.normal.dot(light(k));
        if (!(base[k] > 0) || !(nl > 0)) continue;
        const double r = p.rho_d * nl + p.rho_s * EvaluateLobe(p.normal, halves[k], view, alpha2, false).s - v[4 * k];
        const double u2 = r * r / (width * width * scale * scale);
        const double t = 1 - u2;
        rho += u2 < 1 ? c2 * (1 - t * t * t) : c2;
      }
      if (rho < best_cost) best_cost = rho, best = p;
    }
  }
  if (!std::isfinite(best_cost)) return start;

  // Levenberg-Marquardt. Each iteration's one pass over the samples gives
  // the residuals, their Tukey weights (scale: 1.4826 MAD of the same
  // residuals, floored), the cost and the damped normal equations; the step is
  // accepted when it lowers the cost under those weights.
  const double min_log_alpha = std::log(kLobeMinAlpha), max_log_alpha = std::log(kLobeMaxAlpha);
  LobeParams p = best;
  double lambda = 1e-3;
  thread_local std::vector<double> residual_of;
  residual_of.assign(m, 0.0);
  weights.assign(m, 0.0);
  for (int iteration = 0; iteration < kLobeIterations; ++iteration) {
    Eigen::Vector3d t1, t2;
    TangentBasis(p.normal, &t1, &t2);
    const double alpha2 = std::exp(2 * p.log_alpha);
    thread_local std::vector<Eigen::Matrix<double, 5, 1>> rows;
    rows.resize(m);
    abs_residuals.clear();
    for (int k = 0; k < m; ++k) {
      const Eigen::Vector3d lk = light(k);
      const double nl = p.normal.dot(lk);
      weights[k] = base[k] > 0 && nl > 0 ? 1.0 : 0.0;
      if (!(weights[k] > 0)) continue;
      const LobeTerm t = EvaluateLobe(p.normal, halves[k], view, alpha2, true);
      residual_of[k] = p.rho_d * nl + p.rho_s * t.s - v[4 * k];
      abs_residuals.push_back(std::abs(residual_of[k]));
      const Eigen::Vector3d df_dn = p.rho_d * lk + p.rho_s * t.ds_dn;
      rows[k] << df_dn.dot(t1), df_dn.dot(t2), nl, t.s, p.rho_s * t.ds_dlog_alpha;
    }
    const double scale = std::max(kMadToSigma * MedianAbs(&abs_residuals), floor_scale);
    Eigen::Matrix<double, 5, 5> hessian = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, 1> gradient = Eigen::Matrix<double, 5, 1>::Zero();
    double cost = 0;
    int active = 0;
    for (int k = 0; k < m; ++k) {
      if (!(weights[k] > 0)) continue;
      const double r = residual_of[k];
      const double w = TukeyWeight(r, width * scale);
      weights[k] = w;
      if (!(w > 0)) continue;
      const Eigen::Matrix<double, 5, 1>& j = rows[k];
      for (int a = 0; a < 5; ++a) {
        const double wa = w * j[a];
        for (int b = 0; b <= a; ++b) hessian(a, b) += wa * j[b];
      }
      gradient.noalias() += (w * r) * rows[k];
      cost += w * r * r;
      ++active;
    }
    if (active < kLobeMinSamples) break;
    for (int a = 0; a < 5; ++a) {
      for (int b = 0; b < a; ++b) hessian(b, a) = hessian(a, b);
    }
    bool accepted = false;
    double change = 0;
    for (int attempt = 0; attempt < 6 && !accepted; ++attempt) {
      Eigen::Matrix<double, 5, 5> damped = hessian;
      for (int i = 0; i < 5; ++i) damped(i, i) += lambda * std::max(hessian(i, i), 1e-12);
      const Eigen::Matrix<double, 5, 1> step = damped.ldlt().solve(-gradient);
      if (!step.allFinite()) {
        lambda *= 10;
        continue;
      }
      LobeParams trial = p;
      trial.normal = (p.normal + step[0] * t1 + step[1] * t2).normalized();
      trial.rho_d = p.rho_d + step[2];
      trial.rho_s = std::max(0.0, p.rho_s + step[3]);
      trial.log_alpha = std::clamp(p.log_alpha + step[4], min_log_alpha, max_log_alpha);
      const double trial_cost = projected_cost(&trial);
      if (trial_cost < cost && trial.rho_d > 0 && trial.normal.allFinite()) {
        // Converged: the normal moves by less than 0.01 deg and alpha by less than 1 %.
        change = std::max((trial.normal - p.normal).norm() / kLobeNormalStep,
                          std::abs(trial.log_alpha - p.log_alpha) / kLobeLogAlphaStep);
        accepted = (cost - trial_cost) > 1e-6 * cost || change > 1;  // else converged: keep p
        if (accepted) p = trial;
        lambda = std::max(lambda / 3, 1e-9);
        if (!accepted) break;
      } else {
        lambda *= 4;
      }
    }
    if (!accepted || change < 1) break;
  }
  // Model selection on the final weighted samples: the lobe's residual
  // against the Lambertian fit's with the same weights, both floored at the
  // noise level, by BIC (two more parameters).
  const double lobe_rss = reweight(p, scale_of(p));
  Matrix34d lambert_scaled;
  double condition = 0;
  int used = 0;
  const bool lambert_ok = SolveWeighted(samples, weights, 1, limits, &lambert_scaled, &condition, &used, false);
  double lambert_rss = 0, weight_sum = 0;
  for (int k = 0; k < m; ++k) {
    if (!(weights[k] > 0)) continue;
    const double r = lambert_ok ? light(k).dot(lambert_scaled.col(0)) - v[4 * k] : v[4 * k];
    lambert_rss += weights[k] * r * r;
    weight_sum += weights[k];
  }
  const double noise_rss = weight_sum * floor_scale * floor_scale;
  const double effective = weight_sum;
  const bool lobe_pays = effective >= kLobeMinSamples && p.rho_s > 0 && p.normal.z() > 0 && p.normal.allFinite() &&
                         p.rho_d >= limits.min_albedo &&
                         effective * std::log(std::max(lambert_rss, noise_rss) / std::max(lobe_rss, noise_rss)) >
                             2 * std::log(effective);
  if (!lobe_pays) return start;

  PixelFit fit = start;
  fit.normal = p.normal;
  fit.luminance_albedo = p.rho_d;
  const double alpha = std::exp(p.log_alpha);
  fit.specular_status = SpecularStatus::kEstimated;
  fit.specular_f0 = std::clamp(p.rho_s, 0.0, 1.0);
  fit.roughness_alpha = alpha;
  fit.lights_used = 0;
  for (int k = 0; k < m; ++k) fit.lights_used += weights[k] > kUsedWeight;
  fit.residual = weight_sum > 0 ? std::sqrt(lobe_rss / weight_sum) / p.rho_d : 0.0;
  // The albedo: where the lobe explains the samples to within the noise, per
  // channel with the lobe removed (below). Elsewhere the one isotropic lobe
  // misfits (an anisotropic satin highlight, a Blinn-Phong tail) and
  // removing it leaks the misfit into the albedo (on the simulated satin the
  // albedo error's p95 went from 0.060 to 0.136), so the albedo stays the
  // robust Lambertian fit's (fit = start): its Tukey weights drop the
  // highlight samples and what is left reads the diffuse colour.
  const bool lobe_fits_to_noise = fit.residual <= kLobeAlbedoResidual * options.min_scale;
  if (with_albedo && lobe_fits_to_noise) {
    // Per channel: rho_d,c and that channel's lobe amplitude, n and the lobe shape fixed.
    double aa = 0, ac = 0, cc = 0, ab[3] = {0, 0, 0}, cb[3] = {0, 0, 0};
    for (int k = 0; k < m; ++k) {
      if (!(weights[k] > 0)) continue;
      const double nl = p.normal.dot(light(k));
      const double s = EvaluateLobe(p.normal, halves[k], view, alpha * alpha, false).s;
      const double w = weights[k];
      aa += w * nl * nl, ac += w * nl * s, cc += w * s * s;
      for (int c = 0; c < 3; ++c) ab[c] += w * nl * v[4 * k + 1 + c], cb[c] += w * s * v[4 * k + 1 + c];
    }
    for (int c = 0; c < 3; ++c) {
      double diffuse = 0, lobe = 0;
      fit.albedo[c] = SolveAmplitudes(aa, ac, cc, ab[c], cb[c], &diffuse, &lobe) ? std::max(0.0, diffuse) : 0.0;
    }
  }
  return fit;
}

namespace {

// The velvet sheen fit's settings: fixed, not tuned per data set.
constexpr int kSheenMinSamples = 6;  // 4 fitted parameters (and the width) and a spare sample
// Velvet widths a tried (a geometric ladder over the seed's range: at 0.5 the
// sheen has faded into its constant offset at every rig angle, at 1.4 it
// rises from the normal on).
constexpr double kSheenWidths[] = {0.5, 0.7, 1.0, 1.4};
constexpr double kSheenMinWidth = 0.3;     // fitted width range: narrower is a rim no rig angle reaches,
constexpr double kSheenMaxWidth = 2.0;     // broader is flat
constexpr double kSheenTestWidth = 1.0;    // the residual test's width (mid-ladder)
constexpr double kVelvetAmplitude = kVelvetSheenAmplitude;
static_assert(kLobeMinViewCosine == kVelvetSheenMinViewCosine, "the sheen's n . v floor is the lobe's");
constexpr int kSheenIterations = 12;       // Gauss-Newton steps
constexpr double kSheenNormalStep = 2e-4;  // rad (0.01 deg): a smaller step of the normal has converged
// Residual floor of the model selection, relative to rho_d: below about the
// quantisation of a 14-bit reading of a mid-grey the residual is not evidence.
constexpr double kSheenResidualFloor = 1e-3;

// S (VelvetSheenShape) and, if asked, dS/dn.
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
  const bool nv_clamped = !(raw_nv > kLobeMinViewCosine);
  const double nv = nv_clamped ? kLobeMinViewCosine : std::min(raw_nv, 1.0);
  const double c = std::clamp(n.dot(half), 0.0, 1.0);
  const double s2 = 1 - c * c;
  const double a2 = width * width;
  const double norm = 1 / (1 + kVelvetAmplitude * a2);
  // G = 1 + A exp(-cot^2 / a^2) / sin^4: at th_h -> 0 the exponential wins.
  double g = 1, dg_dc = 0, dg_dlog_width = 0;
  if (s2 > 1e-6) {
    const double cot2 = c * c / s2;
    const double e = std::exp(-cot2 / a2);
    const double inv_s4 = 1 / (s2 * s2);
    g += kVelvetAmplitude * e * inv_s4;
    dg_dc = kVelvetAmplitude * e * c * inv_s4 / s2 * (4 - 2 / (a2 * s2));
    dg_dlog_width = kVelvetAmplitude * e * inv_s4 * 2 * cot2 / a2;
  }
  const double den = nl + nv - nl * nv;  // >= max(nl, nv) > 0
  const double q = nl / (4 * den);
  t.s = norm * g * q;
  if (derivatives) {
    const double inv_den2 = 1 / (4 * den * den);
    t.ds_dn = norm * (dg_dc * q * half + g * nv * inv_den2 * light);
    if (!nv_clamped && raw_nv < 1) t.ds_dn -= norm * g * nl * (1 - nl) * inv_den2 * view;
    t.ds_dlog_width = norm * q * dg_dlog_width - t.s * 2 * kVelvetAmplitude * a2 * norm;
  }
  return t;
}

}  // namespace

VelvetSheenGeometry VelvetSheenGeometryOf(const Eigen::Vector3d& n, const Eigen::Vector3d& light,
                                          const Eigen::Vector3d& half, const Eigen::Vector3d& view) {
  VelvetSheenGeometry g;
  const double nl = n.dot(light);
  if (!(nl > 0)) return g;
  const double raw_nv = n.dot(view);
  const double nv = !(raw_nv > kLobeMinViewCosine) ? kLobeMinViewCosine : std::min(raw_nv, 1.0);
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
  const Eigen::Vector3d view =
      view_in.allFinite() && view_in.norm() > 0 ? view_in.normalized() : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d n = least_squares.normal;
  const Eigen::Vector3d scaled = least_squares.luminance_albedo * n;
  const double* l = samples.light_data();
  const double* v = samples.value_data();
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  Eigen::Vector3d ls = Eigen::Vector3d::Zero();
  double ss = 0, rs = 0, rr = 0;
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d lk(l[3 * k], l[3 * k + 1], l[3 * k + 2]);
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
  return m * std::log(std::max(rr, floor_rss) / std::max(rr - gain, floor_rss)) > std::log(double(m));
}

PixelFit FitDiffuseSheen(const PixelSamples& samples, const Eigen::Vector3d& view_in, bool with_albedo,
                         const PixelFitLimits& limits, const PixelFit& start) {
  const int m = samples.count();
  if (start.status != PixelStatus::kSolved || m < kSheenMinSamples) return start;
  const Eigen::Vector3d view =
      view_in.allFinite() && view_in.norm() > 0 ? view_in.normalized() : Eigen::Vector3d::UnitZ();
  thread_local std::vector<Eigen::Vector3d> halves;
  thread_local std::vector<double> usable;
  halves.resize(m);
  usable.assign(m, 1.0);
  const double* l = samples.light_data();
  const double* v = samples.value_data();
  auto light = [&](int k) { return Eigen::Vector3d(l[3 * k], l[3 * k + 1], l[3 * k + 2]); };
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d sum = light(k) + view;
    const double length = sum.norm();
    if (length > 1e-6) {
      halves[k] = sum / length;
    } else {
      halves[k] = view, usable[k] = 0;  // light opposite the camera: no half vector
    }
  }
  struct Params {
    Eigen::Vector3d normal;
    double rho_d = 0, rho_s = 0;
  };
  // The two amplitudes by least squares for `p.normal` (rho_s >= 0) and the
  // cost; samples with n . l <= 0 there keep their whole reading as residual.
  auto project = [&](Params* p, double width) {
    double aa = 0, ac = 0, cc = 0, ab = 0, cb = 0, bb = 0;
    for (int k = 0; k < m; ++k) {
      if (!(usable[k] > 0)) continue;
      const double b = v[4 * k];
      bb += b * b;
      const double nl = p->normal.dot(light(k));
      if (!(nl > 0)) continue;
      const double s = EvaluateSheen(p->normal, light(k), halves[k], view, width, false).s;
      aa += nl * nl, ac += nl * s, cc += s * s, ab += nl * b, cb += s * b;
    }
    if (!SolveAmplitudes(aa, ac, cc, ab, cb, &p->rho_d, &p->rho_s)) return std::numeric_limits<double>::infinity();
    const double d = p->rho_d, sp = p->rho_s;
    return std::max(0.0, bb - 2 * (d * ab + sp * cb) + d * d * aa + 2 * d * sp * ac + sp * sp * cc);
  };
  // Gauss-Newton over the normal (two tangent angles) and both amplitudes;
  // a step is tried with the amplitudes re-solved (variable projection) and
  // halved until it lowers the cost.
  auto refine = [&](Params& p, double& width, double& cost) {
    for (int iteration = 0; iteration < kSheenIterations; ++iteration) {
      Eigen::Vector3d t1, t2;
      TangentBasis(p.normal, &t1, &t2);
      Eigen::Matrix<double, 5, 5> hessian = Eigen::Matrix<double, 5, 5>::Zero();
      Eigen::Matrix<double, 5, 1> gradient = Eigen::Matrix<double, 5, 1>::Zero();
      for (int k = 0; k < m; ++k) {
        if (!(usable[k] > 0)) continue;
        const Eigen::Vector3d lk = light(k);
        const double nl = p.normal.dot(lk);
        if (!(nl > 0)) continue;
        const SheenTerm t = EvaluateSheen(p.normal, lk, halves[k], view, width, true);
        const double r = p.rho_d * nl + p.rho_s * t.s - v[4 * k];
        const Eigen::Vector3d df_dn = p.rho_d * lk + p.rho_s * t.ds_dn;
        Eigen::Matrix<double, 5, 1> j;
        j << df_dn.dot(t1), df_dn.dot(t2), nl, t.s, p.rho_s * t.ds_dlog_width;
        hessian.noalias() += j * j.transpose();
        gradient.noalias() += r * j;
      }
      // Light damping: the width is poorly constrained where the sheen is weak.
      for (int i = 0; i < 5; ++i) hessian(i, i) += 1e-3 * std::max(hessian(i, i), 1e-12);
      Eigen::Matrix<double, 5, 1> step = hessian.ldlt().solve(-gradient);
      if (!step.allFinite()) break;
      bool accepted = false;
      for (int attempt = 0; attempt < 5 && !accepted; ++attempt, step *= 0.5) {
        Params trial = p;
        trial.normal = (p.normal + step[0] * t1 + step[1] * t2).normalized();
        const double trial_width =
            std::clamp(width * std::exp(std::clamp(step[4], -1.0, 1.0)), kSheenMinWidth, kSheenMaxWidth);
        const double trial_cost = project(&trial, trial_width);
        if (trial_cost <= cost && trial.normal.allFinite()) {
          accepted = true;
          const double moved = (trial.normal - p.normal).norm();
          p = trial, cost = trial_cost, width = trial_width;
          if (moved < kSheenNormalStep) iteration = kSheenIterations;  // converged
        }
      }
      if (!accepted) break;
    }
  };
  // Width: start from the one of the ladder whose linear fit at the start
  // normal leaves the least residual (the fit moves it on).
  double width = kSheenWidths[0];
  Params p;
  double cost = std::numeric_limits<double>::infinity();
  for (double a : kSheenWidths) {
    Params trial;
    trial.normal = start.normal;
    const double trial_cost = project(&trial, a);
    if (trial_cost < cost) cost = trial_cost, p = trial, width = a;
  }
  if (!std::isfinite(cost) || !(p.rho_s > 0)) return start;
  refine(p, width, cost);

  if (!(p.rho_s > 0) || !(p.rho_d >= limits.min_albedo) || !(p.normal.z() > 0) || !p.normal.allFinite()) return start;

  // Model selection: the Lambertian least squares on the same samples (those
  // lit at the sheen's normal) against the sheen, by BIC (amplitude and width).
  thread_local std::vector<double> weights;
  weights.assign(m, 0.0);
  int count = 0;
  for (int k = 0; k < m; ++k) {
    weights[k] = usable[k] > 0 && p.normal.dot(light(k)) > 0 ? 1.0 : 0.0;
    count += weights[k] > 0;
  }
  if (count < kSheenMinSamples) return start;
  Matrix34d lambert_scaled;
  double condition = 0;
  int used = 0;
  if (!SolveWeighted(samples, weights, 1, limits, &lambert_scaled, &condition, &used)) return start;
  double lambert_rss = 0, sheen_rss = 0;
  for (int k = 0; k < m; ++k) {
    if (!(weights[k] > 0)) continue;
    const Eigen::Vector3d lk = light(k);
    const double r0 = lk.dot(lambert_scaled.col(0)) - v[4 * k];
    const double r1 = p.rho_d * p.normal.dot(lk) + p.rho_s * EvaluateSheen(p.normal, lk, halves[k], view, width, false).s -
                      v[4 * k];
    lambert_rss += r0 * r0, sheen_rss += r1 * r1;
  }
  const double floor_rss = count * std::pow(kSheenResidualFloor * p.rho_d, 2);
  const bool sheen_pays =
      count * std::log(std::max(lambert_rss, floor_rss) / std::max(sheen_rss, floor_rss)) > 2 * std::log(double(count));
  if (!sheen_pays) return start;

  PixelFit fit = start;
  fit.normal = p.normal;
  fit.luminance_albedo = p.rho_d;
  fit.sheen_f0 = p.rho_s;
  fit.sheen_width = width;
  fit.lights_used = count;
  fit.condition_number = ClampForStorage(condition);
  fit.residual = std::sqrt(sheen_rss / count) / p.rho_d;
  if (with_albedo) {
    // Per channel: rho_d,c and that channel's sheen amplitude, n and the shape fixed.
    double aa = 0, ac = 0, cc = 0, ab[3] = {0, 0, 0}, cb[3] = {0, 0, 0};
    for (int k = 0; k < m; ++k) {
      if (!(weights[k] > 0)) continue;
      const Eigen::Vector3d lk = light(k);
      const double nl = p.normal.dot(lk);
      const double s = EvaluateSheen(p.normal, lk, halves[k], view, width, false).s;
      aa += nl * nl, ac += nl * s, cc += s * s;
      for (int c = 0; c < 3; ++c) ab[c] += nl * v[4 * k + 1 + c], cb[c] += s * v[4 * k + 1 + c];
    }
    for (int c = 0; c < 3; ++c) {
      double diffuse = 0, sheen = 0;
      fit.albedo[c] = SolveAmplitudes(aa, ac, cc, ab[c], cb[c], &diffuse, &sheen) ? std::max(0.0, diffuse) : 0.0;
    }
  }
  return fit;
}

}  // namespace scanbench
