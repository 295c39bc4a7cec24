#include "pipeline/depth_refinement.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "calibration/camera_model.h"
#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "maps/height_from_normals.h"

namespace scanbench {
namespace {

std::string Mm(double value) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << value;
  return out.str();
}

bool Solved(const PhotometricSolution& solution, size_t i) {
  return solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
}

// The value at `percent` of `values` (nearest rank); 0 when empty.
double Percentile(std::vector<double> values, double percent) {
  if (values.empty()) return 0;
  const size_t index =
      std::min(values.size() - 1, static_cast<size_t>(percent / 100.0 * double(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + index, values.end());
  return values[index];
}

std::vector<double> SolvedHeights(const PhotometricSolution& solution, const ImageF& height_mm) {
  std::vector<double> heights;
  for (size_t i = 0; i < height_mm.num_pixels(); ++i) {
    if (Solved(solution, i)) heights.push_back(height_mm.data()[i]);
  }
  return heights;
}


// The gradient of log t, t the distance along each pixel's camera ray to the
// surface (P = centre + t * ray), from the solved normals: perspective-exact.
// The tangent plane at P meets the neighbouring ray r' at t' = t (n.r) / (n.r'),
// so d(log t) = -(n.dr) / (n.r) per pixel step. Returned as "normals" for the
// height solver (x right, y up = towards image row 0) whose slope, with a
// 1 mm pixel, is that gradient: (-du, dv, 1) normalised (v counts rows down).
ImageF LogDistanceSlopesAsNormals(const PhotometricSolution& solution, const ImageF& rays) {
  const int width = rays.width(), height = rays.height();
  ImageF normals(width, height, 3);
  auto ray = [&](int x, int y) {
    const float* r = &rays.data()[3 * (static_cast<size_t>(y) * width + x)];
    return Eigen::Vector3d(r[0], r[1], r[2]);
  };
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      const float* m = &solution.normal_in_table.data()[3 * i];
      const Eigen::Vector3d n(m[0], m[1], m[2]);
      const int x0 = std::max(0, x - 1), x1 = std::min(width - 1, x + 1);
      const int y0 = std::max(0, y - 1), y1 = std::min(height - 1, y + 1);
      const double n_r = n.dot(ray(x, y));
      double du = 0, dv = 0;
      // A surface seen edge-on (n.r -> 0) has no finite slope: left to the solver's clamp.
      if (n_r < -1e-6) {
        du = -n.dot(ray(x1, y) - ray(x0, y)) / (double(x1 - x0) * n_r);
        dv = -n.dot(ray(x, y1) - ray(x, y0)) / (double(y1 - y0) * n_r);
      }
      const Eigen::Vector3d as_normal = Eigen::Vector3d(-du, dv, 1.0).normalized();
      for (int c = 0; c < 3; ++c) normals.data()[3 * i + c] = static_cast<float>(as_normal[c]);
    }
  }
  return normals;
}

struct Movement {
  double max_mm = 0, mean_mm = 0, p99_mm = 0;
};

Movement SurfaceMovement(const PhotometricSolution& solution, const ImageF& before, const ImageF& after) {
  Movement movement;
  std::vector<double> moves;
  for (size_t i = 0; i < before.num_pixels(); ++i) {
    if (!Solved(solution, i)) continue;
    const Eigen::Vector3f a(&before.data()[3 * i]), b(&after.data()[3 * i]);
    const double d = (b - a).norm();
    movement.max_mm = std::max(movement.max_mm, d);
    movement.mean_mm += d;
    moves.push_back(d);
  }
  if (!moves.empty()) movement.mean_mm /= double(moves.size());
  movement.p99_mm = Percentile(std::move(moves), 99);
  return movement;
}

}  // namespace

void DepthRefinementOptions::Check() const {
  constexpr const char* kWhere = "DepthRefinementOptions";
  SCANBENCH_REQUIRE_GE_LE(kWhere, "max_iterations", max_iterations, 1, 20);
  SCANBENCH_REQUIRE_FINITE_GT(kWhere, "tolerance_mm", tolerance_mm, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kWhere, "min_height_range_mm", min_height_range_mm, 0);
  SCANBENCH_REQUIRE_GE_LE(kWhere, "anchor_percentile", anchor_percentile, 0, 50);
  SCANBENCH_REQUIRE_GE_LE(kWhere, "shadow_edge_radius_px", shadow_edge_radius_px, 0, 10);
  SCANBENCH_REQUIRE_GE_LE(kWhere, "shadow_edge_level", shadow_edge_level, 0, 1);
}

