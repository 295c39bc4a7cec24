// Leave-one-light-out relighting (pipeline/relighting_check.h) on synthetic
// patches with ground truth (fixed seeds): a sheen patch's material predicts
// the held-out lights far better than albedo x n.l; on a Lambertian patch the
// two are the same prediction; the predicted image is the material rendered.
#include "pipeline/relighting_check.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/field_error.h"
#include "tests/solver/cloth_material_test_util.h"

namespace scanbench {
namespace {

using testing::kPatchSize;
using testing::MaterialPatch;

RelightingCheckSummary Check(const MaterialPatch& patch) {
  RelightingCheckOptions options;
  options.fit.num_threads = 2;
  const RelightingCheckSummary summary = CheckRelighting(options, patch.Input(), patch.normals, patch.pixels);
  EXPECT_TRUE(summary.IsUsable()) << summary.BriefReport();
  EXPECT_EQ(summary.lights.size(), patch.dirs.size());
  return summary;
}

TEST(RelightingCheckTest, ASheenMaterialPredictsTheHeldOutLightsBetterThanAlbedoTimesNdotL) {
  ClothMaterial velvet;
  velvet.base_color = Eigen::Vector3d(0.30, 0.12, 0.08);
  velvet.sheen_color = Eigen::Vector3d(0.5, 0.45, 0.45);
  velvet.sheen_roughness = 0.6;
  const RelightingCheckSummary summary = Check(MaterialPatch(velvet, 0.01, 31));
  EXPECT_EQ(summary.pixels_scored, static_cast<size_t>(kPatchSize / 2 * kPatchSize / 2));
  EXPECT_GT(summary.lambertian_error, 0.05) << summary.BriefReport();
  EXPECT_LT(summary.Ratio(), 0.5) << summary.BriefReport();
  for (const RelightingLightError& light : summary.lights) {
    EXPECT_GT(light.samples, 0u);
    EXPECT_LT(light.material, light.lambertian);
  }
}

TEST(RelightingCheckTest, OnALambertianPatchBothPredictionsAreTheSame) {
  ClothMaterial lambert;
  lambert.base_color = Eigen::Vector3d(0.6, 0.4, 0.2);
  const RelightingCheckSummary summary = Check(MaterialPatch(lambert, 0.01, 37));
  EXPECT_NEAR(summary.Ratio(), 1.0, 1e-9) << summary.BriefReport();
  // The noise alone: 1 % Gaussian noise is about 0.8 % mean absolute error.
  EXPECT_LT(summary.lambertian_error, 0.015);
}

TEST(RelightingCheckTest, ThePredictedImageIsTheMaterialRendered) {
  ClothMaterial velvet;
  velvet.base_color = Eigen::Vector3d(0.3, 0.3, 0.3);
  velvet.sheen_color = Eigen::Vector3d(0.4, 0.4, 0.4);
  const MaterialPatch noiseless(velvet, 0.0, 41);
  ClothMaterialFitOptions options;
  options.num_threads = 2;
  options.held_out_light = 2;
  ClothMaterialMaps maps;
  ASSERT_TRUE(FitClothMaterial(options, noiseless.Input(), noiseless.normals, noiseless.pixels, &maps).IsUsable());
  const ImageF predicted = PredictLightImage(maps, noiseless.normals, *noiseless.field, 2, 2);
  double error = 0, sum = 0;
  for (size_t i = 0; i < predicted.size(); ++i) {
    error += std::abs(predicted.data()[i] - noiseless.images[2].data()[i]);
    sum += noiseless.images[2].data()[i];
  }
  EXPECT_LT(error / sum, 0.02);
  EXPECT_THROW(PredictLightImage(maps, noiseless.normals, *noiseless.field, 10, 1), std::invalid_argument);
}

TEST(RelightingCheckTest, BadOptionsNameTheField) {
  RelightingCheckOptions options;
  options.pixel_step = 0;
  EXPECT_THROW(options.Check(), FieldValueError);
}

}  // namespace
}  // namespace scanbench
