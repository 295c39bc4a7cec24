#include "solver/pixel_kernels.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Dense>

#include "solver/kernel_settings.h"
#include "solver/learned_kernel.h"
#include "solver/photometric_methods.h"

namespace scanbench::tiled {
namespace {

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
// Per pixel here: whether it can be solved (lights used, condition number)
// and, in uniform tiles, which inverse it takes; the solves themselves run
// over the span in the per-ISA kernel (SpanKernels::solve).
class NormalEquationsSolve {
 public:
  NormalEquationsSolve(const KernelSettings& settings, int capacity)
      : settings_(settings), n_(capacity), fits_(capacity) {
    scaled_.assign(static_cast<size_t>(3) * n_, 0.0);
    residual2_.assign(n_, 0.0);
    inverse_.assign(static_cast<size_t>(6) * n_, 0.0);
    masks_.assign(n_, 0);
    ready_.assign(n_, 0.0);
    outcome_.assign(n_, 0.0);
    condition_.assign(n_, 0.0);
    condition_fallback_.assign(n_, 1.0);
    gathered_.assign(static_cast<size_t>(kG22 + 1) * n_, 0.0);
    gathered_condition_.assign(n_, 0.0);
    gathered_fallback_.assign(n_, 1.0);
    gathered_index_.assign(n_, 0);
  }

  // fits() for every pixel of the span: status, normal, albedo, condition number.
  void Solve(const Span& span);
  // RMS luminance residual of every solved fit (0 elsewhere), from a second pass over the samples.
  void AddResiduals(const Span& span);
  const SpanFits& fits() const { return fits_; }

 private:
  // Interpolated tiles: condition_ and condition_fallback_ of the pixels not
  // using every light (the others have the nodes' condition number).
  void InterpolatedConditions(const Span& span);
  // Status, lights used and condition number of pixel i where it cannot be
  // solved; else marks it ready (and, in uniform tiles, gives its inverse).
  void PreparePixel(const Span& span, int i);
  // The condition number of a Gram matrix (or the interpolated one) and,
  // where within max_condition_number, its inverse (6 entries, SolveArgs' order).
  // `known_condition` where it is known (interpolated or from the kernel),
  // else negative.
  void InvertGram(double g00, double g01, double g02, double g11, double g12, double g22, double known_condition,
                  double* condition, double inverse[6]) const;
  void SetInverse(int i, const double inverse[6]) {
    for (int e = 0; e < 6; ++e) inverse_[e * n_ + i] = inverse[e];
  }

  // Uniform tiles: the inverse per subset of used lights (PreparePixel).
  struct SubsetInverse {
    uint64_t generation = ~uint64_t(0), mask = 0;
    double condition = 0;
    double inverse[6] = {1, 0, 0, 1, 0, 1};
  };
  static constexpr int kSubsetBits = 6;