std::string DepthRefinementSummary::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "Depth refinement: " << TerminationName(termination) << ", "
      << iterations.size() << " iteration(s)";
  if (!iterations.empty()) {
    out << ", surface moved max";
    for (size_t i = 0; i < iterations.size(); ++i) out << (i ? "/" : " ") << iterations[i].max_move_mm;
    out << " mm, p99";
    for (size_t i = 0; i < iterations.size(); ++i) out << (i ? "/" : " ") << iterations[i].p99_move_mm;
    out << " mm, mean";
    for (size_t i = 0; i < iterations.size(); ++i) out << (i ? "/" : " ") << iterations[i].mean_move_mm;
    out << " mm";
    if (iterations.front().scale_vs_percentile > 0) {
      out << std::setprecision(4) << ", distance scale chosen by the residual (x the anchor percentile's)";
      for (size_t i = 0; i < iterations.size(); ++i) out << (i ? "/" : " ") << iterations[i].scale_vs_percentile;
      out << std::setprecision(2);
    }
  }
  if (decision_block_px > 0) {
    out << "; first-pass height range " << first_height_range_mm << " mm (" << decision_block_px << " px blocks)";
  }
  if (shadow_edge_samples > 0) out << "; " << shadow_edge_samples << " shadow-edge samples left out";
  if (shadow_edge_kept_pixels > 0) {
    out << " (" << shadow_edge_kept_pixels << " px the masks left unsolvable solved with them)";
  }
  out << "; stopped: " << stop_reason;
  if (!message.empty() && termination != Termination::kSuccess) out << " (" << message << ")";
  out << ", " << Significant(seconds) << " s";
  return out.str();
}

std::string DepthRefinementOptions::ReportJson() const {
  const nlohmann::json json = {{"enabled", enabled},
                               {"max_iterations", max_iterations},
                               {"tolerance_mm", tolerance_mm},
                               {"min_height_range_mm", min_height_range_mm},
                               {"anchor_percentile", anchor_percentile},
                               {"shadow_edge_radius_px", shadow_edge_radius_px},
                               {"shadow_edge_level", shadow_edge_level}};
  // Only when set: `scanbench solve` never sets it, and its inputs'
  // fingerprints (which hold these options) stay what they were.
  if (anchor_by_residual) {
    nlohmann::json with_fit = json;
    with_fit["anchor_by_residual"] = true;
    return with_fit.dump();
  }
  return json.dump();
}

std::string DepthRefinementSummary::ReportJson(const DepthRefinementOptions& options) const {
  nlohmann::json list = nlohmann::json::array();
  for (const DepthIteration& it : iterations) {
    list.push_back({{"max_move_mm", it.max_move_mm},
                    {"mean_move_mm", it.mean_move_mm},
                    {"p99_move_mm", it.p99_move_mm},
                    {"height_range_mm", it.height_range_mm},
                    {"seconds", it.seconds}});
    if (it.scale_vs_percentile > 0) list.back()["scale_vs_percentile"] = it.scale_vs_percentile;
  }
  const nlohmann::json json = {{"enabled", options.enabled},
                               {"refined", refined},
                               {"iterations", list},
                               {"first_height_range_mm", first_height_range_mm},
                               {"decision_block_px", decision_block_px},
                               {"shadow_edge_samples", shadow_edge_samples},
                               {"shadow_edge_kept_pixels", shadow_edge_kept_pixels},
                               {"stop_reason", stop_reason},
                               {"seconds", seconds},
                               {"message", BriefReport()}};
  return json.dump();
}

ImageF AnchoredHeightFromSolution(const DepthRefinementOptions& options, const PhotometricSolution& solution,
                                  const CameraGeometry& camera, const DepthScaleChooser& choose_scale,
                                  double* chosen_vs_percentile) {
  const ImageF rays = ComputeRayDirectionsInTable(camera);
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  HeightFromNormalsOptions height_options;
  height_options.method = HeightFromNormalsOptions::Method::kDctPoisson;
  height_options.mm_per_pixel = 1.0;  // the slopes are of log t per pixel
  // A draped sample's edge rises tens of mm within a few mm: slopes up to 50
  // (mm/mm) at the table's pixel footprint and distance, far steeper than the
  // maps' default clamp, which would flatten the whole sample by the difference.
  height_options.max_slope = 50 * TablePixelFootprintMm(camera) / centre.z();
  ImageU8 solved(solution.status.width(), solution.status.height(), 1);
  for (size_t i = 0; i < solved.num_pixels(); ++i) solved.data()[i] = Solved(solution, i);
  ImageF log_t;
  const HeightFromNormalsSummary summary =
      HeightFromNormals(height_options, LogDistanceSlopesAsNormals(solution, rays), &solved, &log_t);
  RequireSuccess(summary, "depth refinement: height from normals");
  // log t is known up to a constant, t up to a factor s. With t_table the
  // distance to the table along the same ray, a point's height is
  // centre.z * (1 - s q), q = exp(log t) / t_table: the lowest solved pixels
  // (the table around the sample, or the folds resting on it) have the
  // highest q, and s puts the anchor percentile of them on the table.
  ImageF q(log_t.width(), log_t.height(), 1);
  for (size_t i = 0; i < q.num_pixels(); ++i) {
    const double ray_z = rays.data()[3 * i + 2];
    const double t_table = ray_z < 0 ? -centre.z() / ray_z : 1.0;
    q.data()[i] = static_cast<float>(std::exp(double(log_t.data()[i])) / t_table);
  }
  const double q_anchor = Percentile(SolvedHeights(solution, q), 100.0 - options.anchor_percentile);
  // The distance along a ray is t = t_table q f; the percentile's f = 1 / q_anchor.
  const double percentile_factor = 1.0 / q_anchor;
  const double factor = choose_scale ? choose_scale(solution, q, percentile_factor) : percentile_factor;
  if (chosen_vs_percentile) *chosen_vs_percentile = factor / percentile_factor;
  ImageF height_mm(q.width(), q.height(), 1);
  for (size_t i = 0; i < q.num_pixels(); ++i) {
    height_mm.data()[i] = static_cast<float>(centre.z() * (1.0 - q.data()[i] * factor));
  }
  return height_mm;
}


