#include "solver/cloth_material.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include <Eigen/Cholesky>

#include "core/field_error.h"
#include "core/parallel_for.h"
#include "solver/engine_shading.h"

namespace scanbench {
namespace {

constexpr double kPi = std::numbers::pi;
// Samples with n.l or n.v below this are grazing: left out of the fit (the
// lobes' shapes and the sample's shading are least certain there).
constexpr double kMinCos = 0.02;
constexpr const char* kOptions = "ClothMaterialFitOptions";

// One lit, valid sample of a pixel: what it reads per channel (intensity
// divided) and its geometry.
struct Sample {
  std::array<double, 3> b{};
  double nl = 0, nv = 0, nh = 0, m5 = 0;  // m5 = (1 - v.h)^5
};

// The terms a block takes and their roughnesses (grid indices).
struct ModelChoice {
  bool sheen = false;
  bool specular = false;
  int sheen_index = 0;
  int specular_index = 0;
};

// A pixel's linear fit under one ModelChoice.
struct PixelFit {
  ClothMaterial material;
  double rss = 0;               // sum of squared residuals over samples and channels
  double sheen_variance = 0;    // of the sheen amplitude (its colour's largest channel)
  double specular_variance = 0; // of F0
};

// ClothMaterialValue from a sample's dot products (one channel at a time would recompute the lobes).
Eigen::Vector3d PredictSample(const ClothMaterial& m, const Sample& s) {
  double fresnel = 0, specular = 0;
  if (m.specular_f0 > 0) {
    const double alpha = m.specular_roughness * m.specular_roughness;
    fresnel = m.specular_f0 + (1.0 - m.specular_f0) * s.m5;
    specular = fresnel * kPi * GgxDistribution(alpha, s.nh) * GgxVisibility(alpha, s.nl, s.nv) * s.nl;
  }
  const Eigen::Vector3d base = (1.0 - fresnel) * m.base_color * s.nl + Eigen::Vector3d::Constant(specular);
  const double sheen_max = m.sheen_color.maxCoeff();
  if (!(sheen_max > 0)) return base;
  const double r = m.sheen_roughness;
  const double scaling = std::clamp(
      std::min(1.0 - sheen_max * CharlieSheenAlbedo(s.nv, r), 1.0 - sheen_max * CharlieSheenAlbedo(s.nl, r)), 0.0, 1.0);
  return scaling * base + m.sheen_color * (kPi * CharlieDistribution(r, s.nh) * SheenVisibility(s.nl, s.nv) * s.nl);
}

// The samples of one pixel under a light field evaluated there.
class PixelSampler {
 public:
  PixelSampler(const PhotometricSolverInput& input, int held_out_light)
      : input_(input), held_out_(held_out_light), num_lights_(input.light_field->num_lights()),
        dirs_(3 * num_lights_), intensities_(3 * num_lights_) {}

  // The pixel's usable samples into *samples; false when the normal is not a unit vector.
  bool Gather(int x, int y, const Eigen::Vector3d& n, std::vector<Sample>* samples) {
    samples->clear();
    if (!(std::abs(n.squaredNorm() - 1.0) < 1e-3)) return false;
    input_.light_field->Evaluate(x, y, dirs_.data(), intensities_.data());
    float view[3];
    input_.light_field->ViewDirection(x, y, view);
    const Eigen::Vector3d v(view[0], view[1], view[2]);
    const double nv = n.dot(v);
    if (!(nv > kMinCos)) return true;
    for (int k = 0; k < num_lights_; ++k) {
      if (k == held_out_) continue;
      if (!input_.sample_valid.empty() && input_.sample_valid[k] && (*input_.sample_valid[k])(x, y) == 0) continue;
      const Eigen::Vector3d l(dirs_[3 * k], dirs_[3 * k + 1], dirs_[3 * k + 2]);
      const double nl = n.dot(l);
      if (!(nl > kMinCos)) continue;
      Sample s;
      bool finite = true;
      for (int c = 0; c < 3; ++c) {
        const double e = intensities_[3 * k + c];
        const double value = (*input_.images[k])(x, y, c);
        if (!(e > 0) || !std::isfinite(value)) finite = false;
        s.b[c] = finite ? value / e : 0;
      }
      if (!finite) continue;
      const Eigen::Vector3d sum = l + v;
      const double sum_norm = sum.norm();
      if (!(sum_norm > 1e-9)) continue;
      const Eigen::Vector3d h = sum / sum_norm;
      s.nl = nl;
      s.nv = nv;
      s.nh = std::clamp(n.dot(h), 0.0, 1.0);
      const double m = 1.0 - std::clamp(v.dot(h), 0.0, 1.0);
      s.m5 = m * m * m * m * m;
      samples->push_back(s);
    }
    return true;
  }

