// The cloth material fit (solver/cloth_material.h) on synthetic patches with
// ground truth (fixed seeds): rendered with the engines' model itself, under
// ten lights on two rings as the scanner's, with 1 % noise. A Lambertian
// patch must get no sheen and no specular term; a sheen and a specular patch
// must get theirs back; a held-out light is one the fit never reads.
#include "solver/cloth_material.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "core/field_error.h"
#include "tests/solver/cloth_material_test_util.h"

namespace scanbench {
namespace {

using testing::kPatchSize;
using testing::MaterialPatch;
constexpr int kSize = kPatchSize;
using Patch = MaterialPatch;

ClothMaterialMaps Fit(const Patch& patch, ClothMaterialFitOptions options = {}, ClothMaterialFitSummary* out = nullptr) {
  options.num_threads = 2;
  ClothMaterialMaps maps;
  const ClothMaterialFitSummary summary = FitClothMaterial(options, patch.Input(), patch.normals, patch.pixels, &maps);
  EXPECT_TRUE(summary.IsUsable()) << summary.BriefReport();
  if (out) *out = summary;
  return maps;
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

TEST(ClothMaterialTest, ALambertianPatchGetsNoSheenAndNoSpecular) {
  ClothMaterial lambert;
  lambert.base_color = Eigen::Vector3d(0.6, 0.4, 0.2);
  const Patch patch(lambert, 0.01, 7);
  ClothMaterialFitSummary summary;
  const ClothMaterialMaps maps = Fit(patch, {}, &summary);
  EXPECT_EQ(summary.pixels_fitted, static_cast<size_t>(kSize * kSize));
  EXPECT_EQ(summary.pixels_sheen, 0u);
  EXPECT_EQ(summary.pixels_specular, 0u);
  std::vector<double> error;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      for (int c = 0; c < 3; ++c) error.push_back(std::abs(maps.base_color(x, y, c) / lambert.base_color(c) - 1));
    }
  }
  EXPECT_LT(Median(error), 0.01);
}

TEST(ClothMaterialTest, ASheenPatchGetsItsSheenColourAndRoughnessBack) {
  ClothMaterial velvet;
  velvet.base_color = Eigen::Vector3d(0.30, 0.12, 0.08);
  velvet.sheen_color = Eigen::Vector3d(0.5, 0.4, 0.4);
  velvet.sheen_roughness = 0.6;
  const Patch patch(velvet, 0.01, 11);
  ClothMaterialFitSummary summary;
  const ClothMaterialMaps maps = Fit(patch, {}, &summary);
  EXPECT_GT(summary.pixels_sheen, static_cast<size_t>(0.99 * kSize * kSize)) << summary.BriefReport();
  EXPECT_EQ(summary.pixels_specular, 0u) << summary.BriefReport();
  std::vector<double> sheen_error, roughness_error, base_error, confidence;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      for (int c = 0; c < 3; ++c) {
        sheen_error.push_back(std::abs(maps.sheen_color(x, y, c) / velvet.sheen_color(c) - 1));
        base_error.push_back(std::abs(maps.base_color(x, y, c) / velvet.base_color(c) - 1));
      }
      roughness_error.push_back(std::abs(maps.sheen_roughness(x, y) - velvet.sheen_roughness));
      confidence.push_back(maps.confidence(x, y, 0));
    }
  }
  EXPECT_LT(Median(sheen_error), 0.10);
  EXPECT_LT(Median(base_error), 0.03);
  EXPECT_LE(Median(roughness_error), 0.1 + 1e-6);  // one grid step
  EXPECT_GT(Median(confidence), 0.0);               // a standard error where there is a sheen
}

TEST(ClothMaterialTest, ASpecularPatchGetsItsF0Back) {
  ClothMaterial gloss;
  gloss.base_color = Eigen::Vector3d(0.2, 0.3, 0.5);
  gloss.specular_f0 = 0.05;
  gloss.specular_roughness = 0.3;
  const Patch patch(gloss, 0.01, 13);
  ClothMaterialFitSummary summary;
  const ClothMaterialMaps maps = Fit(patch, {}, &summary);
  EXPECT_GT(summary.pixels_specular, static_cast<size_t>(0.99 * kSize * kSize)) << summary.BriefReport();
  std::vector<double> f0_error, roughness_error;
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) {
      f0_error.push_back(std::abs(maps.specular(x, y, 0) / gloss.specular_f0 - 1));
      roughness_error.push_back(std::abs(maps.specular(x, y, 1) - gloss.specular_roughness));
    }
  }
  EXPECT_LT(Median(f0_error), 0.15);
  EXPECT_LE(Median(roughness_error), 0.05 + 1e-6);
}

