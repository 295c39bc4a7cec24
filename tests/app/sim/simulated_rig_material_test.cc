// The simulated rig's textile materials (issue #13): lambert unchanged,
// ground truth independent of the material, cloth's sheen and satin's
// anisotropic gloss where the rig renders them.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "app/sim/simulated_rig.h"
#include "calibration/camera_model.h"

namespace scanbench {
namespace {

template <typename T>
bool Same(const Image<T>& a, const Image<T>& b) {
  return a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels() &&
         std::equal(a.data(), a.data() + a.size(), b.data());
}

SimulatedRigOptions SmallOptions() {
  SimulatedRigOptions options;
  options.width = kD5100Width / 16;
  options.height = kD5100Height / 16;
  options.add_noise = false;
  return options;
}

SimulatedRig MakeRig(const SimulatedRigOptions& options, const TextileSceneOptions& scene) {
  return SimulatedRig(options, TextileScene(scene), MakeDefaultSimulatedRig(options.width, options.height, options.color));
}

// A nearly flat weave (threads a few hundredths of a mm high, no folds): the
// normal stays within ~2 deg of z, so the light angle alone varies per LED.
TextileSceneOptions FlatWeave(SurfaceMaterial material) {
  TextileSceneOptions scene;
  scene.material = material;
  scene.thread_height_mm = 0.02;
  scene.crossing_amplitude_mm = 0.01;
  scene.smoothing_mm = 0.001;
  scene.fold_amplitude_mm = 0;
  scene.num_fold_waves = 0;
  scene.fibre_tilt_deg = 0;
  scene.material_variation = 0;
  return scene;
}

TEST(SimulatedRigMaterial, LambertFramesIgnoreTheOtherMaterialsParameters) {
  const SimulatedRigOptions options = SmallOptions();
  TextileSceneOptions changed;  // kLambert by default
  changed.cloth_warp = {0.9, 1.5, 1.5};
  changed.satin_weft = {0.9, 0.05, 0.05};
  changed.fibre_tilt_deg = 15;
  const SimulatedRig a = MakeRig(options, TextileSceneOptions());
  const SimulatedRig b = MakeRig(options, changed);
  for (const std::optional<int> led : {std::optional<int>(), std::optional<int>(2), std::optional<int>(8)}) {
    EXPECT_TRUE(Same(a.RenderFrame(led, 4).mosaic, b.RenderFrame(led, 4).mosaic));
  }
}

// The truth is the diffuse albedo and the pixel-scale normal: the geometric
// normal off the threads, the mean of the fibres' shading normals on them (a
// few degrees at most from the geometric one at this coarse size).
TEST(SimulatedRigMaterial, GroundTruthIsTheDiffuseAlbedoAndThePixelScaleNormalWhateverTheMaterial) {
  const SimulatedRigOptions options = SmallOptions();
  const GroundTruthMaps lambert = MakeRig(options, TextileSceneOptions()).RenderGroundTruth();
  for (SurfaceMaterial m : {SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    TextileSceneOptions scene;
    scene.material = m;
    const SimulatedRig rig = MakeRig(options, scene);
    const GroundTruthMaps truth = rig.RenderGroundTruth();
    int threads = 0;
    double sum_deg = 0, max_deg = 0;
    for (int y = 0; y < rig.height(); ++y) {
      for (int x = 0; x < rig.width(); ++x) {
        double dot = 0;
        for (int c = 0; c < 3; ++c) dot += truth.normal_in_table(x, y, c) * lambert.normal_in_table(x, y, c);
        const double deg = std::acos(std::min(1.0, dot)) * 180 / M_PI;
        if (rig.FootprintShadingNormals(x, y).empty()) {
          for (int c = 0; c < 3; ++c) {
            ASSERT_EQ(truth.normal_in_table(x, y, c), lambert.normal_in_table(x, y, c)) << x << "," << y;
          }
          continue;
        }
        ++threads;
        sum_deg += deg;
        max_deg = std::max(max_deg, deg);
      }
    }
    ASSERT_GT(threads, rig.width() * rig.height() / 4) << SurfaceMaterialName(m);
    EXPECT_GT(sum_deg / threads, 0.2) << SurfaceMaterialName(m);
    EXPECT_LT(sum_deg / threads, 3.0) << SurfaceMaterialName(m);
    EXPECT_LT(max_deg, 10.0) << SurfaceMaterialName(m);
    EXPECT_TRUE(Same(truth.albedo, lambert.albedo)) << SurfaceMaterialName(m);
    EXPECT_TRUE(Same(truth.point_in_table, lambert.point_in_table)) << SurfaceMaterialName(m);
    EXPECT_TRUE(Same(truth.sample_mask, lambert.sample_mask)) << SurfaceMaterialName(m);
    // ... while the frames differ.
    EXPECT_FALSE(Same(rig.RenderLinear(0), MakeRig(options, TextileSceneOptions()).RenderLinear(0))) << SurfaceMaterialName(m);
  }
}

// Mean over the central sample pixels selected by `keep` of material / lambert
// (dark-frame subtracted) for LED `led`, green channel.
template <typename Keep>
double MeanRatio(const SimulatedRig& material, const SimulatedRig& lambert, int led, Keep keep) {
  const ImageF m = material.RenderLinear(led), l = lambert.RenderLinear(led);
  const ImageF m0 = material.RenderLinear(std::nullopt), l0 = lambert.RenderLinear(std::nullopt);
  const GroundTruthMaps truth = lambert.RenderGroundTruth();
  double sum = 0;
  int count = 0;
  for (int y = material.height() / 4; y < 3 * material.height() / 4; ++y) {
    for (int x = material.width() / 4; x < 3 * material.width() / 4; ++x) {
      const SurfaceSample s = material.scene().Sample(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1));
      if (!keep(s)) continue;
      const double lv = l(x, y, 1) - l0(x, y, 1);
      if (!(lv > 1e-4)) continue;
      sum += (m(x, y, 1) - m0(x, y, 1)) / lv;
      ++count;
    }
  }
  EXPECT_GT(count, 50);
  return count > 0 ? sum / count : 0.0;
}

// Cloth's sheen in the rig: relative to the Lambertian render of the same
// scene (equal n.l pixel for pixel), the low ring (30 deg elevation, 60 deg
// from the normal) gains more than the high ring (60 deg elevation). With a
// dielectric fibre's F0 (~0.05) the sheen is a few per cent of the diffuse
// reading, most on the dark indigo warp.
TEST(SimulatedRigMaterial, ClothGainsTowardGrazingLightRelativeToLambert) {
  const SimulatedRigOptions options = SmallOptions();
  const SimulatedRig cloth = MakeRig(options, FlatWeave(SurfaceMaterial::kCloth));
  const SimulatedRig lambert = MakeRig(options, FlatWeave(SurfaceMaterial::kLambert));
  auto all = [](const SurfaceSample& s) { return s.warp_weight >= 0; };
  auto warp = [](const SurfaceSample& s) { return s.warp_weight > 0.95; };
  double low = 0, high = 0, warp_low = 0, warp_high = 0;
  for (int led = 0; led < 5; ++led) low += MeanRatio(cloth, lambert, led, all) / 5;
  for (int led = 5; led < 10; ++led) high += MeanRatio(cloth, lambert, led, all) / 5;
  for (int led = 0; led < 5; ++led) warp_low += MeanRatio(cloth, lambert, led, warp) / 5;
  for (int led = 5; led < 10; ++led) warp_high += MeanRatio(cloth, lambert, led, warp) / 5;
  EXPECT_GT(low, high * 1.01) << "low ring " << low << ", high ring " << high;
  EXPECT_GT(warp_low, warp_high * 1.03) << "warp: low ring " << warp_low << ", high ring " << warp_high;
}

// Satin's lobe follows the thread: long aligned floats are smooth along the
// fibres, so the lobe is narrow along the thread and wide across it. LED 6
// (azimuth 108 deg, light along ~y) and LED 7 (179.4 deg, along -x) are both
// at 60 deg elevation; a warp thread (along y) keeps more of LED 7's
// highlight, a weft thread (along x) of LED 6's.
TEST(SimulatedRigMaterial, SatinHighlightIsNarrowAlongTheThread) {
  const SimulatedRigOptions options = SmallOptions();
  const SimulatedRig satin = MakeRig(options, FlatWeave(SurfaceMaterial::kSatin));
  const SimulatedRig lambert = MakeRig(options, FlatWeave(SurfaceMaterial::kLambert));
  auto warp = [](const SurfaceSample& s) { return s.warp_weight > 0.95; };
  auto weft = [](const SurfaceSample& s) { return s.warp_weight >= 0 && s.warp_weight < 0.05; };
  const double warp_y = MeanRatio(satin, lambert, 6, warp), warp_x = MeanRatio(satin, lambert, 7, warp);
  const double weft_y = MeanRatio(satin, lambert, 6, weft), weft_x = MeanRatio(satin, lambert, 7, weft);
  EXPECT_GT(warp_x, 1.05 * warp_y) << warp_x << " vs " << warp_y;
  EXPECT_GT(weft_y, 1.05 * weft_x) << weft_y << " vs " << weft_x;
}

// The fibres are below the pixel: a pixel reads the MEAN of the material's
// response over its footprint sub-samples' shading normals, as a sensor
// integrates it. Recomputed here from the public pieces for unshadowed pixels.
TEST(SimulatedRigMaterial, PixelReadsTheMeanResponseOfItsFootprintSubSamples) {
  SimulatedRigOptions options = SmallOptions();
  options.ambient = 0;
  for (SurfaceMaterial m : {SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    TextileSceneOptions scene;
    scene.material = m;
    const SimulatedRig rig = MakeRig(options, scene);
    const GroundTruthMaps truth = rig.RenderGroundTruth();
    const Eigen::Vector3d camera_centre = CameraCentreInTable(rig.rig().camera);
    constexpr int kLed = 2;
    const LedDescription& led = rig.rig().leds[kLed];
    const ImageF frame = rig.RenderLinear(kLed);
    const ImageU8 shadow = rig.RenderShadowMask(kLed);
    int checked = 0;
    double max_relative_error = 0, mean_spread_deg = 0;
    for (int y = rig.height() / 3; y < 2 * rig.height() / 3; y += 3) {
      for (int x = rig.width() / 3; x < 2 * rig.width() / 3; x += 3) {
        if (shadow(x, y) != 0) continue;
        const std::vector<Eigen::Vector3d> normals = rig.FootprintShadingNormals(x, y);
        if (normals.empty()) continue;
        ASSERT_EQ(normals.size(), static_cast<size_t>(options.footprint_samples));
        const Eigen::Vector3d p(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1),
                                truth.point_in_table(x, y, 2));
        const SurfaceSample s = rig.scene().Sample(p.x(), p.y());
        const Eigen::Vector3d to_led = led.position_in_table_mm - p;
        const Eigen::Vector3d l = to_led.normalized();
        const Eigen::Vector3d v = (camera_centre - p).normalized();
        const double irradiance = std::pow(-led.axis_in_table.dot(l), led.mu) *
                                  kLedReferenceDistanceMm * kLedReferenceDistanceMm / to_led.squaredNorm();
        const ThreadBrdf warp = rig.scene().ThreadBrdfOf(true, s.warp_index);
        const ThreadBrdf weft = rig.scene().ThreadBrdfOf(false, s.weft_index);
        double diffuse = 0, specular = 0;
        const Eigen::Vector3d truth_normal(truth.normal_in_table(x, y, 0), truth.normal_in_table(x, y, 1),
                                        truth.normal_in_table(x, y, 2));
        for (const Eigen::Vector3d& n : normals) {
          const MaterialResponse a = EvaluateMaterial(m, warp, n, Eigen::Vector3d::UnitY(), l, v);
          const MaterialResponse b = EvaluateMaterial(m, weft, n, Eigen::Vector3d::UnitX(), l, v);
          diffuse += (s.warp_weight * a.diffuse + (1 - s.warp_weight) * b.diffuse) / normals.size();
          specular += (s.warp_weight * a.specular + (1 - s.warp_weight) * b.specular) / normals.size();
          mean_spread_deg += std::acos(std::min(1.0, n.dot(truth_normal))) * 180 / M_PI;
        }
        for (int c = 0; c < 3; ++c) {
          const double e = led.rgb_intensity[c] * irradiance;
          const double expected = truth.albedo_white_balanced_camera(x, y, c) * diffuse * e + specular * e;
          max_relative_error = std::max(max_relative_error, std::abs(frame(x, y, c) - expected) / expected);
        }
        ++checked;
      }
    }
    EXPECT_GT(checked, 200) << SurfaceMaterialName(m);
    EXPECT_LT(max_relative_error, 1e-4) << SurfaceMaterialName(m);
    // The sub-samples really tilt (a few degrees off their mean, the truth).
    mean_spread_deg /= checked * options.footprint_samples;
    EXPECT_GT(mean_spread_deg, 1.0) << SurfaceMaterialName(m);
    EXPECT_LT(mean_spread_deg, 5.0) << SurfaceMaterialName(m);
  }
}

// The fibre tilt is zero-mean: over one thread of a flat cloth the mean
// shading normal stays within a small angle of the geometric one, while the
// tilts themselves spread a few degrees (not turned off).
TEST(SimulatedRigMaterial, FibreTiltAveragesToTheGeometricNormalOverAThread) {
  TextileSceneOptions options = FlatWeave(SurfaceMaterial::kCloth);
  options.thread_height_mm = 0;
  options.crossing_amplitude_mm = 0;
  options.fibre_tilt_deg = TextileSceneOptions().fibre_tilt_deg;
  const TextileScene scene(options);
  for (int64_t warp = 0; warp < 3; ++warp) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double sum_tilt2 = 0;
    int count = 0;
    // One warp thread, one twill repeat (four wefts) along it, every 2 um across.
    const double x0 = warp * options.warp_pitch_mm;
    for (double x = x0 + 0.001; x < x0 + options.warp_pitch_mm; x += 0.002) {
      for (double y = 0.0; y < 4 * options.weft_pitch_mm; y += 0.02) {
        const Eigen::Vector2d g = scene.HeightGradient(x, y) + scene.FibreTiltGradient(x, y);
        const Eigen::Vector3d n = Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
        sum += n;
        sum_tilt2 += std::pow(std::acos(std::min(1.0, n.dot(scene.NormalInTable(x, y)))), 2);
        ++count;
      }
    }
    const Eigen::Vector3d mean = sum.normalized();
    const double mean_off_deg = std::acos(std::min(1.0, mean.dot(Eigen::Vector3d::UnitZ()))) * 180 / M_PI;
    const double rms_tilt_deg = std::sqrt(sum_tilt2 / count) * 180 / M_PI;
    EXPECT_LT(mean_off_deg, 0.5) << "warp " << warp;
    EXPECT_GT(rms_tilt_deg, 2.0) << "warp " << warp;
    EXPECT_LT(rms_tilt_deg, 6.0) << "warp " << warp;
  }
}

// The satin's gloss in the rig, footprint-averaged: where a fold puts a warp
// float at the mirror direction of an LED, its specular reading (rendered on
// black threads) is well above the diffuse reading of the same pixel; the
// cloth's sheen stays a small fraction of it.
TEST(SimulatedRigMaterial, SatinHighlightPeaksWellAboveTheDiffuseReading) {
  SimulatedRigOptions options = SmallOptions();
  options.ambient = 0;
  for (SurfaceMaterial m : {SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    TextileSceneOptions scene;
    scene.material = m;
    TextileSceneOptions black = scene;
    black.warp_rgb = black.weft_rgb = Eigen::Vector3d::Zero();
    const SimulatedRig diffuse = MakeRig(options, TextileSceneOptions());  // lambert: albedo x n.l
    const SimulatedRig specular = MakeRig(options, black);
    const ImageU8 on_sample = diffuse.RenderGroundTruth().sample_mask;  // the table stays Lambertian
    double peak = 0;
    for (int led = 0; led < 10; ++led) {
      const ImageF d = diffuse.RenderLinear(led), s = specular.RenderLinear(led);
      for (int y = 0; y < d.height(); ++y) {
        for (int x = 0; x < d.width(); ++x) {
          if (on_sample(x, y) && d(x, y, 1) > 1e-3) peak = std::max(peak, double{s(x, y, 1)} / d(x, y, 1));
        }
      }
    }
    if (m == SurfaceMaterial::kSatin) {
      EXPECT_GT(peak, 2.0) << "satin specular / diffuse peak";
    } else {
      EXPECT_LT(peak, 0.5) << "cloth sheen / diffuse peak";
    }
    std::cout << SurfaceMaterialName(m) << ": peak specular / diffuse reading " << peak << "\n";
  }
}

// At the default size a pixel's footprint holds ~6 fibres, so its mean
// shading normal scatters about the geometric one (as a real pixel's does)
// by about the fibres' rms tilt over sqrt(6): about a degree, not more. That
// mean is the pixel-scale normal of the surface the pixel sees, so it is the
// ground truth on the threads; off them the truth is the geometric normal.
TEST(SimulatedRigMaterial, TruthIsThePixelMeanShadingNormalWhichScattersAboutTheGeometricOne) {
  SimulatedRigOptions options;
  options.add_noise = false;
  TextileSceneOptions scene;
  scene.material = SurfaceMaterial::kSatin;
  const SimulatedRig rig = MakeRig(options, scene);
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  double sum2 = 0, max_truth_gap = 0, max_table_gap = 0;
  int count = 0, table_count = 0;
  for (int y = rig.height() / 4; y < 3 * rig.height() / 4; y += 7) {
    for (int x = rig.width() / 4; x < 3 * rig.width() / 4; x += 7) {
      const Eigen::Vector3d truth_normal(truth.normal_in_table(x, y, 0), truth.normal_in_table(x, y, 1),
                                         truth.normal_in_table(x, y, 2));
      const Eigen::Vector3d geometric =
          rig.scene().NormalInTable(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1));
      const std::vector<Eigen::Vector3d> normals = rig.FootprintShadingNormals(x, y);
      if (normals.empty()) {
        max_table_gap = std::max(max_table_gap, (truth_normal - geometric).norm());
        ++table_count;
        continue;
      }
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const Eigen::Vector3d& n : normals) mean += n;
      max_truth_gap = std::max(max_truth_gap, (truth_normal - mean.normalized()).norm());
      sum2 += std::pow(std::acos(std::min(1.0, mean.normalized().dot(geometric))), 2);
      ++count;
    }
  }
  ASSERT_GT(count, 1000);
  EXPECT_LT(max_truth_gap, 1e-6);  // float storage
  if (table_count > 0) {  // the sampled centre may hold no table pixel
    EXPECT_LT(max_table_gap, 1e-3);  // the rig stores the normal's xy as float
  }
  const double rms_deg = std::sqrt(sum2 / count) * 180 / M_PI;
  std::cout << "pixel mean shading normal vs geometric: " << rms_deg << " deg rms\n";
  EXPECT_GT(rms_deg, 0.3);
  EXPECT_LT(rms_deg, 2.0);
}