 private:
  const PhotometricSolverInput& input_;
  int held_out_;
  int num_lights_;
  std::vector<float> dirs_, intensities_;
};

// The linear fit of one pixel's colours, sheen amplitude and F0 under
// `model` (roughnesses given), the sheen's colour tied to `tint` (largest
// channel 1), alternated with the Fresnel and albedo-scaling weights.
class PixelFitter {
 public:
  PixelFitter(const ClothMaterialFitOptions& options) : options_(options) {}

  PixelFit Fit(const std::vector<Sample>& samples, const ModelChoice& model, const Eigen::Vector3d& tint) {
    const double sheen_r = options_.sheen_roughnesses[model.sheen_index];
    const double specular_r = options_.specular_roughnesses[model.specular_index];
    const double alpha = specular_r * specular_r;
    const size_t count = samples.size();
    sheen_shape_.assign(count, 0.0);
    specular_shape_.assign(count, 0.0);
    albedo_v_.assign(count, 0.0);
    albedo_l_.assign(count, 0.0);
    for (size_t k = 0; k < count; ++k) {
      const Sample& s = samples[k];
      if (model.sheen) {
        sheen_shape_[k] = kPi * CharlieDistribution(sheen_r, s.nh) * SheenVisibility(s.nl, s.nv) * s.nl;
        albedo_v_[k] = CharlieSheenAlbedo(s.nv, sheen_r);
        albedo_l_[k] = CharlieSheenAlbedo(s.nl, sheen_r);
      }
      if (model.specular) specular_shape_[k] = kPi * GgxDistribution(alpha, s.nh) * GgxVisibility(alpha, s.nl, s.nv) * s.nl;
    }

    // Unknowns: base colour (3), sheen amplitude, F0.
    std::array<bool, 5> active = {true, true, true, model.sheen, model.specular};
    Eigen::Matrix<double, 5, 1> x = Eigen::Matrix<double, 5, 1>::Zero();
    Eigen::Matrix<double, 5, 5> last_inverse = Eigen::Matrix<double, 5, 5>::Zero();
    for (int iteration = 0; iteration < options_.iterations; ++iteration) {
      const double sheen_max = model.sheen ? x(3) : 0.0;  // tint's largest channel is 1
      const double f0 = model.specular ? x(4) : 0.0;
      Eigen::Matrix<double, 5, 5> ata = Eigen::Matrix<double, 5, 5>::Zero();
      Eigen::Matrix<double, 5, 1> atb = Eigen::Matrix<double, 5, 1>::Zero();
      for (size_t k = 0; k < count; ++k) {
        const Sample& s = samples[k];
        const double scale = Scaling(sheen_max, k);
        const double fresnel = model.specular ? f0 + (1.0 - f0) * s.m5 : 0.0;
        const double d = scale * (1.0 - fresnel) * s.nl;
        const double g = model.specular ? scale * (1.0 - s.m5) * specular_shape_[k] : 0.0;
        const double offset = model.specular ? scale * s.m5 * specular_shape_[k] : 0.0;
        for (int c = 0; c < 3; ++c) {
          const double sc = sheen_shape_[k] * tint(c);
          const double y = s.b[c] - offset;
          ata(c, c) += d * d;
          ata(c, 3) += d * sc;
          ata(c, 4) += d * g;
          ata(3, 3) += sc * sc;
          ata(3, 4) += sc * g;
          ata(4, 4) += g * g;
          atb(c) += d * y;
          atb(3) += sc * y;
          atb(4) += g * y;
        }
      }
      for (int i = 0; i < 5; ++i) {
        for (int j = 0; j < i; ++j) ata(i, j) = ata(j, i);
      }
      // Non-negative amplitudes: an amplitude that comes out negative is
      // dropped and the rest solved again.
      for (int round = 0; round < 3; ++round) {
        SolveActive(ata, atb, active, &x, &last_inverse);
        bool dropped = false;
        for (int i = 3; i < 5; ++i) {
          if (active[i] && x(i) < 0) active[i] = false, x(i) = 0, dropped = true;
        }
        if (!dropped) break;
      }
      x(4) = std::min(x(4), 1.0);
    }

    PixelFit fit;
    for (int c = 0; c < 3; ++c) fit.material.base_color(c) = std::max(0.0, x(c));
    fit.material.sheen_color = model.sheen ? Eigen::Vector3d(x(3) * tint) : Eigen::Vector3d::Zero();
    fit.material.sheen_roughness = sheen_r;
    fit.material.specular_f0 = model.specular ? x(4) : 0.0;
    fit.material.specular_roughness = specular_r;
    // The residual under the model itself (its Fresnel and scaling at the fitted values).
    for (const Sample& sample : samples) {
      const Eigen::Vector3d predicted = PredictSample(fit.material, sample);
      for (int c = 0; c < 3; ++c) fit.rss += (sample.b[c] - predicted(c)) * (sample.b[c] - predicted(c));
    }
    const int unknowns = 3 + (active[3] ? 1 : 0) + (active[4] ? 1 : 0);
    const double dof = std::max(1.0, 3.0 * static_cast<double>(count) - unknowns);
    const double sigma2 = fit.rss / dof;
    if (active[3]) fit.sheen_variance = sigma2 * last_inverse(3, 3);
    if (active[4]) fit.specular_variance = sigma2 * last_inverse(4, 4);
    return fit;
  }

