// Shared helpers of the solver tests.
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "solver/photometric_solver.h"
#include "solver/synthetic_scene.h"

namespace scanbench::testing {

inline PhotometricSolverInput InputFor(const SyntheticScene& scene) {
  PhotometricSolverInput input;
  input.images = scene.ImagePointers();
  input.light_field = scene.light_field.get();
  return input;
}

// Pixels where the noise-free Lambertian model holds exactly for every light.
inline ImageU8 ExactPixels(const SyntheticScene& scene) {
  ImageU8 mask = scene.fully_lit;
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] &= scene.object.data()[i];
  return mask;
}

// No NaN or infinity in any float map of the solution.
inline void ExpectAllFinite(const PhotometricSolution& solution) {
  for (const ImageF* image : {&solution.normal_in_table, &solution.albedo, &solution.condition_number,
                              &solution.residual, &solution.specular}) {
    for (size_t i = 0; i < image->size(); ++i) ASSERT_TRUE(std::isfinite(image->data()[i])) << "at index " << i;
  }
}

inline Eigen::Vector3d NormalAt(const ImageF& normals, int x, int y) {
  return Eigen::Vector3d(normals(x, y, 0), normals(x, y, 1), normals(x, y, 2));
}

inline double AngleDegrees(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

inline size_t CountStatus(const PhotometricSolution& solution, PixelStatus status) {
  size_t count = 0;
  for (size_t i = 0; i < solution.status.num_pixels(); ++i) count += solution.status.data()[i] == uint8_t(status);
  return count;
}

}  // namespace scanbench::testing
