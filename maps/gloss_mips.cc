#include "maps/gloss_mips.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

constexpr double kMinNormalLength = 1e-6;  // shorter (or non-finite) input normals carry no weight

double ClampAlpha(double alpha) { return std::clamp(alpha, kMinGgxAlpha, 1.0); }

void ThrowIfNan(double value, const char* function) {
  if (std::isnan(value)) throw std::invalid_argument(std::string(function) + ": argument is NaN");
}

// Lengths at alphas spaced evenly in log(alpha) over [kMinGgxAlpha, 1]; only
// brackets the root for the regula falsi, so a coarse table is enough.
struct LengthTable {
  static constexpr int kSize = 256;
  std::array<double, kSize> alpha{};
  std::array<double, kSize> length{};  // strictly decreasing
  LengthTable() {
    const double log_min = std::log(kMinGgxAlpha);
    for (int k = 0; k < kSize; ++k) {
      alpha[k] = k == 0           ? kMinGgxAlpha
                 : k == kSize - 1 ? 1.0
                                  : std::exp(log_min * (1.0 - static_cast<double>(k) / (kSize - 1)));
      length[k] = GgxAlphaToNormalLength(alpha[k]);
    }
  }
};

const LengthTable& Table() {
  static const LengthTable table;
  return table;
}

// Running sums over the mip-0 footprint of the texels of one level.
struct LevelSums {
  int width = 0, height = 0;
  std::vector<double> vector_sum;    // 3 per texel: unit normals (vMF) or shortened normals (GGX)
  std::vector<double> alpha2_sum;    // vMF only: sum of alpha^2
  std::vector<uint32_t> count;       // valid mip-0 normals in the footprint
  LevelSums(int w, int h, bool with_alpha2)
      : width(w), height(h), vector_sum(static_cast<size_t>(w) * h * 3, 0.0),
        alpha2_sum(with_alpha2 ? static_cast<size_t>(w) * h : 0, 0.0), count(static_cast<size_t>(w) * h, 0) {}
};

LevelSums Downsample(const LevelSums& fine, bool with_alpha2) {
  LevelSums coarse((fine.width + 1) / 2, (fine.height + 1) / 2, with_alpha2);
  for (int y = 0; y < fine.height; ++y) {
    for (int x = 0; x < fine.width; ++x) {
      const size_t from = static_cast<size_t>(y) * fine.width + x;
      const size_t to = static_cast<size_t>(y / 2) * coarse.width + x / 2;
      for (int c = 0; c < 3; ++c) coarse.vector_sum[to * 3 + c] += fine.vector_sum[from * 3 + c];
      if (with_alpha2) coarse.alpha2_sum[to] += fine.alpha2_sum[from];
      coarse.count[to] += fine.count[from];
    }
  }
  return coarse;
}