 private:
  double Scaling(double sheen_max, size_t k) const {
    if (sheen_max <= 0) return 1.0;
    return std::clamp(std::min(1.0 - sheen_max * albedo_v_[k], 1.0 - sheen_max * albedo_l_[k]), 0.0, 1.0);
  }

  // x on the active unknowns (the rest 0) and their inverse normal matrix:
  // an inactive unknown's row and column become the identity's (fixed size,
  // no allocation: this runs some ten times per pixel).
  static void SolveActive(Eigen::Matrix<double, 5, 5> ata, Eigen::Matrix<double, 5, 1> atb,
                          const std::array<bool, 5>& active, Eigen::Matrix<double, 5, 1>* x,
                          Eigen::Matrix<double, 5, 5>* inverse) {
    // A tiny ridge keeps a column the samples do not reach (a sheen shape of
    // zero) from making the system singular.
    const double ridge = 1e-9 * (ata.diagonal().maxCoeff() + 1e-12);
    for (int i = 0; i < 5; ++i) {
      if (active[i]) {
        ata(i, i) += ridge;
        continue;
      }
      ata.row(i).setZero();
      ata.col(i).setZero();
      ata(i, i) = 1;
      atb(i) = 0;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(ata);
    *x = ldlt.solve(atb);
    *inverse = ldlt.solve(Eigen::Matrix<double, 5, 5>::Identity());
    for (int i = 0; i < 5; ++i) {
      if (!active[i] || !std::isfinite((*x)(i))) (*x)(i) = 0;
    }
  }

  const ClothMaterialFitOptions& options_;
  std::vector<double> sheen_shape_, specular_shape_, albedo_v_, albedo_l_;
};

// One pixel of a block, gathered.
struct BlockPixel {
  int x = 0, y = 0;
  std::vector<Sample> samples;
  double weight = 1;  // 1 / mean(b)^2: the block's choice weighs every pixel's residual relative to its brightness
};

// The block's BIC of `model` on its decision pixels.
class BlockDecision {
 public:
  BlockDecision(const ClothMaterialFitOptions& options, PixelFitter* fitter, const std::vector<const BlockPixel*>& pixels)
      : options_(options), fitter_(fitter), pixels_(pixels) {
    for (const BlockPixel* p : pixels_) observations_ += 3.0 * static_cast<double>(p->samples.size());
  }

  double Bic(const ModelChoice& model) {
    double rss = 0;
    const Eigen::Vector3d white = Eigen::Vector3d::Ones();
    for (const BlockPixel* p : pixels_) rss += p->weight * fitter_->Fit(p->samples, model, white).rss;
    const double per_pixel = 3.0 + (model.sheen ? 1 : 0) + (model.specular ? 1 : 0);
    const double parameters = per_pixel * static_cast<double>(pixels_.size()) + (model.sheen ? 1 : 0) + (model.specular ? 1 : 0);
    const double n = std::max(observations_, 1.0);
    return n * std::log(std::max(rss / n, 1e-30)) + parameters * std::log(n);
  }