  const KernelSettings settings_;
  std::vector<SubsetInverse> subsets_ = std::vector<SubsetInverse>(size_t(1) << kSubsetBits);
  const int n_;
  SpanFits fits_;
  std::vector<double> scaled_;     // luminance scaled normal, [c * n + i]; 0 unless solved
  std::vector<double> residual2_;  // sum of squared residuals
  std::vector<double> inverse_;    // uniform tiles: a pixel's own inverse Gram matrix, [e * n + i] (ready 2)
  std::vector<uint64_t> masks_;    // uniform tiles: the lights each pixel uses (bit k: light k)
  std::vector<double> ready_;      // 1 where the kernel solves the pixel (2: with its own inverse)
  std::vector<double> outcome_;    // the kernel's status code where ready
  // Exact tiles: each pixel's condition number from the kernel, unless
  // condition_fallback_ (then ConditionNumberFromGram's).
  std::vector<double> condition_, condition_fallback_;
  // InterpolatedConditions' gathered pixels: Gram rows as in acc, their indices, the kernel's results.
  std::vector<double> gathered_, gathered_condition_, gathered_fallback_;
  std::vector<int> gathered_index_;
};

// Interpolated tiles know the condition number of every pixel that uses all
// the lights; the others (shadowed samples) take the kernel's: their Gram
// matrices gathered, the kernel run over them alone, its results put back.
void NormalEquationsSolve::InterpolatedConditions(const Span& span) {
  const double* acc = span.buffers->acc.data();
  const double* used = acc + kCount * n_;
  int m = 0;
  for (int i = 0; i < span.count; ++i) {
    if (static_cast<int>(used[i]) == settings_.num_lights) continue;
    for (int e = kG00; e <= kG22; ++e) gathered_[e * n_ + m] = acc[e * n_ + i];
    gathered_index_[m++] = i;
  }
  if (m == 0) return;
  ConditionArgs c;
  c.count = m;
  c.capacity = n_;
  c.acc = gathered_.data();
  c.condition = gathered_condition_.data();
  c.fallback = gathered_fallback_.data();
  settings_.kernels->conditions(c);
  for (int j = 0; j < m; ++j) {
    condition_[gathered_index_[j]] = gathered_condition_[j];
    condition_fallback_[gathered_index_[j]] = gathered_fallback_[j];
  }
}

void NormalEquationsSolve::Solve(const Span& span) {
  const bool uniform = span.lights == TileLights::kUniform;
  const double* used = span.buffers->acc.data() + kCount * n_;
  if (span.lights == TileLights::kExact) {
    ConditionArgs c;
    c.count = span.count;
    c.capacity = n_;
    c.acc = span.buffers->acc.data();
    c.condition = condition_.data();
    c.fallback = condition_fallback_.data();
    settings_.kernels->conditions(c);
  } else if (span.lights == TileLights::kInterpolated) {
    InterpolatedConditions(span);
  }
  // Uniform tiles: every pixel using all the tile's usable lights takes the
  // shared inverse; the others are given theirs in the planes (ready 2).
  const Eigen::Matrix3d& m = span.shared->inverse;
  const double shared_inverse[6] = {m(0, 0), m(0, 1), m(0, 2), m(1, 1), m(1, 2), m(2, 2)};
  const int count = span.count;
  const PhotometricSolverOptions& options = settings_.options;
  const int min_used = std::max(3, options.min_lights);
  // The common cases first, in one pass without branches over a span with
  // no region: a pixel of a uniform tile using all its usable lights (the
  // shared matrix, checked once here), a pixel of an interpolated tile using
  // every light within the condition limit (the nodes' condition number).
  // Every other pixel goes through the per-pixel rules below.
  const int shared_usable = uniform && span.shared->condition <= options.max_condition_number &&
                                    span.shared->usable >= min_used
                                ? span.shared->usable
                                : -1;
  const bool interpolated = span.lights == TileLights::kInterpolated && settings_.num_lights >= min_used;
  const int fast_used = uniform ? shared_usable : interpolated ? settings_.num_lights : -1;
  int slow = 0;  // pixels left to the per-pixel rules
  {
    const double target = span.region == nullptr ? fast_used : -1.0;
    const double max_condition = options.max_condition_number;
    const uint8_t* __restrict bad = span.buffers->light_bad.data();
    const double* __restrict node_condition = span.buffers->all_lights_condition.data();
    const double shared_condition = uniform ? span.shared->condition : 0.0;
    double* __restrict ready = ready_.data();
    double* __restrict condition = fits_.condition_number.data();
    double* __restrict residual = fits_.residual.data();
    int* __restrict lights_used = fits_.lights_used.data();
    for (int i = 0; i < count; ++i) {
      const double c = uniform ? shared_condition : node_condition[i];
      const bool fast = (used[i] == target) & (bad[i] == 0) & (c <= max_condition);
      ready[i] = fast ? 1.0 : 0.0;
      condition[i] = fast ? c : 0.0;
      residual[i] = 0.0;
      lights_used[i] = fast ? fast_used : 0;
      slow += !fast;
    }
  }
  if (uniform && slow > 0 && settings_.num_lights <= 64) {
    // Which lights each pixel uses, for PreparePixel's inverses per subset:
    // one pass per light over the span.
    uint64_t* __restrict masks = masks_.data();
    std::fill_n(masks, count, uint64_t{0});
    for (int k = 0; k < settings_.num_lights; ++k) {
      const float* __restrict ok = span.buffers->ok.data() + static_cast<size_t>(k) * n_;
      for (int i = 0; i < count; ++i) masks[i] |= uint64_t(ok[i] > 0) << k;
    }
  }
  for (int i = 0; i < count; ++i) {
    if (ready_[i] != 0) continue;
    if (!span.Wanted(i)) {
      fits_.status[i] = static_cast<uint8_t>(PixelStatus::kOutsideRegion);
    } else if (span.buffers->light_bad[i]) {
      fits_.status[i] = static_cast<uint8_t>(PixelStatus::kInvalidInput);
    } else if (static_cast<int>(used[i]) == shared_usable) {
      fits_.lights_used[i] = shared_usable;
      fits_.condition_number[i] = span.shared->condition;
      ready_[i] = 1;
    } else {
      PreparePixel(span, i);
    }
  }
  SolveArgs a;
  a.count = span.count;
  a.capacity = n_;
  a.albedo = settings_.with_albedo;
  a.invert_gram = !uniform;
  a.min_albedo = settings_.options.min_albedo;
  a.solved = static_cast<int>(PixelStatus::kSolved);
  a.no_signal = static_cast<int>(PixelStatus::kNoSignal);
  a.facing_away = static_cast<int>(PixelStatus::kFacingAway);
  a.acc = span.buffers->acc.data();
  a.inverse = inverse_.data();
  a.shared_inverse = shared_inverse;
  a.ready = ready_.data();
  a.status = outcome_.data();
  a.scaled = scaled_.data();
  a.normal = fits_.normal.data();
  a.luminance_albedo = fits_.luminance_albedo.data();
  a.rgb_albedo = fits_.albedo.data();
  settings_.kernels->solve(a);
  for (int i = 0; i < span.count; ++i) {
    if (ready_[i] != 0) fits_.status[i] = static_cast<uint8_t>(outcome_[i]);
  }
}

void NormalEquationsSolve::InvertGram(double g00, double g01, double g02, double g11, double g12, double g22,
                                      double known_condition, double* condition, double inverse[6]) const {
  *condition = known_condition >= 0 ? known_condition : ConditionNumberFromGram(g00, g01, g02, g11, g12, g22);
  if (*condition <= settings_.options.max_condition_number) {
    // Closed-form inverse through the cofactors (as the solve kernel forms it).
    const double c00 = g11 * g22 - g12 * g12, c01 = g02 * g12 - g01 * g22, c02 = g01 * g12 - g02 * g11;
    const double c11 = g00 * g22 - g02 * g02, c12 = g01 * g02 - g00 * g12, c22 = g00 * g11 - g01 * g01;
    const double det = g00 * c00 + g01 * c01 + g02 * c02;
    const double inv_det = 1.0 / det;
    const double values[6] = {c00 * inv_det, c01 * inv_det, c02 * inv_det, c11 * inv_det, c12 * inv_det, c22 * inv_det};
    std::copy(values, values + 6, inverse);
  }
}

void NormalEquationsSolve::PreparePixel(const Span& span, int i) {
  const PhotometricSolverOptions& options = settings_.options;
  const int n = n_;
  const double* acc = span.buffers->acc.data();
  const int used = static_cast<int>(acc[kCount * n + i]);
  fits_.lights_used[i] = used;
  if (used < std::max(3, options.min_lights)) {
    fits_.status[i] = static_cast<uint8_t>(PixelStatus::kTooFewLights);
    return;
  }
  const double g00 = acc[kG00 * n + i], g01 = acc[kG01 * n + i], g02 = acc[kG02 * n + i];
  const double g11 = acc[kG11 * n + i], g12 = acc[kG12 * n + i], g22 = acc[kG22 * n + i];
  double condition = 0;
  bool own_inverse = false;  // SetInverse gave the pixel its own (ready 2)
  if (span.lights == TileLights::kUniform && used == span.shared->usable) {
    condition = span.shared->condition;  // the shared inverse (ready 1)
  } else if (span.lights == TileLights::kUniform && settings_.num_lights <= 64) {
    // A uniform tile's Gram matrix depends only on which lights a pixel
    // uses (unit weights, the same directions, summed in the same order):
    // pixels with the same shadowed lights share its condition number and
    // inverse, computed once.
    const uint64_t mask = masks_[i];  // Solve's
    SubsetInverse& entry = subsets_[(mask * 0x9E3779B97F4A7C15ull) >> (64 - kSubsetBits)];
    if (entry.generation != span.shared->generation || entry.mask != mask) {
      entry.generation = span.shared->generation;
      entry.mask = mask;
      InvertGram(g00, g01, g02, g11, g12, g22, -1.0, &entry.condition, entry.inverse);
    }
    condition = entry.condition;
    SetInverse(i, entry.inverse);
    own_inverse = true;
  } else {
    // Interpolated tiles have every light usable: a pixel using them all
    // has the interpolated condition number of the nodes; the other pixels
    // of interpolated and exact tiles have the kernel's (Solve) unless it
    // left them to the scalar function. The kernel inverts the Gram matrix
    // itself outside uniform tiles.
    const bool interpolated = span.lights == TileLights::kInterpolated && used == settings_.num_lights;
    const bool from_kernel = span.lights != TileLights::kUniform && condition_fallback_[i] == 0;
    const double known = interpolated ? span.buffers->all_lights_condition[i] : from_kernel ? condition_[i] : -1.0;
    if (span.lights == TileLights::kUniform) {
      double inverse[6] = {1, 0, 0, 1, 0, 1};
      InvertGram(g00, g01, g02, g11, g12, g22, known, &condition, inverse);
      SetInverse(i, inverse);
      own_inverse = true;
    } else {
      condition = known >= 0 ? known : ConditionNumberFromGram(g00, g01, g02, g11, g12, g22);
    }
  }
  if (!(condition <= options.max_condition_number)) {
    fits_.status[i] = static_cast<uint8_t>(PixelStatus::kIllConditioned);
    fits_.condition_number[i] = std::min(condition, double(std::numeric_limits<float>::max()));
    return;
  }
  fits_.condition_number[i] = condition;
  ready_[i] = own_inverse ? 2 : 1;
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
  // The albedo is 0 unless the pixel is solved.
  a.used = b.acc.data() + kCount * n_;
  a.albedo = fits_.luminance_albedo.data();
  a.rms = fits_.residual.data();
  settings_.kernels->residuals(a);
}

// normal_equations and uniform_pinv.
class NormalEquationsKernel final : public PixelKernel {
 public:
  NormalEquationsKernel(const KernelSettings& settings, int capacity) : settings_(settings), solve_(settings, capacity) {}