// One level's output from its footprint sums; returns the mean roughness over
// texels with a valid source (base_roughness if there is none). Rows run in
// parallel (the GGX inversion is the costly part); the mean is summed per row
// and then in row order, so the result does not depend on the threads.
double FinishLevel(const LevelSums& sums, GlossMipOptions::Model model, double base_roughness,
                   GlossMipLevel* level) {
  level->normal_in_tangent = ImageF(sums.width, sums.height, 3);
  level->roughness = ImageF(sums.width, sums.height, 1);
  std::vector<double> row_roughness(sums.height, 0.0);
  std::vector<size_t> row_textured(sums.height, 0);
  auto finish_rows = [&](int first_row, int end_row) {
    for (int y = first_row; y < end_row; ++y) {
      for (int x = 0; x < sums.width; ++x) {
        const size_t i = static_cast<size_t>(y) * sums.width + x;
        std::array<double, 3> direction{0.0, 0.0, 1.0};
        double alpha = base_roughness;
        if (sums.count[i] > 0) {
          const double n = sums.count[i];
          const double mx = sums.vector_sum[i * 3] / n, my = sums.vector_sum[i * 3 + 1] / n,
                       mz = sums.vector_sum[i * 3 + 2] / n;
          const double length = std::sqrt(mx * mx + my * my + mz * mz);
          if (length > 1e-12) direction = {mx / length, my / length, mz / length};
          if (model == GlossMipOptions::Model::kVmf) {
            const double r = std::min(length, 1.0);
            // 1 / kappa of the vMF lobe fitted to the footprint's normals; a
            // single direction (r = 1) adds nothing, opposed ones (r = 0) all.
            alpha = r >= 1.0   ? ClampAlpha(std::sqrt(sums.alpha2_sum[i] / n))
                    : r <= 0.0 ? 1.0
                               : ClampAlpha(std::sqrt(sums.alpha2_sum[i] / n + (1.0 - r * r) / (r * (3.0 - r * r))));
          } else {
            alpha = NormalLengthToGgxAlpha(length);
          }
          row_roughness[y] += alpha;
          ++row_textured[y];
        }
        for (int c = 0; c < 3; ++c) level->normal_in_tangent(x, y, c) = static_cast<float>(direction[c]);
        level->roughness(x, y) = static_cast<float>(alpha);
      }
    }
  };
  // Small levels are not worth the threads: at most 64 chunks, 16384 texels or more each.
  const double stripes = std::max(1.0, std::min(64.0, static_cast<double>(sums.width) * sums.height / 16384));
  const int chunk_rows = static_cast<int>(std::ceil(sums.height / stripes));
  ParallelFor(sums.height, 0, chunk_rows, [&](int first, int last, int) { finish_rows(first, last); });
  double roughness_sum = 0;
  size_t textured = 0;
  for (int y = 0; y < sums.height; ++y) {
    roughness_sum += row_roughness[y];
    textured += row_textured[y];
  }
  return textured > 0 ? roughness_sum / textured : base_roughness;
}

void CheckInputs(const ImageF& normal_in_tangent, const ImageF* roughness, const ImageU8* valid,
                 const std::vector<GlossMipLevel>* levels) {
  const int width = normal_in_tangent.width(), height = normal_in_tangent.height();
  if (normal_in_tangent.empty() || normal_in_tangent.channels() != 3) {
    throw std::invalid_argument("gloss mip chain: normal_in_tangent is " + std::to_string(width) + "x" +
                                std::to_string(height) + "x" + std::to_string(normal_in_tangent.channels()) +
                                ", must be non-empty with 3 channels");
  }
  if (roughness != nullptr && (!roughness->SameSize(normal_in_tangent) || roughness->channels() != 1)) {
    throw std::invalid_argument("gloss mip chain: roughness is " + std::to_string(roughness->width()) + "x" +
                                std::to_string(roughness->height()) + "x" + std::to_string(roughness->channels()) +
                                ", must be " + std::to_string(width) + "x" + std::to_string(height) + "x1");
  }
  if (valid != nullptr && (!valid->SameSize(normal_in_tangent) || valid->channels() != 1)) {
    throw std::invalid_argument("gloss mip chain: valid mask is " + std::to_string(valid->width()) + "x" +
                                std::to_string(valid->height()) + "x" + std::to_string(valid->channels()) +
                                ", must be " + std::to_string(width) + "x" + std::to_string(height) + "x1");
  }
  if (levels == nullptr) throw std::invalid_argument("gloss mip chain: levels must not be null");
}

// Mip 0 (the input, normals normalised, roughness clamped) and the footprint
// sums of level 1 (each mip-0 pixel lies in exactly one level-1 footprint);
// counts what it left out into the summary. `level1` is the size of level 1,
// or {0, 0} when mip 0 is the only level.
struct Mip0 {
  GlossMipLevel level;
  LevelSums level1_sums;
  size_t used = 0;            // mip-0 normals that carry weight
  double roughness_sum = 0;   // of their alphas
};

