#include "app/sim/textile_scene.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "calibration/color_checker.h"

namespace scanbench {
namespace {


Eigen::Vector2d FiniteDifferenceGradient(const TextileScene& scene, double x, double y, double h) {
  return {(scene.HeightMm(x + h, y) - scene.HeightMm(x - h, y)) / (2 * h),
          (scene.HeightMm(x, y + h) - scene.HeightMm(x, y - h)) / (2 * h)};
}

TEST(TextileScene, GradientAgreesWithCentralFiniteDifferences) {
  const TextileScene scene;
  std::mt19937_64 rng(7);
  // Whole sample plus a margin, so the edge blend and the table are covered.
  std::uniform_real_distribution<double> ux(-65, 65), uy(-45, 45);
  // h = 1e-5 mm: the truncation error (h^2 f''' / 6, and h * |jump of f''|
  // where a thread's cos^2 profile meets the next thread) stays below 1e-5,
  // rounding error (1e-16 * 6 mm / h) below 1e-9.
  constexpr double kStepMm = 1e-5;
  constexpr double kTolerance = 2e-5;  // per gradient component (dimensionless slope)
  double worst = 0;
  for (int i = 0; i < 20000; ++i) {
    const double x = ux(rng), y = uy(rng);
    const Eigen::Vector2d analytic = scene.HeightGradient(x, y);
    const Eigen::Vector2d numeric = FiniteDifferenceGradient(scene, x, y, kStepMm);
    const double error = (analytic - numeric).cwiseAbs().maxCoeff();
    worst = std::max(worst, error);
    ASSERT_LT(error, kTolerance) << "at (" << x << ", " << y << "): analytic " << analytic.transpose()
                                 << " numeric " << numeric.transpose();
  }
  RecordProperty("worst_gradient_error", std::to_string(worst));
}

TEST(TextileScene, NormalIsUnitUpwardAndMatchesFiniteDifferences) {
  const TextileScene scene;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> ux(-62, 62), uy(-42, 42);
  for (int i = 0; i < 5000; ++i) {
    const double x = ux(rng), y = uy(rng);
    const Eigen::Vector3d n = scene.NormalInTable(x, y);
    ASSERT_NEAR(n.norm(), 1.0, 1e-12);
    ASSERT_GT(n.z(), 0.0);
    const Eigen::Vector2d g = FiniteDifferenceGradient(scene, x, y, 1e-5);
    const Eigen::Vector3d numeric = Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
    // 2e-5 rad = 0.001 deg, far below anything a solver could resolve.
    ASSERT_LT(std::acos(std::clamp(n.dot(numeric), -1.0, 1.0)), 2e-5) << "at (" << x << ", " << y << ")";
  }
}

TEST(TextileScene, HeightIsZeroOffTheSampleAndContinuousAcrossItsEdge) {
  const TextileScene scene;
  const double half_w = 0.5 * scene.options().sample_width_mm;
  const double half_h = 0.5 * scene.options().sample_height_mm;
  EXPECT_EQ(scene.HeightMm(half_w + 0.01, 0), 0.0);
  EXPECT_EQ(scene.HeightMm(0, -half_h - 0.01), 0.0);
  EXPECT_EQ(scene.HeightMm(200, 200), 0.0);
  EXPECT_EQ(scene.NormalInTable(200, 0), Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(scene.HeightMm(half_w, 3.0), 0.0, 1e-12);
  EXPECT_NEAR(scene.HeightMm(-half_w, 3.0), 0.0, 1e-12);
  EXPECT_NEAR(scene.HeightMm(5.0, half_h), 0.0, 1e-12);
  // Walk across the left edge in 1 um steps: no jumps.
  double previous = scene.HeightMm(-half_w - 1.0, 7.0);
  for (double x = -half_w - 1.0; x < -half_w + 8.0; x += 0.001) {
    const double h = scene.HeightMm(x, 7.0);
    ASSERT_LT(std::abs(h - previous), 0.01) << "jump at x = " << x;
    previous = h;
  }
  // Inside the blend the cloth is at full height: base + folds.
  EXPECT_GT(scene.HeightMm(0, 0), scene.options().base_thickness_mm);
}

TEST(TextileScene, HeightStaysWithinItsBoundAndHasFoldsAndWeave) {
  const TextileScene scene;
  double lowest = 1e9, highest = -1e9;
  for (double y = -40; y <= 40; y += 0.37) {
    for (double x = -60; x <= 60; x += 0.41) {
      const double h = scene.HeightMm(x, y);
      lowest = std::min(lowest, h);
      highest = std::max(highest, h);
    }
  }
  EXPECT_GE(lowest, 0.0);
  EXPECT_LE(highest, scene.MaxHeightMm());
  // Folds of a few mm.
  EXPECT_GT(highest, 3.0);
  EXPECT_LT(scene.MaxHeightMm(), 8.0);
  // Weave relief of a few tenths of a mm across one thread pitch (folds vary
  // by < 0.1 mm over 1.5 mm).
  double local_lo = 1e9, local_hi = -1e9;
  for (double y = 10; y < 11.5; y += 0.02) {
    for (double x = 10; x < 11.2; x += 0.02) {
      local_lo = std::min(local_lo, scene.HeightMm(x, y));
      local_hi = std::max(local_hi, scene.HeightMm(x, y));
    }
  }
  EXPECT_GT(local_hi - local_lo, 0.2);
  EXPECT_LT(local_hi - local_lo, 0.8);
}

TEST(TextileScene, PlainWeaveAlternatesOverAndUnderAtCrossings) {
  TextileSceneOptions options;
  options.weave = WeavePattern::kPlain;
  options.fold_amplitude_mm = 0;
  options.thread_height_variation = 0;
  options.color_variation = 0;
  const TextileScene scene(options);
  const double top = options.base_thickness_mm + options.thread_height_mm + options.crossing_amplitude_mm;
  for (int i = -5; i < 5; ++i) {
    for (int j = -5; j < 5; ++j) {
      const double x = (i + 0.5) * options.warp_pitch_mm;
      const double y = (j + 0.5) * options.weft_pitch_mm;
      // At a crossing the upper thread's crown is base + height + amplitude;
      // the lower one is 2 * amplitude below, so the soft max adds < 1e-3 mm.
      EXPECT_NEAR(scene.HeightMm(x, y), top, 1e-3) << i << "," << j;
      const Eigen::Vector3d albedo = scene.Albedo(x, y);
      const bool warp_on_top = (i + j) % 2 == 0;
      const Eigen::Vector3d expected = warp_on_top ? options.warp_rgb : options.weft_rgb;
      EXPECT_LT((albedo - expected).cwiseAbs().maxCoeff(), 0.01)
          << i << "," << j << " albedo " << albedo.transpose() << " warp on top " << warp_on_top;
    }
  }
}

TEST(TextileScene, AlbedoStaysInRangeAndWarpDiffersFromWeft) {
  const TextileScene scene;
  int warp_like = 0, weft_like = 0;
  for (double y = -39.9; y <= 39.9; y += 0.173) {
    for (double x = -59.9; x <= 59.9; x += 0.191) {
      const Eigen::Vector3d a = scene.Albedo(x, y);
      ASSERT_GE(a.minCoeff(), 0.05) << x << "," << y;
      ASSERT_LE(a.maxCoeff(), 0.9) << x << "," << y;
      if (a.z() > 1.5 * a.x()) ++warp_like;   // indigo
      if (a.x() > 1.5 * a.z()) ++weft_like;   // ecru
    }
  }
  // Both thread colours show in roughly equal shares (a twill shows both).
  EXPECT_GT(warp_like, 20000);
  EXPECT_GT(weft_like, 20000);
  // Off the sample: the neutral grey table.
  EXPECT_EQ(scene.Albedo(61, 0), scene.options().table_rgb);
  EXPECT_EQ(scene.Albedo(0, -41), scene.options().table_rgb);
  const Eigen::Vector3d table = scene.options().table_rgb;
  EXPECT_EQ(table.x(), table.y());
  EXPECT_EQ(table.y(), table.z());
}

TEST(TextileScene, ThreadsVaryFromOneToTheNext) {
  TextileSceneOptions options;
  options.weave = WeavePattern::kPlain;
  options.fold_amplitude_mm = 0;
  options.warp_pitch_mm = 1.2;  // 20 crowns stay well inside the sample
  options.weft_pitch_mm = 1.5;
  const TextileScene scene(options);
  // Crowns of 20 warps at their over-crossings: not all equal.
  double lo = 1e9, hi = -1e9;
  for (int i = 0; i < 40; i += 2) {
    const double h = scene.HeightMm((i + 0.5) * options.warp_pitch_mm, 0.5 * options.weft_pitch_mm);
    lo = std::min(lo, h);
    hi = std::max(hi, h);
  }
  EXPECT_GT(hi - lo, 0.01);
  EXPECT_LT(hi - lo, 2 * options.thread_height_variation * options.thread_height_mm + 1e-3);
}

TEST(TextileScene, OnSampleIsTheRectangle) {
  const TextileScene scene;
  EXPECT_TRUE(scene.OnSample(0, 0));
  EXPECT_TRUE(scene.OnSample(60, 40));
  EXPECT_TRUE(scene.OnSample(-60, -40));
  EXPECT_TRUE(scene.OnSample(59.9, -39.9));
  EXPECT_FALSE(scene.OnSample(60.01, 0));
  EXPECT_FALSE(scene.OnSample(0, -40.01));
  EXPECT_FALSE(scene.OnSample(-70, 50));
}

TEST(TextileScene, SeedFixesTheVariation) {
  TextileSceneOptions a_options, b_options;
  b_options.seed = a_options.seed + 1;
  const TextileScene a(a_options), a_again(a_options), b(b_options);
  int differing = 0;
  for (int i = 0; i < 100; ++i) {
    const double x = -50 + i, y = 30 - 0.6 * i;
    EXPECT_EQ(a.HeightMm(x, y), a_again.HeightMm(x, y));
    EXPECT_EQ(a.Albedo(x, y), a_again.Albedo(x, y));
    if (std::abs(a.HeightMm(x, y) - b.HeightMm(x, y)) > 1e-3) ++differing;
  }
  EXPECT_GT(differing, 90);
}

TEST(TextileScene, CheckNamesTheFieldValueAndRule) {
  auto expect_error = [](TextileSceneOptions options, const std::string& field) {
    try {
      options.Check();
      ADD_FAILURE() << "no error for " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(field));
      EXPECT_THAT(e.what(), ::testing::HasSubstr("must"));
    }
    EXPECT_THROW(TextileScene{options}, std::invalid_argument);
  };
  TextileSceneOptions o;
  EXPECT_NO_THROW(o.Check());
  o.warp_pitch_mm = 0;
  expect_error(o, "warp_pitch_mm");
  o = {};
  o.sample_width_mm = -1;
  expect_error(o, "sample_width_mm");
  o = {};
  o.edge_blend_mm = 50;
  expect_error(o, "edge_blend_mm");
  o = {};
  o.fold_max_wavelength_mm = 10;
  expect_error(o, "fold_max_wavelength_mm");
  o = {};
  o.weft_rgb = Eigen::Vector3d(0.5, 1.2, 0.5);
  expect_error(o, "weft_rgb[1]");
  o = {};
  o.num_fold_waves = -1;
  expect_error(o, "num_fold_waves");
  o = {};
  o.smoothing_mm = 0;
  expect_error(o, "smoothing_mm");
  o = {};
  o.sample = SampleKind::kColorChecker;
  o.chart_pitch_mm = 10;  // below the 16 mm patch
  expect_error(o, "chart_pitch_mm");
  o.chart_pitch_mm = 20;
  o.chart_gloss = 0.5;
  expect_error(o, "chart_gloss");
}

// ----------------------------------------------------------------------------
// The ColorChecker card.

TEST(ColorCheckerScene, PatchGridIsInChartOrderWithDarkSkinTopLeft) {
  // 16 mm patches, 20 mm pitch: centres at u = -50 .. 50, v = 30 .. -30.
  EXPECT_EQ(ColorCheckerPatchIndexAt(-50, 30, 16, 20), 0);    // dark skin: image top left (-x, +y)
  EXPECT_EQ(ColorCheckerPatchIndexAt(50, 30, 16, 20), 5);     // bluish green: top right
  EXPECT_EQ(ColorCheckerPatchIndexAt(-50, -30, 16, 20), 18);  // white: bottom left
  EXPECT_EQ(ColorCheckerPatchIndexAt(50, -30, 16, 20), 23);   // black: bottom right
  EXPECT_EQ(ColorCheckerPatchIndexAt(-10 + 7.9, 10 - 7.9, 16, 20), 8);  // inside "moderate red"
  EXPECT_EQ(ColorCheckerPatchIndexAt(-10 + 8.1, 10, 16, 20), -1);       // in the gap
  EXPECT_EQ(ColorCheckerPatchIndexAt(62, 0, 16, 20), -1);               // beyond the grid
  EXPECT_EQ(ColorCheckerClassic()[18].name.rfind("white", 0), 0u);
}

TEST(ColorCheckerScene, FlatCardWithPatchColoursSurroundAndABlendedEdge) {
  TextileSceneOptions o;
  o.sample = SampleKind::kColorChecker;
  const TextileScene scene(o);
  // 116 x 76 mm grid + the 4 mm border on each side.
  EXPECT_NEAR(scene.SampleExtentMm().x(), 124.0, 1e-12);
  EXPECT_NEAR(scene.SampleExtentMm().y(), 84.0, 1e-12);
  EXPECT_DOUBLE_EQ(scene.MaxHeightMm(), o.chart_thickness_mm);
  for (int k = 0; k < 24; ++k) {
    const double u = (k % 6 - 2.5) * 20, v = (1.5 - k / 6) * 20;
    const SurfaceSample s = scene.Sample(u + 3, v - 5);
    EXPECT_EQ(s.spectral_patch, k);
    EXPECT_EQ(s.albedo, ColorCheckerClassic()[k].linear_rec709) << k;
    EXPECT_DOUBLE_EQ(s.height_mm, o.chart_thickness_mm);
    EXPECT_EQ(s.gradient, Eigen::Vector2d::Zero());
    EXPECT_DOUBLE_EQ(s.gloss, o.chart_gloss);
  }
  const SurfaceSample gap = scene.Sample(-40, 0);
  EXPECT_EQ(gap.spectral_patch, -1);
  EXPECT_EQ(gap.albedo, o.chart_surround_rgb);
  const SurfaceSample table = scene.Sample(0, 43);
  EXPECT_EQ(table.albedo, o.table_rgb);
  EXPECT_EQ(table.height_mm, 0.0);
  EXPECT_EQ(table.gloss, 0.0);
  // The edge ramps within chart_edge_blend_mm, with the analytic gradient.
  const double edge = 0.5 * scene.SampleExtentMm().x();
  EXPECT_GT(scene.HeightMm(edge - 0.5, 0), 0.0);
  EXPECT_LT(scene.HeightMm(edge - 0.5, 0), o.chart_thickness_mm);
  for (const double x : {edge - 0.9, edge - 0.5, edge - 0.1}) {
    const Eigen::Vector2d numeric = FiniteDifferenceGradient(scene, x, 1.0, 1e-6);
    EXPECT_NEAR(scene.HeightGradient(x, 1.0).x(), numeric.x(), 1e-5) << x;
  }
}

}  // namespace
}  // namespace scanbench