  void SolveSpan(const Span& span, PixelWriter* out) override {
    solve_.Solve(span);
    if (settings_.with_confidence) solve_.AddResiduals(span);
    out->StoreFits(solve_.fits(), span, nullptr);
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
// The default's network pixels need as many tokens as the fewest lights the
// network was trained on (scripts/train: distant sets of 6 lights and more).
constexpr int kMinNetworkTokens = 6;

class AdaptiveKernel final : public PixelKernel {
 public:
  AdaptiveKernel(const KernelSettings& settings, int capacity)
      : settings_(settings),
        solve_(settings, capacity),
        samples_(settings.num_lights),
        refitted_(capacity, 0),
        flagged_(capacity, 0) {
    if (settings_.options.adaptive_learned != PhotometricSolverOptions::LearnedUse::kNever &&
        settings_.num_lights <= settings_.options.adaptive_learned_max_lights) {
      learned_.emplace(settings_, capacity);
    }
  }

  // The least-squares fits go out in one StoreFits after the loop, except
  // where a refit replaced them (refitted_).
  void SolveSpan(const Span& span, PixelWriter* out) override {
    solve_.Solve(span);
    solve_.AddResiduals(span);
    const SpanFits& fits = solve_.fits();
    const uint8_t solved = static_cast<uint8_t>(PixelStatus::kSolved);
    bool any_refitted = false;
    if (learned_) {
      // The network's normals for the whole span's flagged pixels in one batch.
      for (int i = 0; i < span.count; ++i) flagged_[i] = span.Wanted(i) && WantsRobust(span, i, fits) ? 1 : 0;
      // Not below the fewest lights the network was trained on: there the robust fit stays.
      learned_->Predict(span, flagged_.data(), kMinNetworkTokens);
    }
    for (int i = 0; i < span.count; ++i) {
      refitted_[i] = 0;
      if (!span.Wanted(i)) continue;
      const bool sheen = settings_.pixel_sheen && fits.status[i] == solved;
      if (!WantsRobust(span, i, fits) && !sheen) continue;
      refitted_[i] = 1;
      any_refitted = true;
      const int x = span.x0 + i;
      const PixelFit fit = fits.Fit(i);
      if (WantsRobust(span, i, fits)) {
        GatherSamples(span, i, settings_.with_albedo, &samples_);
        const PixelFit refit =
            settings_.pixel_lobe
                ? FitDiffuseLobe(samples_, settings_.View(x, span.y), settings_.with_albedo, settings_.limits,
                                 settings_.robust)
                : FitRobustIrls(samples_, settings_.with_albedo, settings_.limits, settings_.robust);
        if (learned_ && learned_->Predicted(i) && TakesLearned(refit)) {
          const PixelFit learned = learned_->FinishFit(samples_, i, settings_.options.learned_refine);
          if (learned.status == PixelStatus::kSolved) {
            out->Store(learned, x, span.y, SolvePath::kLearned);
            out->StoreExpectedError(learned_->ExpectedErrorDeg(i), x, span.y);
            continue;
          }
        }
        if (refit.status == PixelStatus::kSolved || fit.status != PixelStatus::kSolved) {
          out->Store(refit, x, span.y, SolvePath::kRobust);
          continue;
        }
      }
      if (settings_.pixel_sheen && fit.status == PixelStatus::kSolved) {
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
    // No skip list where nothing was refitted: StoreFits' loops without a test.
    out->StoreFits(fits, span, any_refitted ? refitted_.data() : nullptr);
  }

 private:
  bool WantsRobust(const Span& span, int i, const SpanFits& fits) const {
    if (span.buffers->light_bad[i]) return false;
    return span.buffers->clipped[i] > 0 || (fits.status[i] == static_cast<uint8_t>(PixelStatus::kSolved) &&
                                            fits.residual[i] > settings_.options.adaptive_robust_residual);
  }

  // Whether the network's normal replaces the robust pass's fit `refit`.
  bool TakesLearned(const PixelFit& refit) const {
    return settings_.options.adaptive_learned == PhotometricSolverOptions::LearnedUse::kFlagged ||
           refit.specular_status != SpecularStatus::kEstimated;
  }

  const KernelSettings settings_;
  NormalEquationsSolve solve_;
  PixelSamples samples_;
  std::vector<uint8_t> refitted_;  // 1 where the loop stored the pixel itself
  std::vector<uint8_t> flagged_;   // 1 where the robust pass runs (the network's pixels)
  std::optional<LearnedSpanNormals> learned_;  // with adaptive_learned
};

}  // namespace

std::unique_ptr<PixelKernel> MakeAdaptiveKernel(const SolveJob& job, int capacity) {
  return std::make_unique<AdaptiveKernel>(KernelSettings(job), capacity);
}

// normal_equations and uniform_pinv: they differ only in how tiles share lights.
std::unique_ptr<PixelKernel> MakeNormalEquationsKernel(const SolveJob& job, int capacity) {
  return std::make_unique<NormalEquationsKernel>(KernelSettings(job), capacity);
}

std::unique_ptr<PixelKernel> MakeJacobiSvdKernel(const SolveJob& job, int) {
  const KernelSettings s(job);
  return MakePerPixelKernel(
      s, [limits = s.limits, albedo = s.with_albedo](const PixelSamples& samples, int, int) {
        return FitLeastSquares(DenseMethod::kJacobiSvd, samples, albedo, limits);
      },
      false);
}

std::unique_ptr<PixelKernel> MakeQrKernel(const SolveJob& job, int) {
  const KernelSettings s(job);
  return MakePerPixelKernel(
      s, [limits = s.limits, albedo = s.with_albedo](const PixelSamples& samples, int, int) {
        return FitLeastSquares(DenseMethod::kQr, samples, albedo, limits);
      },
      false);
}

std::unique_ptr<PixelKernel> MakeRobustIrlsKernel(const SolveJob& job, int) {
  const KernelSettings s(job);
  return MakePerPixelKernel(
      s, [limits = s.limits, albedo = s.with_albedo, robust = s.robust](const PixelSamples& samples, int, int) {
        return FitRobustIrls(samples, albedo, limits, robust);
      },
      true);
}

std::unique_ptr<PixelKernel> MakeSparseBayesianKernel(const SolveJob& job, int) {
  const KernelSettings s(job);
  return MakePerPixelKernel(
      s, [limits = s.limits, albedo = s.with_albedo, robust = s.robust](const PixelSamples& samples, int, int) {
        return FitSparseBayesian(samples, albedo, limits, robust);
      },
      true);
}

std::unique_ptr<PixelKernel> MakeDiffuseLobeKernel(const SolveJob& job, int) {
  const KernelSettings s(job);
  return MakePerPixelKernel(
      s, [s](const PixelSamples& samples, int x, int y) {
        return FitDiffuseLobe(samples, s.View(x, y), s.with_albedo, s.limits, s.robust);
      },
      true);
}

}  // namespace scanbench::tiled
