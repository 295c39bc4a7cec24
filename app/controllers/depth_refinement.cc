#include "app/controllers/depth_refinement.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "calibration/camera_model.h"
#include "core/field_error.h"
#include "core/format.h"
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

double HeightRangeMm(const PhotometricSolution& solution, const ImageF& height_mm) {
  const std::vector<double> heights = SolvedHeights(solution, height_mm);
  return Percentile(heights, 99) - Percentile(heights, 1);
}

// The normals in the height solver's frame (x along image columns, y towards
// image row 0, z = table up): the table frame turned about z by the camera's
// roll, read off the table points of the centre pixel's neighbours.
ImageF NormalsInImageFrame(const PhotometricSolution& solution, const CameraGeometry& camera) {
  const double cx = camera.intrinsics.width / 2, cy = camera.intrinsics.height / 2;
  const std::vector<Eigen::Vector3d> p =
      ComputePlanePointsInTable(camera, {{cx, cy}, {cx + 1, cy}, {cx, cy - 1}}, 0.0);
  const Eigen::Vector2d right = (p[1] - p[0]).head<2>().normalized();
  const Eigen::Vector2d up = (p[2] - p[0]).head<2>().normalized();
  ImageF normals(solution.normal_in_table.width(), solution.normal_in_table.height(), 3);
  for (size_t i = 0; i < normals.num_pixels(); ++i) {
    const float* n = &solution.normal_in_table.data()[3 * i];
    const Eigen::Vector2d xy(n[0], n[1]);
    normals.data()[3 * i + 0] = static_cast<float>(xy.dot(right));
    normals.data()[3 * i + 1] = static_cast<float>(xy.dot(up));
    normals.data()[3 * i + 2] = n[2];
  }
  return normals;
}

struct Movement {
  double max_mm = 0, mean_mm = 0;
};

Movement SurfaceMovement(const PhotometricSolution& solution, const ImageF& before, const ImageF& after) {
  Movement movement;
  size_t count = 0;
  for (size_t i = 0; i < before.num_pixels(); ++i) {
    if (!Solved(solution, i)) continue;
    const Eigen::Vector3f a(&before.data()[3 * i]), b(&after.data()[3 * i]);
    const double d = (b - a).norm();
    movement.max_mm = std::max(movement.max_mm, d);
    movement.mean_mm += d;
    ++count;
  }
  if (count > 0) movement.mean_mm /= double(count);
  return movement;
}

}  // namespace

void DepthRefinementOptions::Check() const {
  constexpr const char* kWhere = "DepthRefinementOptions";
  if (max_iterations < 1 || max_iterations > 20) {
    throw FieldError(kWhere, "max_iterations", max_iterations, "must lie in [1, 20]");
  }
  if (!(tolerance_mm > 0) || !std::isfinite(tolerance_mm)) {
    throw FieldError(kWhere, "tolerance_mm", tolerance_mm, "must be finite and > 0");
  }
  if (!(min_height_range_mm >= 0) || !std::isfinite(min_height_range_mm)) {
    throw FieldError(kWhere, "min_height_range_mm", min_height_range_mm, "must be finite and >= 0");
  }
  if (!(anchor_percentile >= 0 && anchor_percentile <= 50)) {
    throw FieldError(kWhere, "anchor_percentile", anchor_percentile, "must lie in [0, 50]");
  }
}

std::string DepthRefinementSummary::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "Depth refinement: " << TerminationName(termination) << ", "
      << iterations.size() << " iteration(s)";
  if (!iterations.empty()) {
    out << ", surface moved max";
    for (size_t i = 0; i < iterations.size(); ++i) out << (i ? "/" : " ") << iterations[i].max_move_mm;
    out << " mm, mean";
    for (size_t i = 0; i < iterations.size(); ++i) out << (i ? "/" : " ") << iterations[i].mean_move_mm;
    out << " mm";
  }
  if (first_height_range_mm > 0) out << "; first-pass height range " << first_height_range_mm << " mm";
  out << "; stopped: " << stop_reason;
  if (!message.empty() && termination != Termination::kSuccess) out << " (" << message << ")";
  out << ", " << std::setprecision(2) << seconds << " s";
  return out.str();
}

