// Dense solves of one pixel's samples: the building blocks the photometric
// solver runs per pixel (least squares three ways, and two robust fits).
// Public so that they can be tested and benchmarked on their own.
#pragma once

#include <cmath>

#include <vector>

#include <Eigen/Core>

#include "solver/photometric_solver.h"

namespace scanbench {

// One pixel's usable samples, light intensity already divided out.
class PixelSamples {
 public:
  explicit PixelSamples(int capacity = 0) { Reserve(capacity); }
  void Reserve(int capacity);
  void Clear() { count_ = 0; }
  // dir: unit light direction; values: luminance, R, G, B (intensity divided).
  void Add(double dir_x, double dir_y, double dir_z, double luminance, double red, double green, double blue);

  int count() const { return count_; }
  auto lights() const { return lights_.topRows(count_); }   // count x 3
  auto values() const { return values_.topRows(count_); }   // count x 4: luminance, R, G, B
  const double* light_data() const { return lights_.data(); }  // row-major, 3 per sample
  const double* value_data() const { return values_.data(); }  // row-major, 4 per sample

 private:
  int count_ = 0;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> lights_;
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> values_;
};

// What makes a pixel solvable (the fields of PhotometricSolverOptions).
struct PixelFitLimits {
  int min_lights = 3;                 // [3, 1000]
  double max_condition_number = 100;  // > 1
  double min_albedo = 1e-4;           // >= 0, albedo units
};

struct PixelFit {
  PixelStatus status = PixelStatus::kSolved;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit; (0, 0, 1) unless solved
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();   // RGB; 0 unless solved (and asked for)
  double luminance_albedo = 0;                        // length of the luminance scaled normal
  int lights_used = 0;                                // samples in the fit (robust: weight > 0.01)
  double condition_number = 0;                        // of the (weighted) light matrix
  double residual = 0;                                // (weighted) RMS luminance residual / albedo
  // Specular lobe (FitDiffuseLobe only; the other fits leave kUnsupported when
  // solved): white F0 in [0, 1] and GGX alpha in (0, 1], both 0 unless kEstimated.
  SpecularStatus specular_status = SpecularStatus::kUnsupported;
  double specular_f0 = 0;
  double roughness_alpha = 0;
  // Velvet sheen (FitDiffuseSheen; 0 elsewhere and where BIC keeps the
  // Lambertian fit): white F0 >= 0 and the velvet width a.
  double sheen_f0 = 0;
  double sheen_width = 0;
};

enum class DenseMethod {
  kJacobiSvd,        // Eigen::JacobiSVD, thin U and V
  kQr,               // Eigen::HouseholderQR
  kNormalEquations,  // L^T L x = L^T b, closed-form 3x3 inverse
};

// Condition number (ratio of the singular values) of a light matrix L from
// its Gram matrix G = L^T L: sqrt(largest / smallest eigenvalue); infinity
// when G is singular, never NaN.
double ConditionNumberFromGram(const Eigen::Matrix3d& gram);
// The same from the six distinct entries of the symmetric Gram matrix.
double ConditionNumberFromGram(double g00, double g01, double g02, double g11, double g12, double g22);

// Least squares on all samples; with_albedo solves R, G, B too.
PixelFit FitLeastSquares(DenseMethod method, const PixelSamples& samples, bool with_albedo,
                         const PixelFitLimits& limits);

struct RobustFitOptions {
  PhotometricSolverOptions::RobustLoss loss = PhotometricSolverOptions::RobustLoss::kTukey;
  double width = 0;            // in residual scales; 0 = the loss's standard width
  double min_scale = 0.01;     // residual scale floor relative to the albedo, > 0
  int max_iterations = 50;     // >= 1
  double dark_fraction = 0.0;  // samples below this fraction of the brightest are left out, [0, 1)
};

// Iteratively reweighted least squares from the least-squares start; samples
// with l . n <= 0 at the current estimate (attached shadow) get weight 0.
PixelFit FitRobustIrls(const PixelSamples& samples, bool with_albedo, const PixelFitLimits& limits,
                       const RobustFitOptions& options);

// Sparse Bayesian learning: each sample's non-Lambertian error e_k has its own
// variance gamma_k, learned by expectation-maximisation with the scaled normal
// marginalised (closed form through the 3x3 weighted Gram matrix, so O(lights)
// per iteration); dense noise of standard deviation min_scale x albedo.
// Outliers end with large gamma_k and so near-zero weight.
PixelFit FitSparseBayesian(const PixelSamples& samples, bool with_albedo, const PixelFitLimits& limits,
                           const RobustFitOptions& options);

// Diffuse plus one isotropic specular lobe, per pixel: the luminance is
//   b_k = rho_d (n . l_k) + rho_s alpha^2 / (4 (n . v) ((n . h_k)^2 (alpha^2 - 1) + 1)^2),
// i.e. (n . l) (rho_d + rho_s pi D_GGX(n . h; alpha) / (4 (n . l)(n . v))) with
// h_k = normalize(l_k + v), no shadowing-masking term and a constant Fresnel
// factor (rho_s = F0). Fitted by Levenberg-Marquardt with analytic derivatives
// (normal as two tangent angles, rho_d, rho_s >= 0, log alpha; the two
// amplitudes re-solved linearly at every trial step) from the robust
// Lambertian fit (FitRobustIrls) and the best of a few alpha starts, with a
// Tukey weight on every residual; samples with n . l <= 0 are out. The lobe is
// kept only when BIC prefers it to the Lambertian fit on the same weighted
// samples (residual floored at the noise level min_scale x albedo), else the
// robust Lambertian fit is returned with kUnsupported. `view`: unit, surface
// towards the camera. Colour albedo: rho_d per channel, solved linearly with
// n and the lobe shape fixed.
PixelFit FitDiffuseLobe(const PixelSamples& samples, const Eigen::Vector3d& view, bool with_albedo,
                        const PixelFitLimits& limits, const RobustFitOptions& options);

// The velvet sheen's shape term (so that the sheen reading is F0 times it):
// the seed's cloth sheen, Ashikhmin and Premoze's inverted-Gaussian velvet
// distribution D(h) = (1 + 4 exp(-cot^2 th_h / a^2) / sin^4 th_h) / (pi (1 + 4 a^2))
// with the smooth denominator 4 (n.l + n.v - (n.l)(n.v)) and no shadowing:
//   S = pi D (n . l) / (4 (n.l + n.v - (n.l)(n.v))).
// h = normalize(l + v); n . v floored at 0.1 as FitDiffuseLobe's; 0 when
// n . l <= 0. Never NaN for unit inputs and width > 0.
double VelvetSheenShape(const Eigen::Vector3d& n, const Eigen::Vector3d& light, const Eigen::Vector3d& half,
                        const Eigen::Vector3d& view, double width);

// VelvetSheenShape split into its width-free factors for one sample, so that
// a fit over the width (RefineCoherentSheen, solver/coherent_sheen.h) computes
// the geometry once: S = VelvetSheenOf(VelvetSheenGeometryOf(n, l, h, v), a).
// The velvet sheen's constants: Ashikhmin's amplitude K of the inverted
// Gaussian in G = 1 + K exp(-cot^2 th_h / a^2) / sin^4 th_h, and the floor of
// n . v (near-grazing views only rescale the sheen).
inline constexpr double kVelvetSheenAmplitude = 4.0;
inline constexpr double kVelvetSheenMinViewCosine = 0.1;
struct VelvetSheenGeometry {
  double cot2 = 0;      // cot^2 th_h
  double inv_sin4 = 0;  // 1 / sin^4 th_h; 0 where th_h ~ 0 (the exponential has vanished there)
  double q = 0;         // (n . l) / (4 (n.l + n.v - (n.l)(n.v))); 0 when n . l <= 0
};
VelvetSheenGeometry VelvetSheenGeometryOf(const Eigen::Vector3d& n, const Eigen::Vector3d& light,
                                          const Eigen::Vector3d& half, const Eigen::Vector3d& view);
// S for the factors and width a > 0 (inline: the shared sheen's width search
// evaluates it for every sample at every trial width).
inline double VelvetSheenOf(const VelvetSheenGeometry& geometry, double width) {
  if (!(geometry.q > 0)) return 0;
  const double a2 = width * width;
  const double g = 1 + kVelvetSheenAmplitude * std::exp(-geometry.cot2 / a2) * geometry.inv_sin4;
  return g * geometry.q / (1 + kVelvetSheenAmplitude * a2);
}

// Diffuse plus a white velvet sheen, per pixel:
//   b_k = rho_d (n . l_k) + rho_s S(n, l_k, v; a)       (S: VelvetSheenShape)
// i.e. the seed's cloth BRDF with a constant Fresnel factor (rho_s = F0).
// The width a is taken from a small fixed set (the one whose linear fit at
// the start normal leaves the least residual), then n, rho_d and rho_s >= 0
// by Gauss-Newton with analytic derivatives from `start` (a solved Lambertian
// fit of the same samples, e.g. least squares); samples with n . l <= 0 are
// out. The sheen is kept only when BIC prefers it to the Lambertian fit of the
// same samples (two more parameters, amplitude and width; residuals floored
// at 1e-3 x rho_d, the quantisation level), else `start` is returned. A
// velvet sheen is smooth and weak (a few per cent of the diffuse reading at
// the rig's angles), so unlike FitDiffuseLobe no sample is down-weighted.
// Colour albedo: rho_d per channel with n and the sheen shape fixed.
// The cheap test that decides whether FitDiffuseSheen is worth running: does
// the least-squares fit's residual (solved `least_squares` of the same
// samples, all of them used) carry the velvet sheen's pattern? The residual's
// projection on the sheen shape (width 1, at the least-squares normal), taken
// outside the Lambertian model's span, must be positive light and pay one
// parameter's BIC penalty (residuals floored as FitDiffuseSheen's). O(samples).
bool SheenPatternInResidual(const PixelSamples& samples, const Eigen::Vector3d& view, const PixelFit& least_squares);

PixelFit FitDiffuseSheen(const PixelSamples& samples, const Eigen::Vector3d& view, bool with_albedo,
                         const PixelFitLimits& limits, const PixelFit& start);

}  // namespace scanbench
