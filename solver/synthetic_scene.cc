#include "solver/synthetic_scene.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include "core/field_error.h"

namespace scanbench {
namespace {

constexpr const char* kOptions = "SyntheticSceneOptions";

// RGB intensities differ per light so that dividing them out is exercised.
Eigen::Vector3d LightIntensity(int k) {
  return Eigen::Vector3d(0.9 + 0.02 * k, 1.0 - 0.015 * k, 0.8 + 0.03 * (k % 3));
}

}  // namespace

void SyntheticSceneOptions::Check() const {
  SCANBENCH_REQUIRE_GE(kOptions, "width", width, 8);
  SCANBENCH_REQUIRE_GE(kOptions, "height", height, 8);
  SCANBENCH_REQUIRE_GE(kOptions, "num_lights", num_lights, 3);
  SCANBENCH_REQUIRE_GT_LT(kOptions, "min_elevation_deg", min_elevation_deg, 0, 90);
  if (!(max_elevation_deg >= min_elevation_deg && max_elevation_deg < 90)) {
    throw FieldError(kOptions, "max_elevation_deg", max_elevation_deg, "must lie in [min_elevation_deg, 90)");
  }
  SCANBENCH_REQUIRE_GE_LT(kOptions, "tilt_degrees", tilt_degrees, 0, 80);
  for (int c = 0; c < 3; ++c) {
    SCANBENCH_REQUIRE_GE_LE(kOptions, "albedo", albedo[c], 0, 1);
  }
  SCANBENCH_REQUIRE_GT(kOptions, "light_distance", light_distance, 0);
  SCANBENCH_REQUIRE_GT(kOptions, "pixel_pitch", pixel_pitch, 0);
  SCANBENCH_REQUIRE_GE(kOptions, "noise_stddev", noise_stddev, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "specular", specular, 0, 10);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "shininess", shininess, 1, 10000);
}

std::vector<Eigen::Vector3d> RingLightDirections(int num_lights, double low_elevation_deg,
                                                 double high_elevation_deg, double azimuth_deg) {
  std::vector<Eigen::Vector3d> dirs;
  const int num_low = (num_lights + 1) / 2;
  const int num_high = num_lights - num_low;
  for (int k = 0; k < num_lights; ++k) {
    const bool low = k < num_low;
    const int ring_count = low ? num_low : num_high;
    const int ring_index = low ? k : k - num_low;
    const double elevation = (low ? low_elevation_deg : high_elevation_deg) * M_PI / 180;
    const double azimuth = azimuth_deg * M_PI / 180 + 2 * M_PI * (ring_index + (low ? 0.0 : 0.5)) / ring_count;
    dirs.emplace_back(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                      std::sin(elevation));
  }
  return dirs;
}

std::vector<const ImageF*> SyntheticScene::ImagePointers() const {
  std::vector<const ImageF*> pointers;
  for (const ImageF& image : images) pointers.push_back(&image);
  return pointers;
}

SyntheticScene MakeSyntheticScene(const SyntheticSceneOptions& options) {
  options.Check();
  const int width = options.width;
  const int height = options.height;
  SyntheticScene scene;
  scene.normal_in_table = ImageF(width, height, 3);
  scene.albedo = ImageF(width, height, 3);
  scene.object = ImageU8(width, height, 1, 1);
  scene.fully_lit = ImageU8(width, height, 1, 0);

  // Ground truth geometry: image x = table x, image rows run down table y.
  const double centre_x = 0.5 * (width - 1);
  const double centre_y = 0.5 * (height - 1);
  const double radius = 0.45 * std::min(width, height);
  const double tilt = options.tilt_degrees * M_PI / 180;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
      if (options.shape == SyntheticSceneOptions::Shape::kSphere) {
        const double u = (x - centre_x) / radius;
        const double v = -(y - centre_y) / radius;
        const double r2 = u * u + v * v;
        if (r2 < 1) {
          normal = Eigen::Vector3d(u, v, std::sqrt(1 - r2));
        } else {
          scene.object(x, y) = 0;
        }
      } else {
        normal = Eigen::Vector3d(0, -std::sin(tilt), std::cos(tilt));
      }
      for (int c = 0; c < 3; ++c) {
        scene.normal_in_table(x, y, c) = static_cast<float>(normal[c]);
        scene.albedo(x, y, c) = static_cast<float>(options.albedo[c]);
      }
    }
  }

  const std::vector<Eigen::Vector3d> dirs =
      RingLightDirections(options.num_lights, options.min_elevation_deg, options.max_elevation_deg);
  std::vector<Eigen::Vector3d> intensities;
  for (int k = 0; k < options.num_lights; ++k) intensities.push_back(LightIntensity(k));
  if (options.lights == SyntheticSceneOptions::Lights::kDistant) {
    scene.light_field = std::make_unique<DirectionalLightField>(width, height, dirs, intensities);
  } else {
    // Surface points on the table plane; the LEDs point at the centre.
    ImageF points(width, height, 3, 0.0f);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        points(x, y, 0) = static_cast<float>((x - centre_x) * options.pixel_pitch);
        points(x, y, 1) = static_cast<float>(-(y - centre_y) * options.pixel_pitch);
      }
    }
    std::vector<PointLight> lights;
    for (int k = 0; k < options.num_lights; ++k) {
      PointLight light;
      light.position = dirs[k] * options.light_distance;
      light.axis = -dirs[k];
      light.mu = 1.0 + 0.2 * k;
      light.rgb_intensity = intensities[k];
      light.reference_distance = options.light_distance;
      lights.push_back(light);
    }
    scene.light_field = std::make_unique<PointLightField>(std::move(lights), std::move(points));
  }

  const int num_lights = options.num_lights;
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> noise(0.0, options.noise_stddev);
  scene.images.assign(num_lights, ImageF(width, height, 3));
  std::vector<float> light_dirs(3 * num_lights), rgb_intensities(3 * num_lights);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      scene.light_field->Evaluate(x, y, light_dirs.data(), rgb_intensities.data());
      const Eigen::Vector3d normal(scene.normal_in_table(x, y, 0), scene.normal_in_table(x, y, 1),
                                   scene.normal_in_table(x, y, 2));
      bool all_lit = true;
      for (int k = 0; k < num_lights; ++k) {
        const Eigen::Vector3d light_dir(light_dirs[3 * k], light_dirs[3 * k + 1], light_dirs[3 * k + 2]);
        const double shading = normal.dot(light_dir);
        all_lit = all_lit && shading > 0;
        double sheen = 0;
        if (options.specular > 0 && shading > 0) {
          const Eigen::Vector3d half = (light_dir + Eigen::Vector3d::UnitZ()).normalized();
          sheen = options.specular * std::pow(std::max(0.0, normal.dot(half)), options.shininess);
        }
        for (int c = 0; c < 3; ++c) {
          double value = (options.albedo[c] * std::max(0.0, shading) + sheen) * rgb_intensities[3 * k + c];
          if (options.noise_stddev > 0) value += noise(rng);
          scene.images[k](x, y, c) = static_cast<float>(value);
        }
      }
      scene.fully_lit(x, y) = all_lit ? 1 : 0;
    }
  }
  return scene;
}

}  // namespace scanbench