double SolvedHeightRangeMm(const PhotometricSolution& solution, const ImageF& height_mm) {
  const std::vector<double> heights = SolvedHeights(solution, height_mm);
  return Percentile(heights, 99) - Percentile(heights, 1);
}

DepthDecisionBlocks::DepthDecisionBlocks(int width, int height, int block_px)
    : width_(width), height_(height), block_px_(block_px) {
  if (width < 1 || height < 1) {
    throw std::invalid_argument("DepthDecisionBlocks: " + std::to_string(width) + "x" + std::to_string(height) +
                                " must be at least 1x1");
  }
  if (block_px_ == 0) {
    constexpr int kMinBlocks = 16;
    block_px_ = width / kDepthDecisionBlockPx >= kMinBlocks && height / kDepthDecisionBlockPx >= kMinBlocks
                    ? kDepthDecisionBlockPx
                    : 1;
  }
  if (block_px_ < 1) {
    throw std::invalid_argument("BlockMeanSolution: block_px " + std::to_string(block_px_) + " must be >= 1");
  }
  const int block_columns = width / block_px_, block_rows = height / block_px_;
  if (block_px_ == 1) {
    // Full size: the first pass's normals and status as they are.
    blocks_.normal_in_table = ImageF(width, height, 3);
    blocks_.status = ImageU8(width, height, 1);
    return;
  }
  blocks_.normal_in_table = ImageF(block_columns, block_rows, 3);
  blocks_.status = ImageU8(block_columns, block_rows, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  sums_.assign(block_columns, Eigen::Vector3d::Zero());
  solved_.assign(block_columns, 0);
}

void DepthDecisionBlocks::AddRows(const PhotometricSolution& band, int num_threads) {
  const int rows = band.status.height();
  if (band.status.width() != width_ || rows > height_ - rows_added_ || !band.normal_in_table.SameSize(band.status) ||
      band.normal_in_table.channels() != 3) {
    throw std::invalid_argument("DepthDecisionBlocks: rows of " + ShapeText(band.status) + " (normals " +
                                ShapeText(band.normal_in_table) + ") after " + std::to_string(rows_added_) +
                                " rows of " + std::to_string(width_) + "x" + std::to_string(height_));
  }
  const int y0 = rows_added_;
  rows_added_ += rows;
  if (block_px_ == 1) {
    std::copy(band.normal_in_table.data(), band.normal_in_table.data() + band.normal_in_table.size(),
              blocks_.normal_in_table.row(y0));
    std::copy(band.status.data(), band.status.data() + band.status.size(), blocks_.status.row(y0));
    return;
  }
  // Per block column (in parallel), its pixels row by row, left to right: the
  // order of BlockMeanSolution's sums, whatever the bands.
  const int whole_rows = blocks_.status.height() * block_px_;
  const int min_solved = (block_px_ * block_px_ + 1) / 2;
  ParallelRows(blocks_.status.width(), num_threads, {}, 0, 1, [&](int bx) {
    Eigen::Vector3d& sum = sums_[bx];
    int& solved = solved_[bx];
    for (int r = 0; r < rows && y0 + r < whole_rows; ++r) {
      const int y = y0 + r;
      for (int x = bx * block_px_; x < (bx + 1) * block_px_; ++x) {
        const size_t i = static_cast<size_t>(r) * width_ + x;
        if (!Solved(band, i)) continue;
        const float* n = &band.normal_in_table.data()[3 * i];
        sum += Eigen::Vector3d(n[0], n[1], n[2]);
        ++solved;
      }
      if ((y + 1) % block_px_ != 0) continue;
      const int by = y / block_px_;
      float* out = &blocks_.normal_in_table(bx, by);
      const bool usable = solved >= min_solved && sum.norm() > 0;
      const Eigen::Vector3d mean = usable ? sum.normalized() : Eigen::Vector3d::UnitZ();
      for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(mean[c]);
      if (usable) blocks_.status(bx, by) = static_cast<uint8_t>(PixelStatus::kSolved);
      sum = Eigen::Vector3d::Zero();
      solved = 0;
    }
  });
}

const PhotometricSolution& DepthDecisionBlocks::blocks() const {
  if (rows_added_ != height_) {
    throw std::logic_error("DepthDecisionBlocks: " + std::to_string(rows_added_) + " of " + std::to_string(height_) +
                           " rows added");
  }
  return blocks_;
}

PhotometricSolution BlockMeanSolution(const PhotometricSolution& solution, int block_px, int num_threads) {
  if (block_px < 1) throw std::invalid_argument("BlockMeanSolution: block_px " + std::to_string(block_px) + " must be >= 1");
  if (block_px == 1) return solution;
  DepthDecisionBlocks blocks(solution.status.width(), solution.status.height(), block_px);
  blocks.AddRows(solution, num_threads);
  return blocks.blocks();
}

double DecisionHeightRangeMm(const DepthRefinementOptions& options, const DepthDecisionBlocks& blocks,
                             const CameraGeometry& camera) {
  const int block_px = blocks.block_px();
  const PhotometricSolution& solution = blocks.blocks();
  const CameraGeometry& integrated = block_px == 1 ? camera : BlockCamera(camera, block_px);
  return SolvedHeightRangeMm(solution, AnchoredHeightFromSolution(options, solution, integrated));
}

double DecisionHeightRangeMm(const DepthRefinementOptions& options, const PhotometricSolution& solution,
                             const CameraGeometry& camera, int* block_px_used) {
  DepthDecisionBlocks blocks(solution.status.width(), solution.status.height());
  blocks.AddRows(solution);
  if (block_px_used) *block_px_used = blocks.block_px();
  return DecisionHeightRangeMm(options, blocks, camera);
}

namespace {

// The decision: a summary with the first pass's range, and *kept (the stop
// reason set, the loop not to run) or not.
DepthRefinementSummary Decide(const DepthRefinementOptions& options, const DepthDecisionBlocks& blocks,
                              const CameraGeometry& camera, bool* kept) {
  DepthRefinementSummary summary;
  summary.termination = Termination::kSuccess;
  *kept = true;
  if (!options.enabled) {
    summary.stop_reason = "disabled (the table plane only)";
    return summary;
  }
  // The decision on block means: at 16 MP the full-size integration it
  // replaces took most of this stage on a flat sample (docs/solver.md).
  summary.first_height_range_mm = DecisionHeightRangeMm(options, blocks, camera);
  summary.decision_block_px = blocks.block_px();
  *kept = summary.first_height_range_mm <= options.min_height_range_mm;
  if (*kept) {
    summary.stop_reason = "height range " + Mm(summary.first_height_range_mm) + " mm (" +
                          std::to_string(summary.decision_block_px) + " px blocks) is not above min_height_range_mm " +
                          Mm(options.min_height_range_mm) + " mm: the table plane is kept";
  }
  return summary;
}

}  // namespace

std::optional<DepthRefinementSummary> TablePlaneKept(const DepthRefinementOptions& options,
                                                     const DepthDecisionBlocks& blocks, const CameraGeometry& camera) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  bool kept = false;
  DepthRefinementSummary summary = Decide(options, blocks, camera, &kept);
  if (!kept) return std::nullopt;
  summary.seconds = SecondsSince(start);
  return summary;
}