Mip0 BuildMip0(const ImageF& normal_in_tangent, const ImageF* roughness, const ImageU8* valid,
               const GlossMipOptions& options, std::pair<int, int> level1, GlossMipSummary* s) {
  const int width = normal_in_tangent.width(), height = normal_in_tangent.height();
  const bool vmf = options.model == GlossMipOptions::Model::kVmf;
  const bool has_level1 = level1.first > 0;
  const bool normals = options.mip0_normals;
  Mip0 mip0{{normals ? ImageF(width, height, 3) : ImageF(), ImageF(width, height, 1)},
            LevelSums(level1.first, level1.second, vmf)};
  LevelSums& sums = mip0.level1_sums;
  double cached_alpha = -1, cached_length = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double alpha = options.base_roughness;
      if (roughness != nullptr) {
        const double value = (*roughness)(x, y);
        if (!std::isfinite(value)) {
          ++s->clamped_roughness;
        } else {
          if (value < kMinGgxAlpha || value > 1.0) ++s->clamped_roughness;
          alpha = ClampAlpha(value);
        }
      }
      mip0.level.roughness(x, y) = static_cast<float>(alpha);
      const double nx = normal_in_tangent(x, y, 0), ny = normal_in_tangent(x, y, 1), nz = normal_in_tangent(x, y, 2);
      const double length = std::sqrt(nx * nx + ny * ny + nz * nz);
      if (!std::isfinite(length) || length < kMinNormalLength) {
        ++s->invalid_normals;
        if (normals) {
          mip0.level.normal_in_tangent(x, y, 0) = 0.0f;
          mip0.level.normal_in_tangent(x, y, 1) = 0.0f;
          mip0.level.normal_in_tangent(x, y, 2) = 1.0f;
        }
        continue;
      }
      const std::array<double, 3> unit{nx / length, ny / length, nz / length};
      if (normals) {
        for (int c = 0; c < 3; ++c) mip0.level.normal_in_tangent(x, y, c) = static_cast<float>(unit[c]);
      }
      if (valid != nullptr && (*valid)(x, y) == 0) {
        ++s->masked_pixels;
        continue;
      }
      ++mip0.used;
      mip0.roughness_sum += alpha;
      if (!has_level1) continue;
      const size_t to = static_cast<size_t>(y / 2) * sums.width + x / 2;
      if (!vmf && alpha != cached_alpha) {  // without a roughness map every pixel has the same alpha
        cached_alpha = alpha;
        cached_length = GgxAlphaToNormalLength(alpha);
      }
      const double scale = vmf ? 1.0 : cached_length;
      for (int c = 0; c < 3; ++c) sums.vector_sum[to * 3 + c] += scale * unit[c];
      if (vmf) sums.alpha2_sum[to] += alpha * alpha;
      ++sums.count[to];
    }
  }
  return mip0;
}

std::string Describe(const GlossMipSummary& s, size_t levels, int width, int height,
                     std::pair<int, int> last_size, bool any_used) {
  std::ostringstream message;
  message << s.model << " gloss mips: " << levels << " levels from " << width << "x" << height
          << ", mean roughness " << s.mean_roughness.front() << " at mip 0, " << s.mean_roughness.back() << " at "
          << last_size.first << "x" << last_size.second;
  if (s.invalid_normals > 0) message << "; " << s.invalid_normals << " invalid normals ignored";
  if (s.masked_pixels > 0) message << "; " << s.masked_pixels << " pixels outside the valid mask ignored";
  if (s.clamped_roughness > 0) {
    message << "; " << s.clamped_roughness << " roughness values outside [" << kMinGgxAlpha
            << ", 1] clamped (non-finite: base_roughness)";
  }
  if (!any_used) message << "; no valid normal in the map (all levels flat at base_roughness)";
  return message.str();
}

}  // namespace

void GlossMipOptions::Check() const {
  if (model != Model::kVmf && model != Model::kGgxNormalLength) {
    throw FieldError("GlossMipOptions", "model", static_cast<int>(model), "must be kVmf or kGgxNormalLength");
  }
  if (!(base_roughness >= kMinGgxAlpha && base_roughness <= 1.0)) {
    throw FieldError("GlossMipOptions", "base_roughness", base_roughness,
                     "must lie in [" + std::to_string(kMinGgxAlpha) + ", 1] (GGX alpha)");
  }
  SCANBENCH_REQUIRE_GE("GlossMipOptions", "max_levels", max_levels, 0, "(0 = down to 1x1)");
}

