// The simulated rig's textile materials (issue #13): lambert unchanged,
// ground truth independent of the material, cloth's sheen and satin's
// anisotropic gloss where the rig renders them.
#include <algorithm>
#include <cmath>
#include <string>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "app/sim/simulated_rig.h"

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

TEST(SimulatedRigMaterial, GroundTruthIsTheGeometricNormalAndDiffuseAlbedoWhateverTheMaterial) {
  const SimulatedRigOptions options = SmallOptions();
  const GroundTruthMaps lambert = MakeRig(options, TextileSceneOptions()).RenderGroundTruth();
  for (SurfaceMaterial m : {SurfaceMaterial::kCloth, SurfaceMaterial::kSatin}) {
    TextileSceneOptions scene;
    scene.material = m;
    const SimulatedRig rig = MakeRig(options, scene);
    const GroundTruthMaps truth = rig.RenderGroundTruth();
    EXPECT_TRUE(Same(truth.normal_in_table, lambert.normal_in_table)) << SurfaceMaterialName(m);
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
// from the normal) gains more than the high ring (60 deg elevation).
TEST(SimulatedRigMaterial, ClothGainsTowardGrazingLightRelativeToLambert) {
  const SimulatedRigOptions options = SmallOptions();
  const SimulatedRig cloth = MakeRig(options, FlatWeave(SurfaceMaterial::kCloth));
  const SimulatedRig lambert = MakeRig(options, FlatWeave(SurfaceMaterial::kLambert));
  auto all = [](const SurfaceSample& s) { return s.warp_weight >= 0; };
  double low = 0, high = 0;
  for (int led = 0; led < 5; ++led) low += MeanRatio(cloth, lambert, led, all) / 5;
  for (int led = 5; led < 10; ++led) high += MeanRatio(cloth, lambert, led, all) / 5;
  EXPECT_GT(low, high * 1.03) << "low ring " << low << ", high ring " << high;
}

// Satin's lobe follows the thread: LED 6 (azimuth 108 deg, light along ~y)
// and LED 7 (179.4 deg, along -x) are both at 60 deg elevation; a warp thread
// (along y) keeps more of LED 6's highlight, a weft thread (along x) of LED 7's.
TEST(SimulatedRigMaterial, SatinHighlightStretchesAlongTheThread) {
  const SimulatedRigOptions options = SmallOptions();
  const SimulatedRig satin = MakeRig(options, FlatWeave(SurfaceMaterial::kSatin));
  const SimulatedRig lambert = MakeRig(options, FlatWeave(SurfaceMaterial::kLambert));
  auto warp = [](const SurfaceSample& s) { return s.warp_weight > 0.95; };
  auto weft = [](const SurfaceSample& s) { return s.warp_weight >= 0 && s.warp_weight < 0.05; };
  const double warp_y = MeanRatio(satin, lambert, 6, warp), warp_x = MeanRatio(satin, lambert, 7, warp);
  const double weft_y = MeanRatio(satin, lambert, 6, weft), weft_x = MeanRatio(satin, lambert, 7, weft);
  EXPECT_GT(warp_y, 1.1 * warp_x) << warp_y << " vs " << warp_x;
  EXPECT_GT(weft_x, 1.1 * weft_y) << weft_x << " vs " << weft_y;
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