ImageF SurfacePointsAtHeight(const CameraGeometry& camera, const ImageF& height_mm) {
  const ImageF rays = ComputeRayDirectionsInTable(camera);
  if (rays.width() != height_mm.width() || rays.height() != height_mm.height()) {
    throw std::invalid_argument("SurfacePointsAtHeight: height map " + std::to_string(height_mm.width()) + "x" +
                                std::to_string(height_mm.height()) + " differs from the camera's " +
                                std::to_string(rays.width()) + "x" + std::to_string(rays.height()));
  }
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  ImageF points(rays.width(), rays.height(), 3);
  for (size_t i = 0; i < points.num_pixels(); ++i) {
    const Eigen::Vector3d ray(rays.data()[3 * i], rays.data()[3 * i + 1], rays.data()[3 * i + 2]);
    // Heights at or above the camera cannot be on its ray in front of it: keep
    // the point below the camera (the height map is a smooth estimate).
    const double z = std::min<double>(height_mm.data()[i], centre.z() - 1.0);
    const double t = ray.z() < 0 ? (z - centre.z()) / ray.z() : 0.0;
    const Eigen::Vector3d point = centre + t * ray;
    for (int c = 0; c < 3; ++c) points.data()[3 * i + c] = static_cast<float>(point[c]);
  }
  return points;
}

