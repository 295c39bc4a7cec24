#include "solver/bayer_normal_blend.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

// Fewest samples whose residual says anything about the noise (3 unknowns).
constexpr int kMinLightsForNoise = 4;

struct CellRowCounts {
  size_t blended = 0, kept = 0, compared = 0, lobe_replaced = 0;
  double weight_sum = 0;
};

struct GateRowCounts {
  size_t blocks = 0, blocks_open = 0, left_out = 0;
};

// The normal's angular variance per unit sample variance of a 3-unknown
// least-squares fit on the lights in front of `normal`: the trace of
// (L^T L)^-1 across the normal. 0 when fewer than 3 lights are in front or
// they do not constrain the normal.
double TangentialVarianceFactor(const LightField& field, int x, int y, const Eigen::Vector3d& normal,
                                std::vector<float>* dirs, std::vector<float>* intensities) {
  field.Evaluate(x, y, dirs->data(), intensities->data());
  Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
  int in_front = 0;
  for (int k = 0; k < field.num_lights(); ++k) {
    const Eigen::Vector3d l((*dirs)[3 * k], (*dirs)[3 * k + 1], (*dirs)[3 * k + 2]);
    if (!(l.dot(normal) > 0)) continue;
    gram += l * l.transpose();
    ++in_front;
  }
  if (in_front < 3) return 0;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(gram);
  if (!lu.isInvertible()) return 0;
  const Eigen::Matrix3d inverse = lu.inverse();
  return std::max(0.0, inverse.trace() - normal.dot(inverse * normal));
}

void CheckCellWeights(const BayerNormalBlendOptions& options, int width, int height, const char* where) {
  const int cell = options.cell_size;
  const int cell_rows = (height + cell - 1) / cell, cell_cols = (width + cell - 1) / cell;
  if (options.cell_weights != nullptr && !options.cell_weights->SameSize(cell_cols, cell_rows)) {
    throw std::invalid_argument(std::string(where) + ": cell_weights is " +
                                SizeText(options.cell_weights->width(), options.cell_weights->height()) +
                                "; it must be the cell grid's " + SizeText(cell_cols, cell_rows) + " (cells of " +
                                std::to_string(cell) + " px over " + SizeText(width, height) + ")");
  }
}

// A pixel the blend may weigh, as far as the demosaiced solve tells: solved,
// without a specular lobe.
bool Weighable(const PhotometricSolution& demosaiced, bool has_lobes, int x, int y) {
  return demosaiced.status(x, y) == static_cast<uint8_t>(PixelStatus::kSolved) &&
         !(has_lobes && demosaiced.specular_status(x, y) == static_cast<uint8_t>(SpecularStatus::kEstimated));
}

// Sums of a gate block or of one of its cells.
struct GateSums {
  double curvature = 0, sample_variance = 0;
  size_t curvature_terms = 0, variance_terms = 0;
  void Add(const GateSums& other) {
    curvature += other.curvature, sample_variance += other.sample_variance;
    curvature_terms += other.curvature_terms, variance_terms += other.variance_terms;
  }
  // Whether the mean curvature exceeds `ratio` times factor x the mean sample variance.
  bool Exceeds(double ratio, double factor) const {
    return curvature_terms > 0 && variance_terms > 0 &&
           curvature / curvature_terms > ratio * factor * sample_variance / variance_terms;
  }
};