namespace scanbench {
namespace {

// Textile fibres are dielectrics: F0 = ((n - 1) / (n + 1))^2 for the fibres'
// refractive indices (silk ~1.54-1.56, cotton ~1.53-1.58, nylon ~1.53-1.57,
// polyester ~1.57-1.64) lies in ~[0.044, 0.058]; no default is metal-like.
TEST(TextileMaterialDefaults, SpecularF0IsThatOfADielectricFibre) {
  auto f0 = [](double n) { return std::pow((n - 1) / (n + 1), 2); };
  const TextileSceneOptions o;
  for (const ThreadBrdf& b : {o.cloth_warp, o.cloth_weft, o.satin_warp, o.satin_weft}) {
    EXPECT_GE(b.specular_f0, f0(1.53) - 1e-9);
    EXPECT_LE(b.specular_f0, f0(1.64) + 1e-9);
  }
  // With the per-thread variation the F0 still stays a dielectric's (< 0.07).
  for (SurfaceMaterial m : {SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    TextileSceneOptions options;
    options.material = m;
    const TextileScene scene(options);
    for (int64_t i = -30; i < 30; ++i) {
      EXPECT_LT(scene.ThreadBrdfOf(true, i).specular_f0, 0.07);
      EXPECT_LT(scene.ThreadBrdfOf(false, i).specular_f0, 0.07);
    }
  }
}

// Satin's gloss comes from smooth aligned floats, not from a high F0: at the
// mirror direction (camera overhead, light 30 deg off the normal, the rig's
// high ring) the default warp's specular reading is well above the diffuse
// reading of its indigo thread and above a mid-grey's, and it falls off
// sharply 10 deg away along the thread.
TEST(TextileMaterialDefaults, SatinHighlightIsWellAboveTheDiffuseAtTheMirrorDirection) {
  const TextileSceneOptions o;
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d v = Eigen::Vector3d(std::sin(0.2618), 0, std::cos(0.2618));   // 15 deg
  const Eigen::Vector3d l = Eigen::Vector3d(-std::sin(0.2618), 0, std::cos(0.2618));  // mirror
  const MaterialResponse r = EvaluateMaterial(SurfaceMaterial::kSatin, o.satin_warp, n, Eigen::Vector3d::UnitY(), l, v);
  const double indigo_luminance = Eigen::Vector3d(0.2126, 0.7152, 0.0722).dot(o.warp_rgb);
  EXPECT_GT(r.specular, 3.0 * r.diffuse * indigo_luminance) << r.specular << " vs " << r.diffuse;
  EXPECT_GT(r.specular, 0.5 * r.diffuse) << r.specular << " vs " << r.diffuse;
  // 10 deg off along the thread (y) the lobe is mostly gone.
  const Eigen::Vector3d l_off = Eigen::AngleAxisd(0.1745, Eigen::Vector3d::UnitX()) * l;
  const MaterialResponse off =
      EvaluateMaterial(SurfaceMaterial::kSatin, o.satin_warp, n, Eigen::Vector3d::UnitY(), l_off, v);
  EXPECT_LT(off.specular, 0.3 * r.specular);
}

}  // namespace
}  // namespace scanbench