std::vector<ImageU8> ShadowEdgeSampleMasks(const DepthRefinementOptions& options,
                                           const PhotometricSolverOptions& solver,
                                           const PhotometricSolverInput& input, size_t* num_left_out) {
  options.Check();
  const int r = options.shadow_edge_radius_px;
  const size_t num_lights = input.images.size();
  std::vector<ImageU8> masks;
  for (size_t k = 0; k < num_lights; ++k) {
    const ImageF& image = *input.images[k];
    if (image.channels() != 3) {
      throw std::invalid_argument("ShadowEdgeSampleMasks: image " + std::to_string(k) + " has " +
                                  std::to_string(image.channels()) + " channels, needs 3 (RGB)");
    }
    ImageU8 mask(image.width(), image.height(), 1);
    if (k < input.sample_valid.size() && input.sample_valid[k] != nullptr) {
      mask = *input.sample_valid[k];
    } else {
      std::fill(mask.data(), mask.data() + mask.num_pixels(), uint8_t{1});
    }
    masks.push_back(std::move(mask));
  }
  if (r == 0 || num_lights == 0) return masks;
  const int width = input.images[0]->width(), height = input.images[0]->height();
  const std::array<double, 3>& w = solver.luminance_weights;
  auto luminance = [&](size_t k, size_t i) {
    const float* rgb = &input.images[k]->data()[3 * i];
    return w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2];
  };
  std::vector<ImageU8> left_out(num_lights);
  for (size_t k = 0; k < num_lights; ++k) {
    // Shadowed samples, then a square dilation by r (rows, then columns).
    ImageU8 dark(width, height, 1), near_in_row(width, height, 1);
    left_out[k] = ImageU8(width, height, 1);
    ParallelRows(height, solver.num_threads, {}, 0, 1, [&](int y) {
      uint8_t* d = dark.row(y);
      for (int x = 0; x < width; ++x) {
        // false for NaN: an unusable sample is not a shadow
        d[x] = luminance(k, static_cast<size_t>(y) * width + x) <= options.shadow_edge_level;
      }
      uint8_t* n = near_in_row.row(y);
      int count = 0;  // shadowed samples in [x - r, x + r]
      for (int x = 0; x < std::min(r, width); ++x) count += d[x];
      for (int x = 0; x < width; ++x) {
        if (x + r < width) count += d[x + r];
        if (x - r - 1 >= 0) count -= d[x - r - 1];
        n[x] = count > 0;
      }
    });
    ParallelRows(height, solver.num_threads, {}, 0, 1, [&](int y) {
      const int y0 = std::max(0, y - r), y1 = std::min(height - 1, y + r);
      const uint8_t* d = dark.row(y);
      uint8_t* m = masks[k].row(y);
      uint8_t* out = left_out[k].row(y);
      for (int x = 0; x < width; ++x) {
        if (d[x] || !m[x]) continue;
        for (int yy = y0; yy <= y1; ++yy) {
          if (near_in_row.row(yy)[x]) {
            m[x] = 0;
            out[x] = 1;
            break;
          }
        }
      }
    });
  }
  // A pixel left with fewer lit samples than the solver needs keeps its edge
  // samples: a solve from them beats none.
  std::vector<size_t> row_left_out(height, 0);
  ParallelRows(height, solver.num_threads, {}, 0, 1, [&](int y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = static_cast<size_t>(y) * width + x;
      int lit = 0, removed = 0;
      for (size_t k = 0; k < num_lights; ++k) {
        lit += masks[k].data()[i] != 0 && luminance(k, i) > solver.min_sample_value;
        removed += left_out[k].data()[i];
      }
      if (removed == 0) continue;
      if (lit >= solver.min_lights) {
        row_left_out[y] += removed;
        continue;
      }
      for (size_t k = 0; k < num_lights; ++k) {
        if (left_out[k].data()[i]) masks[k].data()[i] = 1;
      }
    }
  });
  if (num_left_out) {
    for (size_t n : row_left_out) *num_left_out += n;
  }
  return masks;
}

