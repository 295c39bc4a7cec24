#include "solver/pixel_kernels.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace scanbench::tiled {
namespace {

using Method = PhotometricSolverOptions::Method;

// What every kernel takes from the options.
struct KernelSettings {
  explicit KernelSettings(const SolveJob& job)
      : options(*job.options),
        limits{options.min_lights, options.max_condition_number, options.min_albedo},
        with_albedo(job.with_albedo && !job.bayer),
        with_confidence(job.with_confidence),
        num_lights(job.num_lights),
        field(job.field),
        kernels(&KernelsOf(job)) {
    robust.loss = options.robust_loss;
    robust.width = options.robust_loss_width;
    robust.min_scale = options.robust_min_scale;
    robust.max_iterations = options.robust_max_iterations;
    robust.dark_fraction = options.robust_dark_fraction;
  }

  const PhotometricSolverOptions& options;
  PixelFitLimits limits;
  RobustFitOptions robust;
  bool with_albedo;  // RGB albedo solves
  bool with_confidence;
  int num_lights;
  const LightField* field;  // for the view direction of the lobe fits
  const SpanKernels* kernels;

  // Unit direction from pixel (x, y) towards the camera.
  Eigen::Vector3d View(int x, int y) const {
    float view[3];
    field->ViewDirection(x, y, view);
    return Eigen::Vector3d(view[0], view[1], view[2]);
  }
};

// ---------------------------------------------------------------------------
// jacobi_svd, qr, robust_irls, sparse_bayesian, diffuse_lobe: each pixel's
// used samples are gathered and handed to `fit` (a
// PixelFit(const PixelSamples&, int x, int y)).
template <typename Fit>
class PerPixelKernel final : public PixelKernel {
 public:
  PerPixelKernel(const KernelSettings& settings, Fit fit, bool robust)
      : with_albedo_(settings.with_albedo), robust_(robust), fit_(std::move(fit)), samples_(settings.num_lights) {}

  void SolveSpan(const Span& span, PixelWriter* out) override {
    for (int i = 0; i < span.count; ++i) {
      if (!span.Wanted(i)) continue;
      PixelFit fit;
      if (span.buffers->light_bad[i]) {
        fit.status = PixelStatus::kInvalidInput;
      } else {
        GatherSamples(span, i, with_albedo_, &samples_);
        fit = fit_(samples_, span.x0 + i, span.y);
      }
      out->Store(fit, span.x0 + i, span.y, robust_ ? SolvePath::kRobust : span.LightPath());
    }
  }

 private:
  const bool with_albedo_;
  const bool robust_;  // robust fits report SolvePath::kRobust
  Fit fit_;
  PixelSamples samples_;
};

template <typename Fit>
std::unique_ptr<PixelKernel> MakePerPixelKernel(const KernelSettings& settings, Fit fit, bool robust) {
  return std::make_unique<PerPixelKernel<Fit>>(settings, std::move(fit), robust);
}

// ---------------------------------------------------------------------------
// The closed-form solve of the accumulated normal equations for a whole span,
// and its residuals: shared by normal_equations, uniform_pinv and adaptive.
class NormalEquationsSolve {
 public:
  NormalEquationsSolve(const KernelSettings& settings, int capacity) : settings_(settings), n_(capacity) {
    scaled_.assign(static_cast<size_t>(3) * n_, 0.0);
    residual2_.assign(n_, 0.0);
  }

  // fits()[i] for every pixel of the span: status, normal, albedo, condition number.
  void Solve(const Span& span);
  // RMS luminance residual of every solved fit, from a second pass over the samples.
  void AddResiduals(const Span& span);
  std::vector<PixelFit>& fits() { return fits_; }

 private:
  void SolvePixel(const Span& span, int i, PixelFit* fit);
  // The condition number of a Gram matrix (or the interpolated one) and,
  // where within max_condition_number, its inverse.
  void InvertGram(double g00, double g01, double g02, double g11, double g12, double g22,
                  double interpolated_condition, bool interpolated, double* condition,
                  Eigen::Matrix3d* inverse) const;