TEST(ClothMaterialTest, AHeldOutLightIsNeverRead) {
  ClothMaterial velvet;
  velvet.base_color = Eigen::Vector3d(0.3, 0.3, 0.3);
  velvet.sheen_color = Eigen::Vector3d(0.4, 0.4, 0.4);
  Patch patch(velvet, 0.01, 17);
  ClothMaterialFitOptions options;
  options.held_out_light = 4;
  const ClothMaterialMaps reference = Fit(patch, options);
  // Whatever light 4 reads, the fit without it is the same.
  std::fill(patch.images[4].data(), patch.images[4].data() + patch.images[4].size(), 123.0f);
  const ClothMaterialMaps again = Fit(patch, options);
  for (size_t i = 0; i < reference.base_color.size(); ++i) {
    ASSERT_EQ(reference.base_color.data()[i], again.base_color.data()[i]);
    ASSERT_EQ(reference.sheen_color.data()[i], again.sheen_color.data()[i]);
  }
  // And it is read when not held out.
  options.held_out_light = -1;
  const ClothMaterialMaps with_it = Fit(patch, options);
  EXPECT_NE(with_it.base_color(3, 3, 0), reference.base_color(3, 3, 0));
}

TEST(ClothMaterialTest, PixelsThatCannotBeFittedAreFlaggedAndFinite) {
  ClothMaterial lambert;
  lambert.base_color = Eigen::Vector3d(0.5, 0.5, 0.5);
  Patch patch(lambert, 0.0, 19);
  patch.normals(5, 5, 0) = 0, patch.normals(5, 5, 1) = 0, patch.normals(5, 5, 2) = 0;  // not a normal
  patch.normals(6, 6, 0) = 0, patch.normals(6, 6, 1) = 0, patch.normals(6, 6, 2) = -1; // faces away from every light
  patch.pixels(7, 7) = 0;                                                               // not asked for
  ClothMaterialFitSummary summary;
  const ClothMaterialMaps maps = Fit(patch, {}, &summary);
  EXPECT_EQ(summary.pixels_too_few_samples, 2u);
  EXPECT_EQ(maps.terms(5, 5), 0);
  EXPECT_EQ(maps.terms(6, 6), 0);
  EXPECT_EQ(maps.terms(7, 7), 0);
  EXPECT_EQ(maps.terms(8, 8), kMaterialFitted);
  for (const ImageF* map : {&maps.base_color, &maps.sheen_color, &maps.sheen_roughness, &maps.specular, &maps.confidence}) {
    for (size_t i = 0; i < map->size(); ++i) ASSERT_TRUE(std::isfinite(map->data()[i]));
  }
}

TEST(ClothMaterialTest, TheSheenOnlyModelIsKhrMaterialsSheensFormula) {
  // Sheen over a Lambertian base: b = s rho (n.l) + c pi D V (n.l), worked by hand at one geometry.
  ClothMaterial m;
  m.base_color = Eigen::Vector3d(0.5, 0.5, 0.5);
  m.sheen_color = Eigen::Vector3d(0.2, 0.2, 0.2);
  m.sheen_roughness = 0.5;
  const Eigen::Vector3d n(0, 0, 1), v(0, 0, 1);
  const Eigen::Vector3d l = Eigen::Vector3d(std::sin(1.0), 0, std::cos(1.0));
  const double nl = std::cos(1.0), nh = std::cos(0.5);
  const double a = 0.25, sin2 = 1 - nh * nh;
  const double d = (2 + 1 / a) * std::pow(sin2, 0.5 / a) / (2 * std::numbers::pi);
  const double vis = 1 / (4 * (nl + 1 - nl));
  const Eigen::Vector3d value = ClothMaterialValue(m, n, l, v);
  // The albedo scaling is below 1 and at least 1 - 0.2 (E <= 1).
  const double sheen = 0.2 * std::numbers::pi * d * vis * nl;
  const double scaling = (value(0) - sheen) / (0.5 * nl);
  EXPECT_GT(scaling, 0.8);
  EXPECT_LT(scaling, 1.0);
  EXPECT_EQ(ClothMaterialValue(m, n, Eigen::Vector3d(0, 0, -1), v), Eigen::Vector3d::Zero());
}

TEST(ClothMaterialTest, BadOptionsNameTheField) {
  ClothMaterialFitOptions options;
  options.block_size = 1;
  EXPECT_THROW(options.Check(), FieldValueError);
  options = {};
  options.sheen_roughnesses = {};
  try {
    options.Check();
    FAIL();
  } catch (const FieldValueError& e) {
    EXPECT_EQ(e.field(), "sheen_roughnesses");
  }
  options = {};
  options.specular_roughnesses = {0.01};
  EXPECT_THROW(options.Check(), FieldValueError);
  ClothMaterial lambert;
  lambert.base_color = Eigen::Vector3d(0.5, 0.5, 0.5);
  const Patch patch(lambert, 0.0, 23);
  options = {};
  options.held_out_light = 10;
  ClothMaterialMaps maps;
  EXPECT_THROW(FitClothMaterial(options, patch.Input(), patch.normals, patch.pixels, &maps), FieldValueError);
}

TEST(ClothMaterialTest, ACancelReturnsCancelled) {
  ClothMaterial lambert;
  lambert.base_color = Eigen::Vector3d(0.5, 0.5, 0.5);
  const Patch patch(lambert, 0.0, 29);
  ClothMaterialMaps maps;
  ClothMaterialFitOptions options;
  options.num_threads = 1;
  const ClothMaterialFitSummary summary =
      FitClothMaterial(options, patch.Input(), patch.normals, patch.pixels, &maps, [](double) { return false; });
  EXPECT_TRUE(summary.IsCancelled());
  EXPECT_LT(summary.pixels_fitted, static_cast<size_t>(kSize * kSize));
}

}  // namespace
}  // namespace scanbench