  // Each decision pixel's samples predicted one at a time from a fit of the
  // others (leave one out), squared, weighed as Bic's: what the block's
  // choice must lower to be kept, since a lobe that fits every light can
  // still mispredict the next one (a sharp highlight seen by one LED).
  double HeldOutRss(const ModelChoice& model) {
    double rss = 0;
    const Eigen::Vector3d white = Eigen::Vector3d::Ones();
    for (const BlockPixel* p : pixels_) {
      held_out_.resize(p->samples.size() - 1);
      for (size_t i = 0; i < p->samples.size(); ++i) {
        for (size_t k = 0, j = 0; k < p->samples.size(); ++k) {
          if (k != i) held_out_[j++] = p->samples[k];
        }
        const Eigen::Vector3d predicted = PredictSample(fitter_->Fit(held_out_, model, white).material, p->samples[i]);
        for (int c = 0; c < 3; ++c) {
          const double r = p->samples[i].b[c] - predicted(c);
          rss += p->weight * r * r;
        }
      }
    }
    return rss;
  }

  // The sheen's colour direction (largest channel 1) from the decision pixels
  // fitted with a free colour per channel: white where that says nothing.
  Eigen::Vector3d SheenTint(const ModelChoice& model) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int c = 0; c < 3; ++c) {
      Eigen::Vector3d unit = Eigen::Vector3d::Zero();
      unit(c) = 1;
      for (const BlockPixel* p : pixels_) sum(c) += fitter_->Fit(p->samples, model, unit).material.sheen_color(c);
    }
    const double largest = sum.maxCoeff();
    if (!(largest > 0)) return Eigen::Vector3d::Ones();
    return (sum / largest).cwiseMax(0.0);
  }

  bool empty() const { return pixels_.empty(); }

 private:
  const ClothMaterialFitOptions& options_;
  PixelFitter* fitter_;
  const std::vector<const BlockPixel*>& pixels_;
  double observations_ = 0;
  std::vector<Sample> held_out_;
};

// The grid values within 2 of the smallest BIC: half their span, or half the
// step to the nearest neighbour when only the best is.
double GridHalfSpan(const std::vector<double>& grid, const std::vector<double>& bic) {
  if (bic.empty()) return 0;
  const size_t best = std::min_element(bic.begin(), bic.end()) - bic.begin();
  double lo = grid[best], hi = grid[best];
  for (size_t i = 0; i < grid.size(); ++i) {
    if (bic[i] <= bic[best] + 2.0) lo = std::min(lo, grid[i]), hi = std::max(hi, grid[i]);
  }
  if (hi > lo) return 0.5 * (hi - lo);
  double step = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < grid.size(); ++i) {
    if (i != best) step = std::min(step, std::abs(grid[i] - grid[best]));
  }
  return std::isfinite(step) ? 0.5 * step : 0.0;
}

struct BlockCounts {
  size_t fitted = 0, sheen = 0, specular = 0, too_few = 0, blocks = 0, blocks_sheen = 0, blocks_specular = 0;
};

// The steps of one block: gather, decide its terms and roughnesses, fit and write every pixel.
class BlockFitter {
 public:
  BlockFitter(const ClothMaterialFitOptions& options, const PhotometricSolverInput& input, const ImageF& normals,
              const ImageU8& pixels, ClothMaterialMaps* maps)
      : options_(options), normals_(normals), pixels_(pixels), maps_(maps), sampler_(input, options.held_out_light),
        fitter_(options) {}

  void Run(int x0, int y0, int x1, int y1, BlockCounts* counts) {
    if (!Gather(x0, y0, x1, y1, counts)) return;
    ++counts->blocks;
    ModelChoice model;
    Eigen::Vector3d tint = Eigen::Vector3d::Ones();
    double sheen_span = 0, specular_span = 0;
    Decide(&model, &tint, &sheen_span, &specular_span);
    counts->blocks_sheen += model.sheen;
    counts->blocks_specular += model.specular;
    for (const BlockPixel& p : block_) Write(p, fitter_.Fit(p.samples, model, tint), model, sheen_span, specular_span, counts);
  }