  // Uniform tiles: the inverse per subset of used lights (SolvePixel).
  struct SubsetInverse {
    uint64_t generation = ~uint64_t(0), mask = 0;
    double condition = 0;
    Eigen::Matrix3d inverse = Eigen::Matrix3d::Identity();
  };
  static constexpr int kSubsetBits = 6;

  const KernelSettings settings_;
  std::vector<SubsetInverse> subsets_ = std::vector<SubsetInverse>(size_t(1) << kSubsetBits);
  const int n_;
  std::vector<PixelFit> fits_;
  std::vector<double> scaled_;     // luminance scaled normal, [c * n + i]; 0 unless solved
  std::vector<double> residual2_;  // sum of squared residuals
};

void NormalEquationsSolve::Solve(const Span& span) {
  fits_.assign(span.count, PixelFit());
  for (int i = 0; i < span.count; ++i) {
    scaled_[i] = scaled_[n_ + i] = scaled_[2 * n_ + i] = 0;
    if (!span.Wanted(i)) continue;
    if (span.buffers->light_bad[i]) {
      fits_[i].status = PixelStatus::kInvalidInput;
      continue;
    }
    SolvePixel(span, i, &fits_[i]);
  }
}

void NormalEquationsSolve::InvertGram(double g00, double g01, double g02, double g11, double g12, double g22,
                                      double interpolated_condition, bool interpolated, double* condition,
                                      Eigen::Matrix3d* inverse) const {
  *condition = interpolated ? interpolated_condition : ConditionNumberFromGram(g00, g01, g02, g11, g12, g22);
  if (*condition <= settings_.options.max_condition_number) {
    // Closed-form inverse through the cofactors.
    const double c00 = g11 * g22 - g12 * g12, c01 = g02 * g12 - g01 * g22, c02 = g01 * g12 - g02 * g11;
    const double c11 = g00 * g22 - g02 * g02, c12 = g01 * g02 - g00 * g12, c22 = g00 * g11 - g01 * g01;
    const double det = g00 * c00 + g01 * c01 + g02 * c02;
    const double inv_det = 1.0 / det;
    *inverse << c00, c01, c02, c01, c11, c12, c02, c12, c22;
    *inverse *= inv_det;
  }
}

void NormalEquationsSolve::SolvePixel(const Span& span, int i, PixelFit* fit) {
  const PhotometricSolverOptions& options = settings_.options;
  const int n = n_;
  const double* acc = span.buffers->acc.data();
  const int used = static_cast<int>(acc[kCount * n + i]);
  fit->lights_used = used;
  if (used < std::max(3, options.min_lights)) {
    fit->status = PixelStatus::kTooFewLights;
    return;
  }
  const double g00 = acc[kG00 * n + i], g01 = acc[kG01 * n + i], g02 = acc[kG02 * n + i];
  const double g11 = acc[kG11 * n + i], g12 = acc[kG12 * n + i], g22 = acc[kG22 * n + i];
  Eigen::Matrix3d inverse;
  if (span.lights == TileLights::kUniform && used == span.shared->usable) {
    fit->condition_number = span.shared->condition;
    inverse = span.shared->inverse;
  } else if (span.lights == TileLights::kUniform && settings_.num_lights <= 64) {
    // A uniform tile's Gram matrix depends only on which lights a pixel
    // uses (unit weights, the same directions, summed in the same order):
    // pixels with the same shadowed lights share its condition number and
    // inverse, computed once.
    uint64_t mask = 0;
    for (int k = 0; k < settings_.num_lights; ++k) {
      mask |= uint64_t(span.buffers->ok[static_cast<size_t>(k) * n + i] > 0) << k;
    }
    SubsetInverse& entry = subsets_[(mask * 0x9E3779B97F4A7C15ull) >> (64 - kSubsetBits)];
    if (entry.generation != span.shared->generation || entry.mask != mask) {
      entry.generation = span.shared->generation;
      entry.mask = mask;
      InvertGram(g00, g01, g02, g11, g12, g22, span.buffers->all_lights_condition[i], false, &entry.condition,
                 &entry.inverse);
    }
    fit->condition_number = entry.condition;
    inverse = entry.inverse;
  } else {
    // Interpolated tiles have every light usable: a pixel using them all
    // has the interpolated condition number of the nodes.
    const bool interpolated = span.lights == TileLights::kInterpolated && used == settings_.num_lights;
    InvertGram(g00, g01, g02, g11, g12, g22, span.buffers->all_lights_condition[i], interpolated,
               &fit->condition_number, &inverse);
  }
  if (!(fit->condition_number <= options.max_condition_number)) {
    fit->status = PixelStatus::kIllConditioned;
    fit->condition_number = std::min(fit->condition_number, double(std::numeric_limits<float>::max()));
    return;
  }
  const Eigen::Vector3d scaled = inverse * Eigen::Vector3d(acc[kB0 * n + i], acc[kB1 * n + i], acc[kB2 * n + i]);
  const double length = scaled.norm();
  if (!std::isfinite(length) || !(length >= options.min_albedo) || length == 0) {
    fit->status = PixelStatus::kNoSignal;
    return;
  }
  if (!(scaled.z() > 0)) {
    fit->status = PixelStatus::kFacingAway;
    return;
  }
  fit->status = PixelStatus::kSolved;
  fit->normal = scaled / length;
  fit->luminance_albedo = length;
  for (int c = 0; c < 3; ++c) scaled_[c * n + i] = scaled[c];
  if (settings_.with_albedo) {
    for (int c = 0; c < 3; ++c) {
      const int row = kR0 + 3 * c;
      const Eigen::Vector3d channel =
          inverse * Eigen::Vector3d(acc[row * n + i], acc[(row + 1) * n + i], acc[(row + 2) * n + i]);
      fit->albedo[c] = channel.norm();
    }
  }
}

// Exact, no cancellation: the samples are read again rather than expanding
// the squared residual in the accumulated sums.
void NormalEquationsSolve::AddResiduals(const Span& span) {
  const SpanBuffers& b = *span.buffers;
  const int count = span.count;
  ResidualArgs a;
  a.count = count;
  a.num_lights = settings_.num_lights;
  a.capacity = n_;
  a.uniform = span.lights == TileLights::kUniform;
  a.shared_dir = span.shared->dir.data();
  a.dir = b.dir.data();
  a.lum = b.lum.data();
  a.ok = b.ok.data();
  a.scaled = scaled_.data();
  a.residual2 = residual2_.data();
  settings_.kernels->residuals(a);
  for (int i = 0; i < count; ++i) {
    PixelFit& fit = fits_[i];
    if (fit.status != PixelStatus::kSolved) continue;
    fit.residual = std::sqrt(residual2_[i] / std::max(1, fit.lights_used)) / fit.luminance_albedo;
  }
}

// normal_equations and uniform_pinv.
class NormalEquationsKernel final : public PixelKernel {
 public:
  NormalEquationsKernel(const KernelSettings& settings, int capacity) : settings_(settings), solve_(settings, capacity) {}

