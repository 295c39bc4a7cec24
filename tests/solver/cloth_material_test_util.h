// A synthetic patch for the cloth material's tests (solver and pipeline):
// gently varying normals, one material rendered with the engines' model
// (ClothMaterialValue) under ten lights on two rings as the scanner's, with
// relative Gaussian noise from a fixed seed.
#pragma once

#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "core/image.h"
#include "solver/cloth_material.h"
#include "solver/light_field.h"
#include "solver/photometric_solver.h"

namespace scanbench::testing {

inline constexpr int kPatchSize = 48;

// Ten lights on two rings (30 and 55 degrees above the table), as the rig's.
inline std::vector<Eigen::Vector3d> RingLights() {
  std::vector<Eigen::Vector3d> dirs;
  for (int ring = 0; ring < 2; ++ring) {
    const double elevation = (ring == 0 ? 30.0 : 55.0) * std::numbers::pi / 180;
    for (int i = 0; i < 5; ++i) {
      const double azimuth = (72.0 * i + 36.0 * ring) * std::numbers::pi / 180;
      dirs.emplace_back(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                        std::sin(elevation));
    }
  }
  return dirs;
}

// A patch of gently varying normals, one material, rendered with noise.
struct MaterialPatch {
  std::vector<Eigen::Vector3d> dirs = RingLights();
  std::vector<Eigen::Vector3d> intensities;
  std::vector<ImageF> images;
  ImageF normals{kPatchSize, kPatchSize, 3};
  ImageU8 pixels{kPatchSize, kPatchSize, 1, 1};
  std::unique_ptr<DirectionalLightField> field;

  MaterialPatch(const ClothMaterial& material, double noise, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    for (size_t k = 0; k < dirs.size(); ++k) intensities.emplace_back(0.9, 1.0, 1.1);
    field = std::make_unique<DirectionalLightField>(kPatchSize, kPatchSize, dirs, intensities);
    for (int y = 0; y < kPatchSize; ++y) {
      for (int x = 0; x < kPatchSize; ++x) {
        const Eigen::Vector3d n =
            Eigen::Vector3d(0.25 * std::sin(0.3 * x), 0.2 * std::cos(0.23 * y), 1.0).normalized();
        for (int c = 0; c < 3; ++c) normals(x, y, c) = static_cast<float>(n(c));
      }
    }
    const Eigen::Vector3d view(0, 0, 1);
    for (size_t k = 0; k < dirs.size(); ++k) {
      ImageF image(kPatchSize, kPatchSize, 3);
      for (int y = 0; y < kPatchSize; ++y) {
        for (int x = 0; x < kPatchSize; ++x) {
          const Eigen::Vector3d n(normals(x, y, 0), normals(x, y, 1), normals(x, y, 2));
          const Eigen::Vector3d value = ClothMaterialValue(material, n, dirs[k].normalized(), view);
          for (int c = 0; c < 3; ++c) {
            image(x, y, c) = static_cast<float>(intensities[k](c) * value(c) * (1.0 + noise * gauss(rng)));
          }
        }
      }
      images.push_back(std::move(image));
    }
  }

  PhotometricSolverInput Input() const {
    PhotometricSolverInput input;
    for (const ImageF& image : images) input.images.push_back(&image);
    input.light_field = field.get();
    return input;
  }
};

}  // namespace scanbench::testing
