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

}  // namespace scanbench
