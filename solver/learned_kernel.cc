#include "solver/learned_kernel.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "solver/pixel_kernels.h"

namespace scanbench::tiled {
namespace {

// Samples whose shading ratio (luminance over n . l) lies within this factor of
// the median ratio carry the albedo: wide enough for the noise and the weave's
// texture within a pixel, narrow enough to leave out highlights and penumbras.
constexpr double kAlbedoBand = 0.25;
// n . l below this gives no albedo: the ratio's noise grows as 1 / (n . l).
constexpr double kMinShading = 0.05;
// The refit on the agreeing samples: rounds, and how far from the network's
// normal it may move (beyond, the network's normal is kept).
constexpr int kRefineRounds = 2;
constexpr double kMaxRefineDeg = 8.0;

// The lights of pixel i that become tokens, in the table frame, with their values.
template <typename Emit>
void ForEachToken(const Span& span, int i, Emit&& emit) {
  const SpanBuffers& b = *span.buffers;
  const int n = b.capacity;
  const bool uniform = span.lights == TileLights::kUniform;
  for (int k = 0; k < b.num_lights; ++k) {
    const size_t at = static_cast<size_t>(k) * n + i;
    float dir[3], inverse = 0;
    for (int c = 0; c < 3; ++c) {
      dir[c] = uniform ? span.shared->dir[3 * k + c] : b.dir[static_cast<size_t>(3 * k + c) * n + i];
      const float inv_c = uniform ? span.shared->inv[3 * k + c] : b.inv[static_cast<size_t>(3 * k + c) * n + i];
      inverse = std::max(inverse, inv_c);
    }
    if (b.ok[at] > 0) {
      emit(dir, b.lum[at]);
    } else if (b.marks[k][i] != 0 && inverse > 0 && std::isfinite(dir[0] + dir[1] + dir[2])) {
      emit(dir, 0.0f);  // at or below the shadow level: dark, and the network is told so
    }
  }
}

}  // namespace

LearnedSpanNormals::LearnedSpanNormals(const KernelSettings& settings, int capacity)
    : settings_(settings), network_(NormalNetwork::Embedded()), index_(capacity, -1), to_view_(capacity) {}

void LearnedSpanNormals::Predict(const Span& span, const uint8_t* select, int min_tokens) {
  input_.Clear();
  std::vector<float>& kept_dir = kept_dir_;
  std::vector<float>& kept_value = kept_value_;
  for (int i = 0; i < span.count; ++i) {
    index_[i] = -1;
    if (!span.Wanted(i) || (select != nullptr && select[i] == 0) || span.buffers->light_bad[i]) continue;
    const Eigen::Vector3d view = settings_.View(span.x0 + i, span.y);
    to_view_[i] = Eigen::Quaterniond::FromTwoVectors(view, Eigen::Vector3d::UnitZ());
    const Eigen::Matrix3f rotation = to_view_[i].toRotationMatrix().cast<float>();
    kept_dir.clear();
    kept_value.clear();
    ForEachToken(span, i, [&](const float dir[3], float value) {
      const Eigen::Vector3f in_view = rotation * Eigen::Vector3f(dir[0], dir[1], dir[2]);
      kept_dir.insert(kept_dir.end(), in_view.data(), in_view.data() + 3);
      kept_value.push_back(value);
    });
    const int count = static_cast<int>(kept_value.size());
    if (count < std::max(3, min_tokens)) continue;
    // More lights than the network takes: every stride-th, spread over the set.
    const double stride = std::max(1.0, static_cast<double>(count) / NormalNetwork::kMaxTokens);
    for (double t = 0; t < count; t += stride) {
      const int k = static_cast<int>(t);
      input_.AddToken(&kept_dir[3 * k], kept_value[k]);
    }
    input_.EndPixel();
    index_[i] = input_.num_pixels() - 1;
  }
  if (input_.num_pixels() > 0) network_.Predict(input_, &outputs_, settings_.kernels->isa, &workspace_);
}

Eigen::Vector3d LearnedSpanNormals::NormalInTable(int i) const {
  const Eigen::Vector3d in_view = outputs_[index_[i]].normal_in_view.cast<double>();
  return (to_view_[i].conjugate() * in_view).normalized();
}

namespace {

// The samples of `samples` that agree with `normal`: shading n . l above
// kMinShading and a shading ratio within kAlbedoBand of the median ratio.
// Returns how many; `weights` gets 1 for each, 0 for the others.
int AgreeingSamples(const PixelSamples& samples, const Eigen::Vector3d& normal, std::vector<double>* weights) {
  const int count = samples.count();
  weights->assign(count, 0.0);
  std::vector<double> ratios;
  for (int k = 0; k < count; ++k) {
    const double shading = samples.lights().row(k).dot(normal);
    if (shading > kMinShading) ratios.push_back(samples.values()(k, 0) / shading);
  }
  if (ratios.empty()) return 0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double median = ratios[ratios.size() / 2];
  int used = 0;
  for (int k = 0; k < count; ++k) {
    const double shading = samples.lights().row(k).dot(normal);
    if (!(shading > kMinShading)) continue;
    if (std::abs(samples.values()(k, 0) / shading - median) > kAlbedoBand * std::abs(median)) continue;
    (*weights)[k] = 1.0;
    ++used;
  }
  return used;
}

}  // namespace

PixelFit LearnedSpanNormals::FinishFit(const PixelSamples& samples, int i, bool refine) const {
  PixelFit fit;
  fit.normal = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d predicted = NormalInTable(i);
  Eigen::Vector3d normal = predicted;
  std::vector<double> weights;
  int used = AgreeingSamples(samples, normal, &weights);
  // Least squares on the samples the network's normal explains: its noise
  // averaging where the samples are Lambertian, kept only near the prediction
  // (a refit that wanders off has found a consistent outlier group instead).
  for (int round = 0; refine && round < kRefineRounds && used >= 3; ++round) {
    Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (int k = 0; k < samples.count(); ++k) {
      if (weights[k] == 0) continue;
      const Eigen::Vector3d light = samples.lights().row(k).transpose();
      gram += light * light.transpose();
      rhs += light * samples.values()(k, 0);
    }
    if (!(ConditionNumberFromGram(gram) <= settings_.limits.max_condition_number)) break;
    const Eigen::Vector3d scaled = gram.ldlt().solve(rhs);
    if (!(scaled.norm() > 0)) break;
    const Eigen::Vector3d refined = scaled.normalized();
    if (!(refined.dot(predicted) >= std::cos(kMaxRefineDeg * M_PI / 180))) break;
    normal = refined;
    used = AgreeingSamples(samples, normal, &weights);
  }
  fit.lights_used = used;
  if (used < settings_.limits.min_lights) {
    fit.status = PixelStatus::kTooFewLights;
    return fit;
  }
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  Eigen::Vector4d numerator = Eigen::Vector4d::Zero();
  double denominator = 0;
  for (int k = 0; k < samples.count(); ++k) {
    if (weights[k] == 0) continue;
    const Eigen::Vector3d light = samples.lights().row(k).transpose();
    const double shading = light.dot(normal);
    numerator += samples.values().row(k).transpose() * shading;
    denominator += shading * shading;
    gram += light * light.transpose();
  }
  const double luminance_albedo = numerator[0] / denominator;
  if (!(luminance_albedo >= settings_.limits.min_albedo)) {
    fit.status = PixelStatus::kNoSignal;
    return fit;
  }
  fit.status = PixelStatus::kSolved;
  fit.normal = normal;
  fit.luminance_albedo = luminance_albedo;
  if (settings_.with_albedo) fit.albedo = numerator.tail<3>() / denominator;
  fit.condition_number = ConditionNumberFromGram(gram);
  double residual2 = 0;
  for (int k = 0; k < samples.count(); ++k) {
    if (weights[k] == 0) continue;
    const double r = samples.values()(k, 0) - luminance_albedo * samples.lights().row(k).dot(normal);
    residual2 += r * r;
  }
  fit.residual = std::sqrt(residual2 / used) / luminance_albedo;
  return fit;
}

namespace {

// `learned`: every solvable pixel's normal from the network.
class LearnedKernel final : public PixelKernel {
 public:
  LearnedKernel(const KernelSettings& settings, int capacity)
      : settings_(settings), learned_(settings_, capacity), samples_(settings.num_lights) {}

  void SolveSpan(const Span& span, PixelWriter* out) override {
    learned_.Predict(span, nullptr);
    for (int i = 0; i < span.count; ++i) {
      if (!span.Wanted(i)) continue;
      PixelFit fit;
      if (span.buffers->light_bad[i]) {
        fit.status = PixelStatus::kInvalidInput;
      } else if (!learned_.Predicted(i)) {
        fit.status = PixelStatus::kTooFewLights;
      } else {
        GatherSamples(span, i, settings_.with_albedo, &samples_);
        fit = learned_.FinishFit(samples_, i, settings_.options.learned_refine);
      }
      out->Store(fit, span.x0 + i, span.y, SolvePath::kLearned);
      if (fit.status == PixelStatus::kSolved) out->StoreExpectedError(learned_.ExpectedErrorDeg(i), span.x0 + i, span.y);
    }
  }

 private:
  const KernelSettings settings_;
  LearnedSpanNormals learned_;
  PixelSamples samples_;
};

}  // namespace

std::unique_ptr<PixelKernel> MakeLearnedKernel(const SolveJob& job, int capacity) {
  return std::make_unique<LearnedKernel>(KernelSettings(job), capacity);
}

}  // namespace scanbench::tiled