const char* GlossModelName(GlossMipOptions::Model model) {
  switch (model) {
    case GlossMipOptions::Model::kVmf: return "vmf";
    case GlossMipOptions::Model::kGgxNormalLength: return "ggx";
  }
  return "unknown";
}

GlossMipOptions::Model GlossModelFromName(const std::string& name) {
  if (name == "vmf") return GlossMipOptions::Model::kVmf;
  if (name == "ggx") return GlossMipOptions::Model::kGgxNormalLength;
  throw std::invalid_argument("gloss model '" + name + "' is unknown; use 'vmf' or 'ggx'");
}

std::vector<std::pair<int, int>> GlossMipLevelSizes(int width, int height, int max_levels) {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("gloss mip chain of a " + std::to_string(width) + "x" + std::to_string(height) +
                                " map: the size must be positive");
  }
  std::vector<std::pair<int, int>> sizes{{width, height}};
  while ((sizes.back().first > 1 || sizes.back().second > 1) &&
         (max_levels == 0 || static_cast<int>(sizes.size()) < max_levels)) {
    sizes.emplace_back((sizes.back().first + 1) / 2, (sizes.back().second + 1) / 2);
  }
  return sizes;
}

std::string GlossMipSummary::BriefReport() const {
  std::string report = "Gloss mips (" + (model.empty() ? std::string("?") : model) + "): " +
                       TerminationName(termination) + ", " + std::to_string(mean_roughness.size()) + " levels";
  if (!mean_roughness.empty()) {
    report += ", mean GGX alpha " + Fixed(mean_roughness.front(), 3) + " at mip 0, " +
              Fixed(mean_roughness.back(), 3) + " at the last";
  }
  report += ", " + Fixed(seconds, 2) + " s";
  if (termination != Termination::kSuccess) report += " (" + message + ")";
  return report;
}

GlossMipSummary BuildGlossMipChain(const GlossMipOptions& options, const ImageF& normal_in_tangent,
                                   const ImageF* roughness, const ImageU8* valid, std::vector<GlossMipLevel>* levels,
                                   const ProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  options.Check();
  CheckInputs(normal_in_tangent, roughness, valid, levels);
  const int width = normal_in_tangent.width(), height = normal_in_tangent.height();
  const bool vmf = options.model == GlossMipOptions::Model::kVmf;
  const std::vector<std::pair<int, int>> sizes = GlossMipLevelSizes(width, height, options.max_levels);
  GlossMipSummary s;
  s.model = GlossModelName(options.model);
  levels->clear();
  // Progress in texels made, every level's share by its size.
  double total_texels = 0, done_texels = 0;
  for (const auto& [w, h] : sizes) total_texels += static_cast<double>(w) * h;
  auto cancelled_after = [&](const std::pair<int, int>& size) {
    done_texels += static_cast<double>(size.first) * size.second;
    if (!progress || progress(done_texels / total_texels)) return false;
    levels->clear();
    s.SetCancelled("gloss mips cancelled by the progress callback after " + std::to_string(size.first) + "x" +
                   std::to_string(size.second));
    s.seconds = SecondsSince(start);
    return true;
  };

  std::vector<GlossMipLevel> chain(sizes.size());
  Mip0 mip0 = BuildMip0(normal_in_tangent, roughness, valid, options,
                        sizes.size() > 1 ? sizes[1] : std::pair<int, int>{0, 0}, &s);
  chain[0] = std::move(mip0.level);
  s.mean_roughness.push_back(mip0.used > 0 ? mip0.roughness_sum / mip0.used : options.base_roughness);
  if (cancelled_after(sizes[0])) return s;
  LevelSums sums = std::move(mip0.level1_sums);
  for (size_t l = 1; l < sizes.size(); ++l) {
    if (l > 1) sums = Downsample(sums, vmf);
    s.mean_roughness.push_back(FinishLevel(sums, options.model, options.base_roughness, &chain[l]));
    if (cancelled_after(sizes[l])) return s;
  }

  s.termination = mip0.used > 0 ? Termination::kSuccess : Termination::kFailure;
  s.message = Describe(s, chain.size(), width, height, sizes.back(), mip0.used > 0);
  s.seconds = SecondsSince(start);
  *levels = std::move(chain);
  return s;
}