  void SolveSpan(const Span& span, PixelWriter* out) override {
    solve_.Solve(span);
    if (settings_.with_confidence) solve_.AddResiduals(span);
    for (int i = 0; i < span.count; ++i) {
      if (span.Wanted(i)) out->Store(solve_.fits()[i], span.x0 + i, span.y, span.LightPath());
    }
  }

 private:
  const KernelSettings settings_;
  NormalEquationsSolve solve_;
};

// adaptive: the normal-equations solve everywhere, then IRLS (or, with
// adaptive_lobe, the diffuse-lobe fit) where the
// least-squares residual (relative to the albedo) is above
// adaptive_robust_residual or a sample was clipped; the robust fit is kept
// when it solves the pixel or the least-squares one did not.
// With adaptive_sheen, the solved pixels left to least squares whose residual
// has a velvet sheen's pattern get the diffuse + sheen fit (kept where BIC
// prefers it; reported as the robust path).
class AdaptiveKernel final : public PixelKernel {
 public:
  AdaptiveKernel(const KernelSettings& settings, int capacity)
      : settings_(settings), solve_(settings, capacity), samples_(settings.num_lights) {}

  void SolveSpan(const Span& span, PixelWriter* out) override {
    solve_.Solve(span);
    solve_.AddResiduals(span);
    for (int i = 0; i < span.count; ++i) {
      if (!span.Wanted(i)) continue;
      const int x = span.x0 + i;
      const PixelFit& fit = solve_.fits()[i];
      if (WantsRobust(span, i, fit)) {
        GatherSamples(span, i, settings_.with_albedo, &samples_);
        const PixelFit refit =
            settings_.options.adaptive_lobe
                ? FitDiffuseLobe(samples_, settings_.View(x, span.y), settings_.with_albedo, settings_.limits,
                                 settings_.robust)
                : FitRobustIrls(samples_, settings_.with_albedo, settings_.limits, settings_.robust);
        if (refit.status == PixelStatus::kSolved || fit.status != PixelStatus::kSolved) {
          out->Store(refit, x, span.y, SolvePath::kRobust);
          continue;
        }
      }
      if (settings_.options.adaptive_sheen && fit.status == PixelStatus::kSolved) {
        // The smooth, low-residual bias of a velvet sheen stays under the
        // residual trigger: a cheap test of the residual's pattern picks the
        // pixels worth the sheen fit.
        GatherSamples(span, i, settings_.with_albedo, &samples_);
        const Eigen::Vector3d view = settings_.View(x, span.y);
        if (SheenPatternInResidual(samples_, view, fit)) {
          const PixelFit refit = FitDiffuseSheen(samples_, view, settings_.with_albedo, settings_.limits, fit);
          if (refit.sheen_f0 > 0) {
            out->Store(refit, x, span.y, SolvePath::kRobust);
            continue;
          }
        }
      }
      out->Store(fit, x, span.y, span.LightPath());
    }
  }

