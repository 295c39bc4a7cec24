// The learned solver's training observations (app/sim/observation_sets.h) and
// the shading models they are rendered with (app/sim/shading_models.h).
#include "app/sim/observation_sets.h"

#include <cmath>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "app/sim/shading_models.h"

namespace scanbench {
namespace {

ObservationSets Render(ObservationSetOptions options) {
  ObservationSets sets;
  const ObservationSetSummary summary = GenerateObservationSets(options, &sets);
  EXPECT_TRUE(summary.IsUsable()) << summary.BriefReport();
  return sets;
}

TEST(ObservationSetsTest, SameSeedSameSetsWhateverTheThreads) {
  ObservationSetOptions options;
  options.num_sets = 3000;
  options.seed = 11;
  options.num_threads = 1;
  const ObservationSets one = Render(options);
  options.num_threads = 2;
  const ObservationSets two = Render(options);
  ASSERT_EQ(one.offset, two.offset);
  ASSERT_EQ(one.value, two.value);
  for (int s = 0; s < one.num_sets(); ++s) ASSERT_EQ(one.normal[s], two.normal[s]);
  options.seed = 12;
  const ObservationSets other = Render(options);
  EXPECT_NE(other.value, one.value);
}

TEST(ObservationSetsTest, SetsAreWellFormed) {
  ObservationSetOptions options;
  options.num_sets = 5000;
  const ObservationSets sets = Render(options);
  ASSERT_EQ(sets.num_sets(), 5000);
  int near_field = 0, with_specular = 0, with_sheen = 0, with_shadow = 0;
  for (int s = 0; s < sets.num_sets(); ++s) {
    EXPECT_GE(sets.NumLights(s), 3);
    EXPECT_LE(sets.NumLights(s), options.max_lights);
    EXPECT_NEAR(sets.normal[s].norm(), 1.0f, 1e-5f);
    EXPECT_GT(sets.normal[s].z(), 0.0f) << "every normal faces the view";
    near_field += sets.light_set_kind[s] == static_cast<int32_t>(LightSetKind::kNearField);
    with_specular += (sets.material_flags[s] & 1) != 0;
    with_sheen += (sets.material_flags[s] & 8) != 0;
    with_shadow += (sets.material_flags[s] & 32) != 0;
    for (int64_t k = sets.offset[s]; k < sets.offset[s + 1]; ++k) {
      ASSERT_TRUE(std::isfinite(sets.value[k]));
      ASSERT_GE(sets.value[k], 0.0f);
      ASSERT_NEAR(sets.light_dir[k].norm(), 1.0f, 1e-5f);
    }
  }
  // The shares asked for, within sampling error (5000 sets: 3 sigma is about 2 %).
  EXPECT_NEAR(near_field / 5000.0, options.near_field_share, 0.03);
  EXPECT_NEAR(with_specular / 5000.0, options.specular_share, 0.03);
  EXPECT_NEAR(with_sheen / 5000.0, options.sheen_share, 0.03);
  EXPECT_NEAR(with_shadow / 5000.0, options.shadow_share, 0.03);
}

TEST(ObservationSetsTest, LambertianSetsWithoutShadowsAreWhatLeastSquaresSolves) {
  // No lobe, no sheen, no shadow: only inter-reflection, footprints, calibration
  // error and the sensor stand between least squares and the truth.
  ObservationSetOptions options;
  options.num_sets = 2000;
  options.specular_share = options.sheen_share = options.shadow_share = 0;
  options.near_field_share = 0;
  const ObservationSets sets = Render(options);
  double error_sum = 0;
  int counted = 0;
  for (int s = 0; s < sets.num_sets(); ++s) {
    if (sets.material_flags[s] != 0 || sets.NumLights(s) < 12) continue;  // Burley, bounce, footprint: skip
    Eigen::MatrixXd lights(sets.NumLights(s), 3);
    Eigen::VectorXd values(sets.NumLights(s));
    for (int k = 0; k < sets.NumLights(s); ++k) {
      lights.row(k) = sets.light_dir[sets.offset[s] + k].cast<double>().transpose();
      values[k] = sets.value[sets.offset[s] + k];
    }
    // Attached shadows read 0 and bias least squares: only the lit samples.
    const Eigen::Vector3d n = sets.normal[s].cast<double>();
    std::vector<int> lit;
    for (int k = 0; k < sets.NumLights(s); ++k) {
      if (lights.row(k).dot(n) > 0.1) lit.push_back(k);
    }
    if (lit.size() < 6) continue;
    Eigen::MatrixXd l(lit.size(), 3);
    Eigen::VectorXd b(lit.size());
    for (size_t k = 0; k < lit.size(); ++k) {
      l.row(k) = lights.row(lit[k]);
      b[k] = values[lit[k]];
    }
    const Eigen::Vector3d solved = l.colPivHouseholderQr().solve(b).normalized();
    error_sum += std::acos(std::clamp(solved.dot(n), -1.0, 1.0)) * 180 / M_PI;
    ++counted;
  }
  ASSERT_GT(counted, 100);
  // Calibration errors of up to 1.5 deg and 4 % and the sensor's noise: a few degrees, not tens.
  EXPECT_LT(error_sum / counted, 4.0);
  EXPECT_GT(error_sum / counted, 0.05) << "the sets carry calibration error and noise";
}

TEST(ShadingModelsTest, LambertReadsAlbedoTimesCosine) {
  ShadingModel m;
  m.albedo = 0.4;
  const Eigen::Vector3d n(0, 0, 1), v(0, 0, 1);
  const Eigen::Vector3d l = Eigen::Vector3d(0.6, 0, 0.8);
  EXPECT_NEAR(ShadedValue(m, n, l, v), 0.4 * 0.8, 1e-12);
  EXPECT_EQ(ShadedValue(m, n, Eigen::Vector3d(0, 0, -1), v), 0.0);
}

TEST(ShadingModelsTest, LobesPeakAtTheMirrorDirection) {
  ShadingModel m;
  m.albedo = 0.2;
  m.specular = SpecularModel::kGgx;
  m.alpha = 0.1;
  const Eigen::Vector3d n(0, 0, 1);
  const Eigen::Vector3d v = Eigen::Vector3d(0.5, 0, 0.866).normalized();
  const Eigen::Vector3d mirror = Eigen::Vector3d(-0.5, 0, 0.866).normalized();
  const Eigen::Vector3d off = Eigen::Vector3d(-0.1, 0.5, 0.86).normalized();
  EXPECT_GT(ShadedValue(m, n, mirror, v), 5 * ShadedValue(m, n, off, v));
  // Anisotropic with equal alphas is the isotropic lobe up to its Smith form (within 10 %).
  ShadingModel a = m;
  a.specular = SpecularModel::kAnisotropicGgx;
  a.alpha_across = a.alpha;
  EXPECT_NEAR(ShadedValue(a, n, mirror, v), ShadedValue(m, n, mirror, v), 0.1 * ShadedValue(m, n, mirror, v));
}

TEST(ShadingModelsTest, SheensBrightenGrazingAndConserveEnergy) {
  const Eigen::Vector3d n(0, 0, 1);
  const Eigen::Vector3d grazing_view = Eigen::Vector3d(0.95, 0, 0.31).normalized();
  // Light and view grazing from the same side: the half vector near the
  // surface's plane, where velvet and Charlie distributions peak.
  const Eigen::Vector3d grazing_light = Eigen::Vector3d(0.9, 0.3, 0.3).normalized();
  for (SheenModel sheen : {SheenModel::kVelvet, SheenModel::kCharlie, SheenModel::kFuzz}) {
    ShadingModel m;
    m.albedo = 0.3;
    m.sheen = sheen;
    m.sheen_color = 0.8;
    m.sheen_roughness = 0.5;
    m.fuzz_density = 0.3;
    ShadingModel base = m;
    base.sheen = SheenModel::kNone;
    // Energy-conserving sheens dim the base they cover: what they add shows as
    // a larger share of the reading at grazing light and view than head-on.
    const Eigen::Vector3d head_on = Eigen::Vector3d(0.1, 0, 1).normalized();
    const double grazing_share =
        ShadedValue(m, n, grazing_light, grazing_view) / ShadedValue(base, n, grazing_light, grazing_view);
    const double head_on_share = ShadedValue(m, n, head_on, n) / ShadedValue(base, n, head_on, n);
    EXPECT_GT(grazing_share, 1.2 * head_on_share) << static_cast<int>(sheen);
  }
  for (double mu : {0.05, 0.3, 0.7, 1.0}) {
    for (double r : {0.1, 0.5, 1.0}) {
      const double e = CharlieSheenAlbedo(mu, r);
      EXPECT_GE(e, 0.0);
      EXPECT_LE(e, 1.0);
    }
  }
  // Rougher Charlie sheen reflects more at normal view (its lobe widens toward the normal).
  EXPECT_GT(CharlieSheenAlbedo(1.0, 1.0), CharlieSheenAlbedo(1.0, 0.2));
}

TEST(ObservationSetsTest, RejectsBadOptions) {
  ObservationSetOptions options;
  options.min_lights = 2;
  ObservationSets sets;
  try {
    GenerateObservationSets(options, &sets);
    FAIL() << "min_lights 2 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ObservationSetOptions.min_lights = 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace scanbench