double GlossToGgxAlpha(double gloss) {
  ThrowIfNan(gloss, "GlossToGgxAlpha");
  gloss = std::clamp(gloss, 0.0, 1.0);
  return std::sqrt(2.0 / (1.0 + std::exp2(18.0 * gloss)));
}

double GgxAlphaToGloss(double alpha) {
  ThrowIfNan(alpha, "GgxAlphaToGloss");
  if (alpha <= 0.0) return 1.0;
  alpha = std::min(alpha, 1.0);
  // Inverse of eq. 2: 2^(18 g) = 2 / alpha^2 - 1.
  return std::clamp(std::log2(2.0 / (alpha * alpha) - 1.0) / 18.0, 0.0, 1.0);
}

double GgxAlphaToNormalLength(double alpha) {
  ThrowIfNan(alpha, "GgxAlphaToNormalLength");
  alpha = std::clamp(alpha, 0.0, 1.0);
  if (alpha == 0.0) return 1.0;
  const double alpha2 = alpha * alpha;
  const double a = std::sqrt(1.0 - alpha2);
  if (a < 0.5) {
    // Eq. 26 cancels for small a; its series: sum_k>=1 2 a^(2k-2) / (4k^2 - 1).
    double sum = 0, power = 1;
    for (int k = 1; k < 64; ++k) {
      const double term = 2.0 * power / (4.0 * k * k - 1.0);
      sum += term;
      if (term < 1e-18) break;
      power *= a * a;
    }
    return sum;
  }
  // Eq. 26 with 1 - a^2 = alpha^2 and atanh(a) = log((1 + a) / alpha), which
  // stays accurate as a -> 1.
  return (a - alpha2 * std::log((1.0 + a) / alpha)) / (a * a * a);
}

double NormalLengthToGgxAlpha(double length) {
  ThrowIfNan(length, "NormalLengthToGgxAlpha");
  const LengthTable& table = Table();
  if (length <= table.length.back()) return 1.0;
  if (length >= table.length.front()) return kMinGgxAlpha;
  // First k with length[k] < target: the root lies in (alpha[k - 1], alpha[k]].
  const auto it = std::upper_bound(table.length.begin(), table.length.end(), length, std::greater<double>());
  const int k = static_cast<int>(it - table.length.begin());
  double lo = table.alpha[k - 1], hi = table.alpha[k];
  double f_lo = table.length[k - 1] - length, f_hi = table.length[k] - length;  // f_lo >= 0 > f_hi
  double x = lo;
  int last_side = 0;
  // Illinois variant of regula falsi: halves the stale end's value so both
  // ends converge; bisection if the secant leaves the bracket. Stops when a
  // step moves x by less than ~1e-13 relative (about 6 steps from the table).
  for (int iteration = 0; iteration < 100; ++iteration) {
    const double previous = x;
    x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
    if (!(x > lo && x < hi)) x = 0.5 * (lo + hi);
    if (iteration > 0 && std::abs(x - previous) <= 1e-13 * x) break;
    const double f = GgxAlphaToNormalLength(x) - length;
    if (f == 0.0) break;
    if (f > 0) {
      lo = x;
      f_lo = f;
      if (last_side == 1) f_hi *= 0.5;
      last_side = 1;
    } else {
      hi = x;
      f_hi = f;
      if (last_side == -1) f_lo *= 0.5;
      last_side = -1;
    }
    if (hi - lo <= 1e-13 * hi || std::abs(f) <= 1e-16) break;
  }
  return ClampAlpha(x);
}

}  // namespace scanbench