ImageF AnchoredHeightFromSolution(const DepthRefinementOptions& options, const PhotometricSolution& solution,
                                  const CameraGeometry& camera) {
  HeightFromNormalsOptions height_options;
  height_options.method = HeightFromNormalsOptions::Method::kDctPoisson;
  height_options.mm_per_pixel = TablePixelFootprintMm(camera);
  // A draped sample's edge rises tens of mm within a few mm: far steeper than
  // the default clamp, which would flatten the whole sample by the difference.
  height_options.max_slope = 50;
  ImageU8 solved(solution.status.width(), solution.status.height(), 1);
  for (size_t i = 0; i < solved.num_pixels(); ++i) solved.data()[i] = Solved(solution, i);
  ImageF height_mm;
  const HeightFromNormalsSummary summary =
      HeightFromNormals(height_options, NormalsInImageFrame(solution, camera), &solved, &height_mm);
  RequireSuccess(summary, "depth refinement: height from normals");
  // The integration knows the height up to a constant; the lowest solved
  // pixels (the table around the sample, or the folds resting on it) are put on the table.
  const double anchor = Percentile(SolvedHeights(solution, height_mm), options.anchor_percentile);
  for (size_t i = 0; i < height_mm.num_pixels(); ++i) height_mm.data()[i] -= static_cast<float>(anchor);
  return height_mm;
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

DepthRefinementSummary RefineDepth(const DepthRefinementOptions& options, const PhotometricSolverOptions& solver,
                                   const PhotometricSolverInput& input, const std::vector<PointLight>& lights,
                                   const CameraGeometry& camera, PhotometricSolution* solution,
                                   ImageF* surface_points_in_table, const ProgressCallback& progress) {
  const DepthResolve resolve = [&](const LightField& moved_field, PhotometricSolution* resolved,
                                   const ProgressCallback& resolve_progress) {
    PhotometricSolverInput moved_input = input;
    moved_input.light_field = &moved_field;
    return SolvePhotometricStereo(solver, moved_input, resolved, resolve_progress);
  };
  return RefineDepth(options, resolve, lights, camera, solution, surface_points_in_table, progress);
}

DepthRefinementSummary RefineDepth(const DepthRefinementOptions& options, const DepthResolve& resolve,
                                   const std::vector<PointLight>& lights, const CameraGeometry& camera,
                                   PhotometricSolution* solution, ImageF* surface_points_in_table,
                                   const ProgressCallback& progress) {
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
  points = ComputeTablePoints(camera);
  const Eigen::Vector3d centre = CameraCentreInTable(camera);
  const int cap = options.max_iterations;
  for (int iteration = 0; iteration < cap; ++iteration) {
    const auto iteration_start = std::chrono::steady_clock::now();
    const ImageF height_mm = AnchoredHeightFromSolution(options, *solution, camera);
    const double range = HeightRangeMm(*solution, height_mm);
    if (iteration == 0) {
      summary.first_height_range_mm = range;
      if (range <= options.min_height_range_mm) {
        return finish("height range " + Mm(range) + " mm is not above min_height_range_mm " +
                      Mm(options.min_height_range_mm) + " mm: the table plane is kept");
      }
    }
    ImageF moved = SurfacePointsAtHeight(camera, height_mm);
    const Movement movement = SurfaceMovement(*solution, points, moved);
    // Points that hardly move would give the same solution again: stop before re-solving.
    if (iteration > 0 && movement.max_mm < options.tolerance_mm) {
      summary.final_move_max_mm = movement.max_mm;
      return finish("converged (the next move would be at most " + Mm(movement.max_mm) +
                    " mm < tolerance " + Mm(options.tolerance_mm) + " mm)");
    }
    points = std::move(moved);
    const PointLightField field(lights, points, centre);
    PhotometricSolution resolved;
    const ProgressCallback stage_progress = [&](double fraction) {
      return !progress || progress((iteration + fraction) / cap);
    };
    const PhotometricSolverSummary solved = resolve(field, &resolved, stage_progress);
    if (solved.IsCancelled()) {
      summary.SetCancelled("cancelled during re-solve " + std::to_string(iteration + 1));
      return finish("cancelled");
    }
    RequireSuccess(solved, "depth refinement: re-solve " + std::to_string(iteration + 1));
    *solution = std::move(resolved);
    summary.refined = true;
    summary.iterations.push_back({movement.max_mm, movement.mean_mm, range, SecondsSince(iteration_start)});
  }
  return finish("iteration cap (" + std::to_string(cap) + " re-solves)");
}

}  // namespace scanbench