// A fibre as wide as a pixel would be resolved structure (geometry), not a
// sub-pixel variation to integrate: refused, naming the field.
TEST(SimulatedRigMaterial, FibresWiderThanThePixelAreRefused) {
  SimulatedRigOptions options = SmallOptions();  // ~0.46 mm per pixel
  TextileSceneOptions scene;
  scene.material = SurfaceMaterial::kSatin;
  scene.fibre_diameter_mm = 0.1;
  EXPECT_NO_THROW(MakeRig(options, scene));
  options.width = 1600;
  options.height = 1060;  // ~0.089 mm per pixel
  try {
    MakeRig(options, scene);
    ADD_FAILURE() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fibre_diameter_mm"), std::string::npos) << e.what();
  }
}

// The sheen and gloss are the LED's white: on black threads with no ambient
// light, every channel reads the LED's raw white times one factor.
TEST(SimulatedRigMaterial, SpecularPartIsTheLedsWhite) {
  SimulatedRigOptions options = SmallOptions();
  options.ambient = 0;
  for (SurfaceMaterial m : {SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    TextileSceneOptions scene;
    scene.material = m;
    scene.warp_rgb = scene.weft_rgb = Eigen::Vector3d::Zero();
    const SimulatedRig rig = MakeRig(options, scene);
    const ImageF frame = rig.RenderLinear(3);
    const Eigen::Vector3d white = rig.rig().leds[3].rgb_intensity;
    const int x = rig.width() / 2, y = rig.height() / 2;
    ASSERT_GT(frame(x, y, 1), 1e-5) << SurfaceMaterialName(m);
    EXPECT_NEAR(frame(x, y, 0) / white[0], frame(x, y, 1) / white[1], 1e-4 * frame(x, y, 1) / white[1]);
    EXPECT_NEAR(frame(x, y, 2) / white[2], frame(x, y, 1) / white[1], 1e-4 * frame(x, y, 1) / white[1]);
  }
}

TEST(SimulatedRigMaterial, OptionsCheckNamesTheField) {
  TextileSceneOptions scene;
  scene.fibre_tilt_deg = 30;
  EXPECT_THROW(TextileScene{scene}, std::invalid_argument);
  scene = {};
  scene.satin_warp.roughness_across = 0;
  try {
    TextileScene{scene};
    ADD_FAILURE() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("satin_warp.roughness_across"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace scanbench