DepthScaleChooser ResidualScaleChooser(const PhotometricSolverOptions& solver, const PhotometricSolverInput& input,
                                       const std::vector<ImageU8>* masks, const std::vector<PointLight>& lights,
                                       const CameraGeometry& camera) {
  const size_t num_lights = input.images.size();
  if (num_lights == 0 || num_lights != lights.size() || (masks && masks->size() != num_lights)) {
    throw std::invalid_argument("ResidualScaleChooser: " + std::to_string(num_lights) + " images, " +
                                std::to_string(lights.size()) + " lights" +
                                (masks ? ", " + std::to_string(masks->size()) + " masks" : std::string()) +
                                "; one of each per light required");
  }
  return [&solver, &input, masks, &lights, &camera, num_lights](const PhotometricSolution& solution, const ImageF& q,
                                                                 double percentile_factor) {
    const int width = q.width(), height = q.height();
    size_t num_solved = 0;
    for (size_t i = 0; i < q.num_pixels(); ++i) num_solved += Solved(solution, i);
    // A regular grid of the solved pixels, at most kMaxPixels of them: the
    // median below needs many pixels, not all.
    constexpr size_t kMaxPixels = 16384;
    constexpr double kQuantile = 0.5;  // the median
    constexpr int kMinPixels = 64;
    const int step = std::max(1, static_cast<int>(std::ceil(std::sqrt(double(num_solved) / kMaxPixels))));
    const std::array<double, 3>& w = solver.luminance_weights;
    struct Pixel {
      Eigen::Vector3f table_point;
      float q = 0;
    };
    std::vector<Pixel> pixels;
    std::vector<float> samples;  // per pixel and light: RGB, or NaN when unusable
    std::vector<float> row_points;
    for (int y = 0; y < height; y += step) {
      const int count = (width + step - 1) / step;
      row_points.resize(3 * static_cast<size_t>(count));
      ComputeTablePointsOfRow(camera, 0, step, y, count, row_points.data());
      for (int j = 0; j < count; ++j) {
        const size_t i = static_cast<size_t>(y) * width + static_cast<size_t>(j) * step;
        if (!Solved(solution, i)) continue;
        // Pixels the solve found a lobe or a sheen at: their residual is the
        // material's, not the light field's.
        if (!solution.specular_status.empty() &&
            solution.specular_status.data()[i] == static_cast<uint8_t>(SpecularStatus::kEstimated)) {
          continue;
        }
        if (!solution.coherent_sheen.empty() && solution.coherent_sheen.data()[i] != 0) continue;
        int usable = 0;
        const size_t first = samples.size();
        for (size_t k = 0; k < num_lights; ++k) {
          const float* rgb = &input.images[k]->data()[3 * i];
          const double luminance = w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2];
          bool ok = luminance > solver.min_sample_value;  // as the solver: the shadow level, NaN out
          if (k < input.sample_valid.size() && input.sample_valid[k] != nullptr) {
            ok = ok && input.sample_valid[k]->data()[i] != 0;
          }
          if (masks) ok = ok && (*masks)[k].data()[i] != 0;
          usable += ok;
          for (int c = 0; c < 3; ++c) samples.push_back(ok ? rgb[c] : std::numeric_limits<float>::quiet_NaN());
        }
        // Three samples fit any normal exactly: a residual needs a fourth.
        if (usable < 4) {
          samples.resize(first);
          continue;
        }
        pixels.push_back({Eigen::Vector3f(&row_points[3 * j]), q.data()[i]});
      }
    }
    if (pixels.size() < static_cast<size_t>(kMinPixels)) return percentile_factor;
    const Eigen::Vector3d centre = CameraCentreInTable(camera);
    const int count = static_cast<int>(pixels.size());
    // The median over the pixels of the relative RMS residual of the
    // Lambertian least-squares fit, the surface points at factor f.
    const auto median_residual = [&](double f) {
      ImageF points(count, 1, 3);
      for (int p = 0; p < count; ++p) {
        const Eigen::Vector3d table = pixels[p].table_point.cast<double>();
        const Eigen::Vector3d point = centre + f * double(pixels[p].q) * (table - centre);
        for (int c = 0; c < 3; ++c) points.data()[3 * p + c] = static_cast<float>(point[c]);
      }
      const PointLightField field(lights, std::move(points), centre);
      std::vector<float> dirs(3 * num_lights * static_cast<size_t>(count)), rgb(dirs.size());
      field.EvaluateSpan(0, 0, count, count, dirs.data(), rgb.data());
      std::vector<double> residuals(count, std::numeric_limits<double>::infinity());
      // Sample k of pixel p divided as the solver divides it (each channel by
      // the light's, then luminance); false when unusable.
      const auto sample_of = [&](int p, size_t k, Eigen::Vector3d* dir, double* value) {
        const float* sample = &samples[(static_cast<size_t>(p) * num_lights + k) * 3];
        if (std::isnan(sample[0])) return false;
        Eigen::Vector3d intensity;
        for (int c = 0; c < 3; ++c) {
          (*dir)[c] = dirs[(3 * k + c) * static_cast<size_t>(count) + p];
          intensity[c] = rgb[(3 * k + c) * static_cast<size_t>(count) + p];
        }
        if (!(intensity.minCoeff() > 0)) return false;
        *value = w[0] * sample[0] / intensity[0] + w[1] * sample[1] / intensity[1] + w[2] * sample[2] / intensity[2];
        return true;
      };
      constexpr int kChunk = 256;
      ParallelRows((count + kChunk - 1) / kChunk, solver.num_threads, {}, 0, 1, [&](int chunk) {
        for (int p = chunk * kChunk; p < std::min(count, (chunk + 1) * kChunk); ++p) {
          Eigen::Matrix3d gram = Eigen::Matrix3d::Zero();
          Eigen::Vector3d rhs = Eigen::Vector3d::Zero(), dir;
          double value = 0;
          int n = 0;
          for (size_t k = 0; k < num_lights; ++k) {
            if (!sample_of(p, k, &dir, &value)) continue;
            gram += dir * dir.transpose();
            rhs += dir * value;
            ++n;
          }
          if (n < 4) continue;
          const Eigen::LDLT<Eigen::Matrix3d> ldlt(gram);
          if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-9 * gram.trace())) continue;
          const Eigen::Vector3d scaled_normal = ldlt.solve(rhs);
          const double albedo = scaled_normal.norm();
          if (!(albedo > 0)) continue;
          double sum = 0;
          for (size_t k = 0; k < num_lights; ++k) {
            if (sample_of(p, k, &dir, &value)) sum += (dir.dot(scaled_normal) - value) * (dir.dot(scaled_normal) - value);
          }
          residuals[p] = std::sqrt(sum / n) / albedo;
        }
      });
      const size_t rank = static_cast<size_t>(kQuantile * double(residuals.size() - 1));
      std::nth_element(residuals.begin(), residuals.begin() + rank, residuals.end());
      return residuals[rank];
    };
    // A grid over +-25 % of the percentile's factor (log spaced), then a
    // golden-section search between the best point's neighbours.
    constexpr double kRange = 0.25, kStep = 0.02, kTolerance = 5e-4;
    const double log_f0 = std::log(percentile_factor);
    double best_u = 0, best = std::numeric_limits<double>::infinity();
    for (double u = -kRange; u <= kRange + 1e-12; u += kStep) {
      const double value = median_residual(std::exp(log_f0 + u));
      if (value < best) {
        best = value;
        best_u = u;
      }
    }
    if (!std::isfinite(best)) return percentile_factor;
    constexpr double kGolden = 0.6180339887498949;
    double a = best_u - kStep, b = best_u + kStep;
    double c = b - kGolden * (b - a), d = a + kGolden * (b - a);
    double fc = median_residual(std::exp(log_f0 + c)), fd = median_residual(std::exp(log_f0 + d));
    while (b - a > kTolerance) {
      if (fc < fd) {
        b = d, d = c, fd = fc;
        c = b - kGolden * (b - a);
        fc = median_residual(std::exp(log_f0 + c));
      } else {
        a = c, c = d, fc = fd;
        d = a + kGolden * (b - a);
        fd = median_residual(std::exp(log_f0 + d));
      }
    }
    const double u = 0.5 * (a + b);
    return median_residual(std::exp(log_f0 + u)) <= best ? std::exp(log_f0 + u) : std::exp(log_f0 + best_u);
  };
}

