// The per-pixel samples, the light matrix's condition number and the
// least-squares fits (solver/pixel_solvers.h). The robust fits are in
// robust_fits.cc, the diffuse + lobe and the diffuse + sheen fits in
// diffuse_lobe_fit.cc and diffuse_sheen_fit.cc; what they share in
// pixel_fit_internal.h.
#include "solver/pixel_solvers.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "solver/pixel_fit_internal.h"

namespace scanbench {

using pixel_fit::ClampForStorage;
using pixel_fit::FinishFit;
using pixel_fit::Matrix34d;

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

}  // namespace scanbench