// The gate of one block, pixels [x0, x1) x [y0, y1) in cells of `cell` px:
// whether the demosaiced normals vary beyond their noise from a pixel to the
// mean of its two neighbours (in the block), which is what a demosaic gets
// wrong; over the block (gate_ratio) or in one of its cells (gate_cell_ratio:
// a fibre crossing a smooth stretch). Undecided (no second difference, no
// noise figure, no lights in front) = open.
bool GateOpen(const BayerNormalBlendOptions& options, const PhotometricSolution& demosaiced, bool has_lobes,
              const LightField& field, int x0, int x1, int y0, int y1, std::vector<GateSums>* cell_sums,
              std::vector<float>* dirs, std::vector<float>* intensities) {
  if (options.gate_ratio == 0) return true;
  const int cell = options.cell_size;
  const uint8_t solved = static_cast<uint8_t>(PixelStatus::kSolved);
  const ImageF& normals = demosaiced.normal_in_table;
  auto second_difference = [&](int xa, int ya, int x, int y, int xb, int yb) {
    double sum = 0;
    for (int c = 0; c < 3; ++c) {
      const double d = double(normals(xa, ya, c)) + double(normals(xb, yb, c)) - 2.0 * double(normals(x, y, c));
      sum += d * d;
    }
    return sum;
  };
  cell_sums->assign((x1 - x0 + cell - 1) / cell, GateSums());
  Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) {
      if (!Weighable(demosaiced, has_lobes, x, y)) continue;
      GateSums& sums = (*cell_sums)[(x - x0) / cell];
      normal_sum += Eigen::Vector3d(normals(x, y, 0), normals(x, y, 1), normals(x, y, 2));
      if (x - 1 >= x0 && x + 1 < x1 && demosaiced.status(x - 1, y) == solved && demosaiced.status(x + 1, y) == solved) {
        sums.curvature += second_difference(x - 1, y, x, y, x + 1, y);
        ++sums.curvature_terms;
      }
      if (y - 1 >= y0 && y + 1 < y1 && demosaiced.status(x, y - 1) == solved && demosaiced.status(x, y + 1) == solved) {
        sums.curvature += second_difference(x, y - 1, x, y, x, y + 1);
        ++sums.curvature_terms;
      }
      const int lights = demosaiced.lights_used(x, y);
      if (lights >= kMinLightsForNoise) {
        const double residual = demosaiced.residual(x, y);
        sums.sample_variance += residual * residual * lights / (lights - 3);
        ++sums.variance_terms;
      }
    }
  }
  GateSums block;
  for (const GateSums& sums : *cell_sums) block.Add(sums);
  if (block.curvature_terms == 0 || block.variance_terms == 0 || !(normal_sum.squaredNorm() > 0)) return true;
  const double factor =
      TangentialVarianceFactor(field, (x0 + x1) / 2, (y0 + y1) / 2, normal_sum.normalized(), dirs, intensities);
  if (!(factor > 0)) return true;
  if (block.Exceeds(options.gate_ratio, factor)) return true;
  return std::any_of(cell_sums->begin(), cell_sums->end(),
                     [&](const GateSums& sums) { return sums.Exceeds(options.gate_cell_ratio, factor); });
}

// Throws std::invalid_argument naming `who` and the map unless `image` is the
// light field's size with `channels` channels.
template <typename Map>
void CheckMapShape(const char* who, const LightField& field, const Map& image, int channels, const char* name) {
  const int width = field.width(), height = field.height();
  if (!image.SameSize(width, height) || image.channels() != channels) {
    throw std::invalid_argument(std::string(who) + ": " + name + " is " + SizeText(image.width(), image.height()) +
                                " x " + std::to_string(image.channels()) + "; it must be the light field's " +
                                SizeText(width, height) + " x " + std::to_string(channels));
  }
}

void CheckMaps(const PhotometricSolution& bayer, const LightField& field, const PhotometricSolution& demosaiced) {
  auto check = [&](const auto& image, int channels, const char* name) {
    CheckMapShape("BlendBayerNormals", field, image, channels, name);
  };
  check(bayer.normal_in_table, 3, "bayer.normal_in_table");
  check(bayer.status, 1, "bayer.status");
  check(bayer.residual, 1, "bayer.residual");
  check(bayer.lights_used, 1, "bayer.lights_used");
  check(demosaiced.normal_in_table, 3, "demosaiced.normal_in_table");
  check(demosaiced.status, 1, "demosaiced.status");
  if (!demosaiced.specular_status.empty()) check(demosaiced.specular_status, 1, "demosaiced.specular_status");
}

}  // namespace

void BayerNormalBlendOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE("BayerNormalBlendOptions", "cell_size", cell_size, 2, 64);
  SCANBENCH_REQUIRE_GE_LE("BayerNormalBlendOptions", "num_threads", num_threads, 0, 256);
  SCANBENCH_REQUIRE_GE_LE("BayerNormalBlendOptions", "gate_block_cells", gate_block_cells, 1, 4096);
  SCANBENCH_REQUIRE_FINITE_GE("BayerNormalBlendOptions", "gate_ratio", gate_ratio, 0);
  SCANBENCH_REQUIRE_FINITE_GE("BayerNormalBlendOptions", "gate_cell_ratio", gate_cell_ratio, 0);
  if (cell_weights != nullptr) {
    if (cell_weights->channels() != 1) {
      throw FieldError("BayerNormalBlendOptions", "cell_weights channels", cell_weights->channels(), "must be 1");
    }
    for (size_t i = 0; i < cell_weights->size(); ++i) {
      const float w = cell_weights->data()[i];
      SCANBENCH_REQUIRE_GE_LE("BayerNormalBlendOptions", "cell_weights[" + std::to_string(i) + "]", w, 0, 1);
    }
  }
}

std::string BayerNormalBlendSummary::BriefReport() const {
  return "Bayer-domain normal blend: " + std::to_string(pixels_blended) + " px blended, " +
         std::to_string(pixels_kept) + " kept demosaiced, mean Bayer weight " + Fixed(mean_weight, 3) +
         (pixels_lobe_replaced > 0 ? ", " + std::to_string(pixels_lobe_replaced) + " lobe px from their raw samples"
                                   : std::string());
}

std::string BayerBlendCellsSummary::BriefReport() const {
  return "Bayer blend cells: " + std::to_string(blocks_open) + " of " + std::to_string(blocks) +
         " gate blocks solved in the Bayer domain, " + std::to_string(pixels_left_out) + " px left out";
}

BayerBlendCellsSummary SelectBayerBlendCells(const BayerNormalBlendOptions& options,
                                             const PhotometricSolution& demosaiced, const LightField& light_field,
                                             const ProgressCallback& progress) {
  options.Check();
  const int width = light_field.width(), height = light_field.height(), cell = options.cell_size;
  auto check = [&](const auto& image, int channels, const char* name) {
    CheckMapShape("SelectBayerBlendCells", light_field, image, channels, name);
  };
  check(demosaiced.normal_in_table, 3, "demosaiced.normal_in_table");
  check(demosaiced.status, 1, "demosaiced.status");
  check(demosaiced.lights_used, 1, "demosaiced.lights_used");
  check(demosaiced.residual, 1, "demosaiced.residual");
  if (!demosaiced.specular_status.empty()) check(demosaiced.specular_status, 1, "demosaiced.specular_status");
  CheckCellWeights(options, width, height, "SelectBayerBlendCells");
  const int cell_rows = (height + cell - 1) / cell, cell_cols = (width + cell - 1) / cell;
  const int block_cells = options.gate_block_cells;
  const bool has_lobes = !demosaiced.specular_status.empty();

  BayerBlendCellsSummary summary;
  summary.cells = ImageU8(cell_cols, cell_rows, 1, uint8_t{0});
  std::vector<GateRowCounts> counts(cell_rows);
  const bool finished = ParallelRows(cell_rows, options.num_threads, progress, 0, 1, [&](int cell_row) {
    std::vector<float> dirs(3 * light_field.num_lights()), intensities(3 * light_field.num_lights());
    std::vector<size_t> members(block_cells);
    std::vector<GateSums> cell_sums;
    const int y0 = cell_row * cell, y1 = std::min(height, y0 + cell);
    GateRowCounts& row_counts = counts[cell_row];
    for (int first = 0; first < cell_cols; first += block_cells) {
      const int last = std::min(cell_cols, first + block_cells);
      size_t block_members = 0;
      for (int cell_col = first; cell_col < last; ++cell_col) {
        const int x0 = cell_col * cell, x1 = std::min(width, x0 + cell);
        size_t& n = members[cell_col - first];
        n = 0;
        for (int y = y0; y < y1; ++y) {
          for (int x = x0; x < x1; ++x) n += Weighable(demosaiced, has_lobes, x, y);
        }
        block_members += n;
      }
      if (block_members == 0) continue;
      ++row_counts.blocks;
      const bool open = options.cell_weights != nullptr ||
                        GateOpen(options, demosaiced, has_lobes, light_field, first * cell,
                                 std::min(width, last * cell), y0, y1, &cell_sums, &dirs, &intensities);
      bool any = false;
      for (int cell_col = first; cell_col < last; ++cell_col) {
        const bool wanted = open && members[cell_col - first] > 0 &&
                            (options.cell_weights == nullptr || (*options.cell_weights)(cell_col, cell_row) > 0);
        summary.cells(cell_col, cell_row) = wanted ? 1 : 0;
        if (!wanted) row_counts.left_out += members[cell_col - first];
        any |= wanted;
      }
      row_counts.blocks_open += any;
    }
  });
  if (!finished) {
    summary.SetCancelled("cancelled choosing the cells of the Bayer-domain blend");
    return summary;
  }
  for (const GateRowCounts& row : counts) {
    summary.blocks += row.blocks;
    summary.blocks_open += row.blocks_open;
    summary.pixels_left_out += row.left_out;
  }
  summary.termination = Termination::kSuccess;
  return summary;
}