namespace {

// Pixel i of `from` into `to`, every map both hold at the same shape.
void CopyPixel(const PhotometricSolution& from, size_t i, PhotometricSolution* to) {
  const auto copy = [i](const auto& source, auto& target) {
    if (source.empty() || target.empty() || source.channels() != target.channels() ||
        source.num_pixels() != target.num_pixels()) {
      return;
    }
    const int c = source.channels();
    std::copy(source.data() + i * c, source.data() + (i + 1) * c, target.data() + i * c);
  };
  copy(from.normal_in_table, to->normal_in_table);
  copy(from.albedo, to->albedo);
  copy(from.status, to->status);
  copy(from.lights_used, to->lights_used);
  copy(from.condition_number, to->condition_number);
  copy(from.residual, to->residual);
  copy(from.solve_path, to->solve_path);
  copy(from.specular, to->specular);
  copy(from.specular_status, to->specular_status);
  copy(from.coherent_sheen, to->coherent_sheen);
}

}  // namespace

size_t SolveWithEdgeSamplesWhereMasksFail(const PhotometricSolverOptions& solver, const PhotometricSolverInput& input,
                                          const std::vector<ImageU8>& masks, PhotometricSolution* solution,
                                          PhotometricSolverSummary* summary) {
  if (masks.size() != input.images.size()) {
    throw std::invalid_argument("SolveWithEdgeSamplesWhereMasksFail: " + std::to_string(masks.size()) +
                                " masks for " + std::to_string(input.images.size()) + " images");
  }
  const ImageU8& status = solution->status;
  ImageU8 retry(status.width(), status.height(), 1, 0);
  size_t num_retry = 0;
  for (size_t i = 0; i < status.num_pixels(); ++i) {
    const auto s = static_cast<PixelStatus>(status.data()[i]);
    if (s == PixelStatus::kSolved || s == PixelStatus::kOutsideRegion) continue;
    bool lost_samples = false;
    for (size_t k = 0; k < masks.size() && !lost_samples; ++k) {
      const bool usable = k >= input.sample_valid.size() || input.sample_valid[k] == nullptr ||
                          input.sample_valid[k]->data()[i] != 0;
      lost_samples = usable && masks[k].data()[i] == 0;
    }
    if (lost_samples) {
      retry.data()[i] = 1;
      ++num_retry;
    }
  }
  if (num_retry == 0) return 0;
  PhotometricSolverInput retry_input = input;
  retry_input.region = &retry;
  retry_input.lobe_mosaics = nullptr;
  retry_input.lobe_bayer = nullptr;
  PhotometricSolution fallback;
  const PhotometricSolverSummary fallback_summary = SolvePhotometricStereo(solver, retry_input, &fallback);
  RequireSuccess(fallback_summary, "depth refinement: re-solve with the shadow-edge samples");
  size_t taken = 0;
  const auto recount = [](auto& counts, int value, int delta) {
    const int index = std::min<int>(value, static_cast<int>(counts.size()) - 1);
    counts[index] = static_cast<size_t>(static_cast<long long>(counts[index]) + delta);
  };
  for (size_t i = 0; i < status.num_pixels(); ++i) {
    if (!retry.data()[i] || fallback.status.data()[i] != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
    recount(summary->pixels_by_status, solution->status.data()[i], -1);
    recount(summary->pixels_by_path, solution->solve_path.data()[i], -1);
    if (!solution->specular_status.empty() && !fallback.specular_status.empty()) {
      recount(summary->pixels_by_specular, solution->specular_status.data()[i], -1);
      recount(summary->pixels_by_specular, fallback.specular_status.data()[i], +1);
    }
    CopyPixel(fallback, i, solution);
    recount(summary->pixels_by_status, solution->status.data()[i], +1);
    recount(summary->pixels_by_path, solution->solve_path.data()[i], +1);
    ++taken;
  }
  return taken;
}

DepthRefinementSummary RefineDepth(const DepthRefinementOptions& options, const PhotometricSolverOptions& solver,
                                   const PhotometricSolverInput& input, const std::vector<PointLight>& lights,
                                   const CameraGeometry& camera, PhotometricSolution* solution,
                                   ImageF* surface_points_in_table, const ProgressCallback& progress) {
  // The masks depend on the frames only: made at the first re-solve, kept for the others.
  std::vector<ImageU8> shadow_edge_masks;
  size_t shadow_edge_samples = 0, edge_kept_pixels = 0;
  bool masks_made = false;
  const DepthResolve resolve = [&](const LightField& moved_field, PhotometricSolution* resolved,
                                   const ProgressCallback& resolve_progress, size_t* edge_samples) {
    if (!masks_made && options.shadow_edge_radius_px > 0) {
      shadow_edge_masks = ShadowEdgeSampleMasks(options, solver, input, &shadow_edge_samples);
    }
    masks_made = true;
    PhotometricSolverInput moved_input = input;
    moved_input.light_field = &moved_field;
    if (!shadow_edge_masks.empty()) {
      moved_input.sample_valid.clear();
      for (const ImageU8& mask : shadow_edge_masks) moved_input.sample_valid.push_back(&mask);
    }
    *edge_samples = shadow_edge_samples;
    PhotometricSolverSummary solved = SolvePhotometricStereo(solver, moved_input, resolved, resolve_progress);
    if (solved.IsUsable() && !shadow_edge_masks.empty()) {
      PhotometricSolverInput unmasked = input;
      unmasked.light_field = &moved_field;
      edge_kept_pixels = SolveWithEdgeSamplesWhereMasksFail(solver, unmasked, shadow_edge_masks, resolved, &solved);
    }
    return solved;
  };
  DepthScaleChooser choose_scale;
  if (options.anchor_by_residual) {
    // The shadow edges out of the fit too: made now, before the first re-solve.
    if (options.shadow_edge_radius_px > 0) {
      shadow_edge_masks = ShadowEdgeSampleMasks(options, solver, input, &shadow_edge_samples);
    }
    masks_made = true;
    choose_scale = ResidualScaleChooser(solver, input, shadow_edge_masks.empty() ? nullptr : &shadow_edge_masks,
                                        lights, camera);
  }
  DepthRefinementSummary summary =
      RefineDepth(options, resolve, lights, camera, solution, surface_points_in_table, progress, choose_scale);
  if (summary.refined) summary.shadow_edge_kept_pixels = edge_kept_pixels;
  return summary;
}

DepthRefinementSummary RefineDepth(const DepthRefinementOptions& options, const DepthResolve& resolve,
                                   const std::vector<PointLight>& lights, const CameraGeometry& camera,
                                   PhotometricSolution* solution, ImageF* surface_points_in_table,
                                   const ProgressCallback& progress, const DepthScaleChooser& choose_scale) {
  options.Check();
  if (solution == nullptr) throw std::invalid_argument("RefineDepth: solution must not be null");
  const auto start = std::chrono::steady_clock::now();
  DepthRefinementSummary summary;
  summary.termination = Termination::kSuccess;
  ImageF points;  // the table points, once the loop runs
  auto finish = [&](std::string reason) {
    summary.stop_reason = std::move(reason);
    summary.seconds = SecondsSince(start);
    if (surface_points_in_table) *surface_points_in_table = points.empty() ? ComputeTablePoints(camera) : points;
    return summary;
  };
  if (!options.enabled) return finish("disabled (the table plane only)");
  {
    DepthDecisionBlocks blocks(solution->status.width(), solution->status.height());
    blocks.AddRows(*solution);
    bool kept = false;
    summary = Decide(options, blocks, camera, &kept);
    if (kept) return finish(summary.stop_reason);
  }
  points = ComputeTablePoints(camera);
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  const int cap = options.max_iterations;
  for (int iteration = 0; iteration < cap; ++iteration) {
    const auto iteration_start = std::chrono::steady_clock::now();
    double scale_vs_percentile = 0;
    const ImageF height_mm =
        AnchoredHeightFromSolution(options, *solution, camera, choose_scale, choose_scale ? &scale_vs_percentile : nullptr);
    const double range = SolvedHeightRangeMm(*solution, height_mm);
    ImageF moved = SurfacePointsAtHeight(camera, height_mm);
    const Movement movement = SurfaceMovement(*solution, points, moved);
    // Points that hardly move would give the same solution again: stop before
    // re-solving. The 99th percentile, not the maximum: a few pixels on walls
    // seen nearly edge-on flip by a mm or two between re-solves for good
    // (measured on the +-25 mm scene: max 1.7-2.2 mm for ever, mean 0.01 mm).
    if (iteration > 0 && movement.p99_mm < options.tolerance_mm) {
      summary.final_move_max_mm = movement.max_mm;
      summary.final_move_p99_mm = movement.p99_mm;
      return finish("converged (the next move: 99 % of the points at most " + Mm(movement.p99_mm) +
                    " mm < tolerance " + Mm(options.tolerance_mm) + " mm, max " + Mm(movement.max_mm) + " mm)");
    }
    points = std::move(moved);
    const PointLightField field(lights, points, centre);
    PhotometricSolution resolved;
    const ProgressCallback stage_progress = [&](double fraction) {
      return !progress || progress((iteration + fraction) / cap);
    };
    const PhotometricSolverSummary solved = resolve(field, &resolved, stage_progress, &summary.shadow_edge_samples);
    if (solved.IsCancelled()) {
      summary.SetCancelled("cancelled during re-solve " + std::to_string(iteration + 1));
      return finish("cancelled");
    }
    RequireSuccess(solved, "depth refinement: re-solve " + std::to_string(iteration + 1));
    *solution = std::move(resolved);
    summary.last_resolve = solved;
    summary.refined = true;
    summary.iterations.push_back({movement.max_mm, movement.mean_mm, movement.p99_mm, range,
                                  SecondsSince(iteration_start), choose_scale ? scale_vs_percentile : 0.0});
  }
  return finish("iteration cap (" + std::to_string(cap) + " re-solves)");
}

}  // namespace scanbench