 private:
  bool WantsRobust(const Span& span, int i, const PixelFit& fit) const {
    if (span.buffers->light_bad[i]) return false;
    return span.buffers->clipped[i] > 0 ||
           (fit.status == PixelStatus::kSolved && fit.residual > settings_.options.adaptive_robust_residual);
  }

  const KernelSettings settings_;
  NormalEquationsSolve solve_;
  PixelSamples samples_;
};

}  // namespace

LightSharing LightSharingOf(Method method) {
  switch (method) {
    case Method::kAdaptive: return LightSharing::kWithinTolerance;
    case Method::kUniformPseudoInverse: return LightSharing::kAlways;
    default: return LightSharing::kNever;
  }
}

std::unique_ptr<PixelKernel> MakePixelKernel(const SolveJob& job, int capacity) {
  const KernelSettings s(job);
  switch (job.options->method) {
    case Method::kAdaptive: return std::make_unique<AdaptiveKernel>(s, capacity);
    case Method::kNormalEquations:
    case Method::kUniformPseudoInverse: return std::make_unique<NormalEquationsKernel>(s, capacity);
    case Method::kJacobiSvd:
      return MakePerPixelKernel(
          s, [limits = s.limits, albedo = s.with_albedo](const PixelSamples& samples, int, int) {
            return FitLeastSquares(DenseMethod::kJacobiSvd, samples, albedo, limits);
          },
          false);
    case Method::kQr:
      return MakePerPixelKernel(
          s, [limits = s.limits, albedo = s.with_albedo](const PixelSamples& samples, int, int) {
            return FitLeastSquares(DenseMethod::kQr, samples, albedo, limits);
          },
          false);
    case Method::kRobustIrls:
      return MakePerPixelKernel(
          s, [limits = s.limits, albedo = s.with_albedo, robust = s.robust](const PixelSamples& samples, int, int) {
            return FitRobustIrls(samples, albedo, limits, robust);
          },
          true);
    case Method::kSparseBayesian:
      return MakePerPixelKernel(
          s, [limits = s.limits, albedo = s.with_albedo, robust = s.robust](const PixelSamples& samples, int, int) {
            return FitSparseBayesian(samples, albedo, limits, robust);
          },
          true);
    case Method::kDiffuseLobe:
      return MakePerPixelKernel(
          s, [s](const PixelSamples& samples, int x, int y) {
            return FitDiffuseLobe(samples, s.View(x, y), s.with_albedo, s.limits, s.robust);
          },
          true);
  }
  return nullptr;
}

}  // namespace scanbench::tiled