 private:
  // The block's pixels to fit with their samples; false when there are none.
  bool Gather(int x0, int y0, int x1, int y1, BlockCounts* counts) {
    block_.clear();
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) {
        if (pixels_(x, y) == 0) continue;
        BlockPixel p;
        p.x = x, p.y = y;
        const Eigen::Vector3d n(normals_(x, y, 0), normals_(x, y, 1), normals_(x, y, 2));
        if (!sampler_.Gather(x, y, n, &p.samples) || static_cast<int>(p.samples.size()) < options_.min_samples) {
          ++counts->too_few;
          continue;
        }
        double mean = 0;
        for (const Sample& s : p.samples) mean += s.b[0] + s.b[1] + s.b[2];
        mean /= 3.0 * static_cast<double>(p.samples.size());
        p.weight = 1.0 / std::max(mean * mean, 1e-12);
        block_.push_back(std::move(p));
      }
    }
    return !block_.empty();
  }

  // The terms by BIC: the diffuse fit, then a sheen and a specular term over
  // their grids, then both at the best of each, refined one grid at a time.
  void Decide(ModelChoice* chosen, Eigen::Vector3d* tint, double* sheen_span, double* specular_span) {
    decision_.clear();
    const size_t n = block_.size();
    const size_t take = std::min<size_t>(n, options_.max_decision_pixels);
    for (size_t i = 0; i < take; ++i) decision_.push_back(&block_[i * n / take]);
    BlockDecision decision(options_, &fitter_, decision_);
    const int num_sheen = static_cast<int>(options_.sheen_roughnesses.size());
    const int num_specular = static_cast<int>(options_.specular_roughnesses.size());

    const double diffuse_bic = decision.Bic(ModelChoice{});
    ModelChoice best;
    double best_bic = diffuse_bic;
    std::vector<double> sheen_bic, specular_bic;
    ModelChoice sheen_only{true, false, 0, 0}, specular_only{false, true, 0, 0};
    if (options_.fit_sheen) {
      for (int i = 0; i < num_sheen; ++i) {
        sheen_bic.push_back(decision.Bic(ModelChoice{true, false, i, 0}));
      }
      sheen_only.sheen_index = static_cast<int>(std::min_element(sheen_bic.begin(), sheen_bic.end()) - sheen_bic.begin());
      if (sheen_bic[sheen_only.sheen_index] < best_bic - options_.bic_margin) {
        best = sheen_only, best_bic = sheen_bic[sheen_only.sheen_index];
      }
    }
    if (options_.fit_specular) {
      for (int i = 0; i < num_specular; ++i) {
        specular_bic.push_back(decision.Bic(ModelChoice{false, true, 0, i}));
      }
      specular_only.specular_index =
          static_cast<int>(std::min_element(specular_bic.begin(), specular_bic.end()) - specular_bic.begin());
      const double bic = specular_bic[specular_only.specular_index];
      if (bic < diffuse_bic - options_.bic_margin && bic < best_bic) best = specular_only, best_bic = bic;
    }
    if (options_.fit_sheen && options_.fit_specular) {
      ModelChoice both{true, true, sheen_only.sheen_index, specular_only.specular_index};
      std::vector<double> both_sheen(num_sheen), both_specular(num_specular);
      for (int i = 0; i < num_sheen; ++i) both_sheen[i] = decision.Bic(ModelChoice{true, true, i, both.specular_index});
      both.sheen_index = static_cast<int>(std::min_element(both_sheen.begin(), both_sheen.end()) - both_sheen.begin());
      for (int i = 0; i < num_specular; ++i) both_specular[i] = decision.Bic(ModelChoice{true, true, both.sheen_index, i});
      both.specular_index =
          static_cast<int>(std::min_element(both_specular.begin(), both_specular.end()) - both_specular.begin());
      const double bic = both_specular[both.specular_index];
      if (bic < best_bic - options_.bic_margin) {
        best = both, best_bic = bic;
        sheen_bic = both_sheen, specular_bic = both_specular;
      }
    }
    // A term the held-out samples do not confirm is not kept.
    if ((best.sheen || best.specular) && options_.min_held_out_gain < 1 &&
        !(decision.HeldOutRss(best) < (1.0 - options_.min_held_out_gain) * decision.HeldOutRss(ModelChoice{}))) {
      best = ModelChoice{};
    }
    *chosen = best;
    *sheen_span = best.sheen ? GridHalfSpan(options_.sheen_roughnesses, sheen_bic) : 0.0;
    *specular_span = best.specular ? GridHalfSpan(options_.specular_roughnesses, specular_bic) : 0.0;
    *tint = best.sheen ? decision.SheenTint(best) : Eigen::Vector3d::Ones();
  }

  void Write(const BlockPixel& p, const PixelFit& fit, const ModelChoice& model, double sheen_span,
             double specular_span, BlockCounts* counts) {
    const ClothMaterial& m = fit.material;
    const bool sheen = model.sheen && m.sheen_color.maxCoeff() > 0;
    const bool specular = model.specular && m.specular_f0 > 0;
    for (int c = 0; c < 3; ++c) {
      maps_->base_color(p.x, p.y, c) = static_cast<float>(m.base_color(c));
      maps_->sheen_color(p.x, p.y, c) = sheen ? static_cast<float>(m.sheen_color(c)) : 0.0f;
    }
    maps_->sheen_roughness(p.x, p.y) = sheen ? static_cast<float>(m.sheen_roughness) : 0.0f;
    maps_->specular(p.x, p.y, 0) = specular ? static_cast<float>(m.specular_f0) : 0.0f;
    maps_->specular(p.x, p.y, 1) = specular ? static_cast<float>(m.specular_roughness) : 0.0f;
    maps_->terms(p.x, p.y) = kMaterialFitted | (sheen ? kMaterialSheen : 0) | (specular ? kMaterialSpecular : 0);
    maps_->confidence(p.x, p.y, 0) = sheen ? static_cast<float>(std::sqrt(std::max(0.0, fit.sheen_variance))) : 0.0f;
    maps_->confidence(p.x, p.y, 1) = sheen ? static_cast<float>(sheen_span) : 0.0f;
    maps_->confidence(p.x, p.y, 2) = specular ? static_cast<float>(std::sqrt(std::max(0.0, fit.specular_variance))) : 0.0f;
    maps_->confidence(p.x, p.y, 3) = specular ? static_cast<float>(specular_span) : 0.0f;
    ++counts->fitted;
    counts->sheen += sheen;
    counts->specular += specular;
  }

  const ClothMaterialFitOptions& options_;
  const ImageF& normals_;
  const ImageU8& pixels_;
  ClothMaterialMaps* maps_;
  PixelSampler sampler_;
  PixelFitter fitter_;
  std::vector<BlockPixel> block_;
  std::vector<const BlockPixel*> decision_;
};

