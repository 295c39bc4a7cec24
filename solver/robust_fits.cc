// The robust per-pixel fits (solver/pixel_solvers.h): iteratively
// reweighted least squares and sparse Bayesian learning, both from the
// least-squares start.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "solver/pixel_fit_internal.h"
#include "solver/pixel_solvers.h"

namespace scanbench {
namespace {

using namespace pixel_fit;

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