ImageU8 BayerBlendRegion(const ImageU8& cells, int cell_size, int width, int height) {
  if (cell_size < 1 || cells.channels() != 1 ||
      !cells.SameSize((width + cell_size - 1) / cell_size, (height + cell_size - 1) / cell_size)) {
    throw std::invalid_argument("BayerBlendRegion: cells of " + SizeText(cells.width(), cells.height()) +
                                " do not cover " + SizeText(width, height) + " px in cells of " +
                                std::to_string(cell_size) + " px");
  }
  ImageU8 region(width, height, 1, uint8_t{0});
  for (int y = 0; y < height; ++y) {
    const uint8_t* cell_row = cells.row(y / cell_size);
    uint8_t* out = region.row(y);
    for (int x = 0; x < width; ++x) out[x] = cell_row[x / cell_size];
  }
  return region;
}

BayerNormalBlendSummary BlendBayerNormals(const BayerNormalBlendOptions& options, const PhotometricSolution& bayer,
                                          const LightField& light_field, PhotometricSolution* demosaiced,
                                          const ProgressCallback& progress) {
  options.Check();
  if (demosaiced == nullptr) throw std::invalid_argument("BlendBayerNormals: demosaiced must not be null");
  CheckMaps(bayer, light_field, *demosaiced);
  const int width = light_field.width(), height = light_field.height(), cell = options.cell_size;
  const int cell_rows = (height + cell - 1) / cell, cell_cols = (width + cell - 1) / cell;
  CheckCellWeights(options, width, height, "BlendBayerNormals");
  const uint8_t solved = static_cast<uint8_t>(PixelStatus::kSolved);
  const bool has_lobes = !demosaiced->specular_status.empty();
  const bool with_lobe_bayer = options.lobe_bayer != nullptr && !options.lobe_bayer->status.empty();
  if (with_lobe_bayer) {
    auto check = [&](const auto& image, int channels, const char* name) {
      CheckMapShape("BlendBayerNormals", light_field, image, channels, name);
    };
    check(options.lobe_bayer->normal_in_table, 3, "lobe_bayer.normal_in_table");
    check(options.lobe_bayer->status, 1, "lobe_bayer.status");
    check(options.lobe_bayer->residual, 1, "lobe_bayer.residual");
    check(options.lobe_bayer->lights_used, 1, "lobe_bayer.lights_used");
  }
  std::vector<CellRowCounts> counts(cell_rows);

  BayerNormalBlendSummary summary;
  summary.cell_weights = ImageF(cell_cols, cell_rows, 1);
  const bool finished = ParallelRows(cell_rows, options.num_threads, progress, 0, 1, [&](int cell_row) {
    std::vector<float> dirs(3 * light_field.num_lights()), intensities(3 * light_field.num_lights());
    std::vector<int> members;
    const int y0 = cell_row * cell, y1 = std::min(height, y0 + cell);
    CellRowCounts& row_counts = counts[cell_row];
    for (int cell_col = 0; cell_col < cell_cols; ++cell_col) {
      const int x0 = cell_col * cell, x1 = std::min(width, x0 + cell);
      members.clear();
      double disagreement = 0, sample_variance = 0;
      Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
      for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
          if (demosaiced->status(x, y) != solved) continue;
          if (has_lobes && demosaiced->specular_status(x, y) == static_cast<uint8_t>(SpecularStatus::kEstimated)) {
            // A lobe pixel takes the shared lobe's re-solve from its own raw
            // samples outright, where there is one (the Bayer-domain solve
            // has no lobe). Weighed like the others, by its residual, it
            // kept too little of it: that residual is mostly the shared
            // shape's misfit to the pixel's fibres, which the demosaiced fit
            // shares, not noise (satin 0.860 deg against 0.829;
            // docs/solver.md).
            if (with_lobe_bayer && options.lobe_bayer->status(x, y) == solved &&
                options.lobe_bayer->lights_used(x, y) >= kMinLightsForNoise) {
              for (int c = 0; c < 3; ++c) {
                demosaiced->normal_in_table(x, y, c) = options.lobe_bayer->normal_in_table(x, y, c);
              }
              ++row_counts.lobe_replaced;
            } else {
              ++row_counts.kept;
            }
            continue;
          }
          const int lights = bayer.lights_used(x, y);
          if (bayer.status(x, y) != solved || lights < kMinLightsForNoise) {
            ++row_counts.kept;
            continue;
          }
          const Eigen::Vector3d nd(demosaiced->normal_in_table(x, y, 0), demosaiced->normal_in_table(x, y, 1),
                                   demosaiced->normal_in_table(x, y, 2));
          const Eigen::Vector3d nb(bayer.normal_in_table(x, y, 0), bayer.normal_in_table(x, y, 1),
                                   bayer.normal_in_table(x, y, 2));
          const double angle = std::atan2(nd.cross(nb).norm(), nd.dot(nb));
          const double residual = bayer.residual(x, y);
          disagreement += angle * angle;
          sample_variance += residual * residual * lights / (lights - 3);
          normal_sum += nd;
          members.push_back(y * width + x);
        }
      }
      if (members.empty()) continue;
      double weight = 0;
      if (options.cell_weights != nullptr) {
        weight = (*options.cell_weights)(cell_col, cell_row);
      } else if (disagreement > 0 && normal_sum.squaredNorm() > 0) {
        const double factor = TangentialVarianceFactor(light_field, (x0 + x1) / 2, (y0 + y1) / 2,
                                                       normal_sum.normalized(), &dirs, &intensities);
        weight = factor > 0 ? std::clamp(1.0 - factor * sample_variance / disagreement, 0.0, 1.0) : 0.0;
      }
      // As stored: given back (cell_weights) it blends bit for bit alike.
      weight = static_cast<float>(weight);
      summary.cell_weights(cell_col, cell_row) = static_cast<float>(weight);
      row_counts.compared += members.size();
      row_counts.weight_sum += weight * members.size();
      if (weight == 0) {
        row_counts.kept += members.size();
        continue;
      }
      row_counts.blended += members.size();
      for (const int index : members) {
        float* out = demosaiced->normal_in_table.data() + 3 * size_t(index);
        const float* own = bayer.normal_in_table.data() + 3 * size_t(index);
        Eigen::Vector3d mixed;
        for (int c = 0; c < 3; ++c) mixed[c] = weight * own[c] + (1 - weight) * out[c];
        mixed.normalize();
        for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(mixed[c]);
      }
    }
  });
  if (!finished) {
    summary.SetCancelled("cancelled blending the Bayer-domain normals");
    return summary;
  }
  size_t compared = 0;
  double weight_sum = 0;
  for (const CellRowCounts& row : counts) {
    summary.pixels_blended += row.blended;
    summary.pixels_kept += row.kept;
    summary.pixels_lobe_replaced += row.lobe_replaced;
    compared += row.compared;
    weight_sum += row.weight_sum;
  }
  summary.pixels_weighed = compared;
  summary.mean_weight = compared > 0 ? weight_sum / compared : 0;
  summary.termination = Termination::kSuccess;
  return summary;
}

}  // namespace scanbench