void CheckGrid(const char* field, const std::vector<double>& grid) {
  if (grid.empty()) throw FieldError(kOptions, field, "{}", "must hold at least one roughness");
  for (double r : grid) SCANBENCH_REQUIRE_GE_LE(kOptions, field, r, 0.05, 1.0);
}

}  // namespace

Eigen::Vector3d ClothMaterialValue(const ClothMaterial& material, const Eigen::Vector3d& n, const Eigen::Vector3d& l,
                                   const Eigen::Vector3d& v) {
  const double nl = n.dot(l), nv = n.dot(v);
  if (!(nl > 0) || !(nv > 0)) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d sum = l + v;
  const double sum_norm = sum.norm();
  if (!(sum_norm > 1e-12)) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d h = sum / sum_norm;
  Sample s;
  s.nl = nl, s.nv = nv;
  s.nh = std::clamp(n.dot(h), 0.0, 1.0);
  const double m = 1.0 - std::clamp(v.dot(h), 0.0, 1.0);
  s.m5 = m * m * m * m * m;
  return PredictSample(material, s);
}

ClothMaterial MaterialAt(const ClothMaterialMaps& maps, int x, int y) {
  ClothMaterial m;
  if ((maps.terms(x, y) & kMaterialFitted) == 0) return m;
  for (int c = 0; c < 3; ++c) {
    m.base_color(c) = maps.base_color(x, y, c);
    m.sheen_color(c) = maps.sheen_color(x, y, c);
  }
  m.sheen_roughness = maps.sheen_roughness(x, y) > 0 ? maps.sheen_roughness(x, y) : 0.5;
  m.specular_f0 = maps.specular(x, y, 0);
  m.specular_roughness = maps.specular(x, y, 1) > 0 ? maps.specular(x, y, 1) : 0.5;
  return m;
}

void ClothMaterialFitOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE(kOptions, "block_size", block_size, 2, 256);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_decision_pixels", max_decision_pixels, 1, 65536);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "min_samples", min_samples, 4, 10000);
  CheckGrid("sheen_roughnesses", sheen_roughnesses);
  CheckGrid("specular_roughnesses", specular_roughnesses);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "bic_margin", bic_margin, 0.0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "iterations", iterations, 1, 10);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "min_held_out_gain", min_held_out_gain, 0.0, 1.0);
  SCANBENCH_REQUIRE_GE(kOptions, "held_out_light", held_out_light, -1);
  SCANBENCH_REQUIRE_GE(kOptions, "num_threads", num_threads, 0);
}

std::string ClothMaterialFitSummary::BriefReport() const {
  std::ostringstream out;
  out << "cloth material: " << TerminationName(termination) << ", " << pixels_fitted << " px fitted (sheen "
      << pixels_sheen << ", specular " << pixels_specular << "), " << pixels_too_few_samples
      << " with too few samples; blocks " << blocks << " (sheen " << blocks_sheen << ", specular " << blocks_specular
      << ")";
  if (!message.empty()) out << "; " << message;
  return out.str();
}

ClothMaterialFitSummary FitClothMaterial(const ClothMaterialFitOptions& options, const PhotometricSolverInput& input,
                                         const ImageF& normals, const ImageU8& pixels, ClothMaterialMaps* maps,
                                         const ProgressCallback& progress) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  if (input.light_field == nullptr) throw std::invalid_argument("FitClothMaterial: input.light_field is null");
  const LightField& field = *input.light_field;
  const int width = field.width(), height = field.height(), num_lights = field.num_lights();
  if (static_cast<int>(input.images.size()) != num_lights) {
    throw std::invalid_argument("FitClothMaterial: " + std::to_string(input.images.size()) + " images for " +
                                std::to_string(num_lights) + " lights");
  }
  for (const ImageF* image : input.images) {
    if (image == nullptr || !image->SameSize(width, height) || image->channels() != 3) {
      throw std::invalid_argument("FitClothMaterial: every image must be 3 channels of " + std::to_string(width) +
                                  "x" + std::to_string(height));
    }
  }
  if (!normals.SameSize(width, height) || normals.channels() != 3 || !pixels.SameSize(width, height)) {
    throw std::invalid_argument("FitClothMaterial: normals (3 channels) and pixels must be " + std::to_string(width) +
                                "x" + std::to_string(height));
  }
  if (options.held_out_light >= num_lights) {
    throw FieldError(kOptions, "held_out_light", options.held_out_light,
                     "must be below the input's " + std::to_string(num_lights) + " lights");
  }
  maps->base_color = ImageF(width, height, 3);
  maps->sheen_color = ImageF(width, height, 3);
  maps->sheen_roughness = ImageF(width, height, 1);
  maps->specular = ImageF(width, height, 2);
  maps->terms = ImageU8(width, height, 1);
  maps->confidence = ImageF(width, height, 4);

  const int bs = options.block_size;
  const int blocks_x = (width + bs - 1) / bs, blocks_y = (height + bs - 1) / bs;
  const int threads = ResolveThreadCount(options.num_threads);
  std::vector<BlockCounts> counts(threads);
  std::vector<std::unique_ptr<BlockFitter>> fitters(threads);
  const bool finished = ParallelFor(
      blocks_x * blocks_y, threads, 1,
      [&](int first, int last, int worker) {
        if (!fitters[worker]) fitters[worker] = std::make_unique<BlockFitter>(options, input, normals, pixels, maps);
        for (int b = first; b < last; ++b) {
          const int x0 = (b % blocks_x) * bs, y0 = (b / blocks_x) * bs;
          fitters[worker]->Run(x0, y0, std::min(x0 + bs, width), std::min(y0 + bs, height), &counts[worker]);
        }
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(static_cast<double>(done) / (blocks_x * blocks_y)); })
               : std::function<bool(int)>());

  ClothMaterialFitSummary summary;
  for (const BlockCounts& c : counts) {
    summary.pixels_fitted += c.fitted;
    summary.pixels_sheen += c.sheen;
    summary.pixels_specular += c.specular;
    summary.pixels_too_few_samples += c.too_few;
    summary.blocks += c.blocks;
    summary.blocks_sheen += c.blocks_sheen;
    summary.blocks_specular += c.blocks_specular;
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!finished) {
    summary.SetCancelled("cancelled while fitting the cloth material");
  } else {
    summary.termination = Termination::kSuccess;
  }
  return summary;
}

}  // namespace scanbench
