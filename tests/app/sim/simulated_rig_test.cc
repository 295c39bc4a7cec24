#include "app/sim/simulated_rig.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/sim/sensor_color.h"
#include "calibration/camera_model.h"
#include "calibration/color_checker.h"
#include "calibration/color_science.h"
#include "tests/app/sim/light_model.h"

namespace scanbench {
namespace {


// 1/16 of a D5100 each way: fast, and still 0.46 mm per pixel.
constexpr int kSmallWidth = kD5100Width / 16;
constexpr int kSmallHeight = kD5100Height / 16;

SimulatedRigOptions SmallOptions() {
  SimulatedRigOptions options;
  options.width = kSmallWidth;
  options.height = kSmallHeight;
  return options;
}

SimulatedRig MakeRig(const SimulatedRigOptions& options, const TextileSceneOptions& scene_options = {}) {
  return SimulatedRig(options, TextileScene(scene_options),
                      MakeDefaultSimulatedRig(options.width, options.height, options.color));
}

double Range(const SimulatedRigOptions& o) { return o.white_level - o.black_level; }

using testing::ExpectedDirect;

// ----------------------------------------------------------------------------
// Rig truth.

TEST(DefaultSimulatedRig, LedsAreAboveTheTableAndAimedAtTheCentre) {
  const RigDescription rig = MakeDefaultSimulatedRig(1232, 816);
  ASSERT_EQ(rig.leds.size(), 10u);
  int low_ring = 0, high_ring = 0;
  for (size_t k = 0; k < rig.leds.size(); ++k) {
    const LedDescription& led = rig.leds[k];
    EXPECT_EQ(led.id, static_cast<int>(k));
    const Eigen::Vector3d& p = led.position_in_table_mm;
    EXPECT_GT(p.z(), 200.0) << k;
    EXPECT_GT(p.norm(), 450.0) << k;
    EXPECT_LT(p.norm(), 550.0) << k;
    EXPECT_NEAR(led.axis_in_table.norm(), 1.0, 1e-12);
    EXPECT_LT((led.axis_in_table - (-p).normalized()).norm(), 1e-12) << k;
    EXPECT_GE(led.mu, 1.0);
    EXPECT_LE(led.mu, 3.0);
    const double elevation_deg = std::asin(p.z() / p.norm()) * 180.0 / std::numbers::pi;
    if (std::abs(elevation_deg - 30) < 2) ++low_ring;
    if (std::abs(elevation_deg - 60) < 2) ++high_ring;
  }
  EXPECT_EQ(low_ring, 5);
  EXPECT_EQ(high_ring, 5);
}

TEST(DefaultSimulatedRig, BrightestLedGivesAboutSeventyPercentAtTheCentre) {
  const RigDescription rig = MakeDefaultSimulatedRig(1232, 816);
  double brightest = 0, dimmest_green = 1e9, brightest_green = 0;
  for (const LedDescription& led : rig.leds) {
    const Eigen::Vector3d point = Eigen::Vector3d::Zero();
    const Eigen::Vector3d facing = (led.position_in_table_mm - point).normalized();
    for (int c = 0; c < 3; ++c) {
      EXPECT_GT(led.rgb_intensity[c], 0.0);
      brightest = std::max(brightest, ExpectedDirect(led, point, facing, c));
    }
    dimmest_green = std::min(dimmest_green, led.rgb_intensity[1]);
    brightest_green = std::max(brightest_green, led.rgb_intensity[1]);
    // Raw white balance: green strongest, tints small.
    EXPECT_LT(led.rgb_intensity[0], led.rgb_intensity[1]);
    EXPECT_LT(led.rgb_intensity[2], led.rgb_intensity[1]);
  }
  EXPECT_GE(brightest, 0.6);
  EXPECT_LE(brightest, 0.8);
  // +-10 % from LED to LED.
  EXPECT_LT(brightest_green / dimmest_green, 1.25);
  EXPECT_GT(brightest_green / dimmest_green, 1.05);
}

TEST(DefaultSimulatedRig, IntrinsicsAreValidAndScaleWithBinning) {
  const RigDescription full = MakeDefaultSimulatedRig(kD5100Width, kD5100Height);
  const RigDescription quarter = MakeDefaultSimulatedRig(kD5100Width / 4, kD5100Height / 4);
  EXPECT_NO_THROW(CheckCameraIntrinsics(full.camera.intrinsics));
  EXPECT_NO_THROW(CheckCameraIntrinsics(quarter.camera.intrinsics));
  EXPECT_NO_THROW(CheckCameraIntrinsics(MakeDefaultSimulatedRig(kSmallWidth, kSmallHeight).camera.intrinsics));
  EXPECT_NEAR(full.camera.intrinsics.fx / quarter.camera.intrinsics.fx, 4.0, 1e-12);
  EXPECT_NEAR(full.camera.intrinsics.fy / quarter.camera.intrinsics.fy, 4.0, 1e-12);
  // Square pixels: the sensor's 23.6 x 15.6 mm match 4928 x 3264 to 0.1 %.
  EXPECT_NEAR(full.camera.intrinsics.fx / full.camera.intrinsics.fy, 1.0, 2e-3);
  // Same field of view: a table point lands on the same fraction of the frame.
  const Eigen::Vector3d corner_in_table(55, 35, 0);
  const Eigen::Vector2d a = ProjectToPixel(full.camera.intrinsics, full.camera.cam_from_table * corner_in_table);
  const Eigen::Vector2d b =
      ProjectToPixel(quarter.camera.intrinsics, quarter.camera.cam_from_table * corner_in_table);
  EXPECT_NEAR((a.x() + 0.5) / kD5100Width, (b.x() + 0.5) / (kD5100Width / 4), 1e-9);
  EXPECT_NEAR((a.y() + 0.5) / kD5100Height, (b.y() + 0.5) / (kD5100Height / 4), 1e-9);
  EXPECT_THROW(MakeDefaultSimulatedRig(0, 100), std::invalid_argument);
}

TEST(DefaultSimulatedRig, DistortionIsMild) {
  const RigDescription rig = MakeDefaultSimulatedRig(kD5100Width, kD5100Height);
  CameraIntrinsics pinhole = rig.camera.intrinsics;
  pinhole.k1 = pinhole.k2 = pinhole.k3 = pinhole.p1 = pinhole.p2 = 0;
  double worst = 0;
  for (double x : {-70.0, 0.0, 70.0}) {
    for (double y : {-46.0, 0.0, 46.0}) {
      const Eigen::Vector3d p = rig.camera.cam_from_table * Eigen::Vector3d(x, y, 0);
      worst = std::max(worst, (ProjectToPixel(rig.camera.intrinsics, p) - ProjectToPixel(pinhole, p)).norm());
    }
  }
  EXPECT_GT(worst, 0.3);   // present: full-resolution pixels
  EXPECT_LT(worst, 10.0);  // and mild, as for a short-tele prime
}

TEST(DefaultSimulatedRig, SampleCentreProjectsNearTheImageCentreWithTableAxesAlongTheImage) {
  for (auto [w, h] : {std::pair{1232, 816}, std::pair{kD5100Width, kD5100Height}}) {
    const RigDescription rig = MakeDefaultSimulatedRig(w, h);
    const auto project = [&](double x, double y, double z) {
      return ProjectToPixel(rig.camera.intrinsics, rig.camera.cam_from_table * Eigen::Vector3d(x, y, z));
    };
    const Eigen::Vector2d centre = project(0, 0, 0);
    EXPECT_NEAR(centre.x(), 0.5 * (w - 1), 0.02 * w);
    EXPECT_NEAR(centre.y(), 0.5 * (h - 1), 0.02 * h);
    // Image x ~ table +x, image up ~ table +y.
    const Eigen::Vector2d right = project(10, 0, 0) - centre;
    const Eigen::Vector2d up = project(0, 10, 0) - centre;
    EXPECT_GT(right.x(), 0.99 * right.norm());
    EXPECT_LT(up.y(), -0.99 * up.norm());
    // About 600 mm above the table, looking down.
    const Eigen::Vector3d camera_centre = CameraCentreInTable(rig.camera);
    EXPECT_NEAR(camera_centre.z(), 600.0, 5.0);
    const Eigen::Vector3d optical_axis_in_table = rig.camera.cam_from_table.rotation().transpose().col(2);
    EXPECT_LT(optical_axis_in_table.z(), -0.99);
  }
}

TEST(DefaultSimulatedRig, SampleFitsInTheFrameAndFillsMuchOfIt) {
  const RigDescription rig = MakeDefaultSimulatedRig(1232, 816);
  const TextileScene scene;
  const double hw = 0.5 * scene.options().sample_width_mm, hh = 0.5 * scene.options().sample_height_mm;
  double min_x = 1e9, max_x = -1e9, min_y = 1e9, max_y = -1e9;
  for (double z : {0.0, scene.MaxHeightMm()}) {
    for (double sx : {-1.0, 1.0}) {
      for (double sy : {-1.0, 1.0}) {
        const Eigen::Vector2d p =
            ProjectToPixel(rig.camera.intrinsics, rig.camera.cam_from_table * Eigen::Vector3d(sx * hw, sy * hh, z));
        min_x = std::min(min_x, p.x());
        max_x = std::max(max_x, p.x());
        min_y = std::min(min_y, p.y());
        max_y = std::max(max_y, p.y());
      }
    }
  }
  EXPECT_GT(min_x, 0.02 * 1232);
  EXPECT_LT(max_x, 0.98 * 1232);
  EXPECT_GT(min_y, 0.02 * 816);
  EXPECT_LT(max_y, 0.98 * 816);
  EXPECT_GT((max_x - min_x) * (max_y - min_y), 0.6 * 1232 * 816);
}

// ----------------------------------------------------------------------------
// Renderer: options and set-up.

TEST(SimulatedRig, OptionsCheckNamesTheFieldValueAndRule) {
  auto expect_error = [](SimulatedRigOptions options, const std::string& field) {
    try {
      options.Check();
      ADD_FAILURE() << "no error for " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_THAT(e.what(), ::testing::HasSubstr(field));
      EXPECT_THAT(e.what(), ::testing::HasSubstr("must"));
    }
  };
  SimulatedRigOptions o;
  EXPECT_NO_THROW(o.Check());
  EXPECT_EQ(o.width, 1232);
  EXPECT_EQ(o.height, 816);
  EXPECT_EQ(o.black_level, 600);
  EXPECT_EQ(o.white_level, 16383);
  o.black_level = 20000;
  expect_error(o, "black_level");
  o = {};
  o.gain_e_per_dn = 0;
  expect_error(o, "gain_e_per_dn");
  o = {};
  o.read_noise_dn = -1;
  expect_error(o, "read_noise_dn");
  o = {};
  o.width = 0;
  expect_error(o, "width");
  o = {};
  o.shadow_grid_mm = 0;
  expect_error(o, "shadow_grid_mm");
  o = {};
  o.num_threads = -2;
  expect_error(o, "num_threads");
}

TEST(SimulatedRig, RejectsARigOfAnotherSizeAndBadLeds) {
  const SimulatedRigOptions options = SmallOptions();
  EXPECT_THROW(SimulatedRig(options, TextileScene(), MakeDefaultSimulatedRig(1232, 816)), std::invalid_argument);
  RigDescription rig = MakeDefaultSimulatedRig(options.width, options.height);
  rig.leds[3].mu = -1;
  try {
    SimulatedRig bad(options, TextileScene(), rig);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("leds[3].mu"));
  }
  const SimulatedRig sim = MakeRig(options);
  EXPECT_THROW(sim.RenderFrame(10, 0), std::out_of_range);
  EXPECT_THROW(sim.RenderLinear(-1), std::out_of_range);
}

// ----------------------------------------------------------------------------
// Geometry.

TEST(SimulatedRig, GroundTruthPointsLieOnThePixelRaysAndOnTheSurface) {
  SimulatedRigOptions options;  // default 1232 x 816: 0.116 mm per pixel
  const SimulatedRig sim = MakeRig(options);
  const GroundTruthMaps truth = sim.RenderGroundTruth();
  const TextileScene& scene = sim.scene();
  const CameraGeometry& camera = sim.rig().camera;
  EXPECT_NEAR(truth.mm_per_pixel, 0.116, 0.005);
  int on_sample = 0;
  for (int y = 0; y < options.height; y += 7) {
    for (int x = 0; x < options.width; x += 5) {
      const Eigen::Vector3d p(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1),
                              truth.point_in_table(x, y, 2));
      // On the surface (float storage: ~1e-5 mm).
      ASSERT_NEAR(p.z(), scene.HeightMm(p.x(), p.y()), 1e-4) << x << "," << y;
      ASSERT_FLOAT_EQ(truth.height_mm(x, y), static_cast<float>(p.z()));
      // On the ray of pixel (x, y), through the lens distortion.
      const Eigen::Vector2d pixel = ProjectToPixel(camera.intrinsics, camera.cam_from_table * p);
      ASSERT_NEAR(pixel.x(), x, 2e-3) << x << "," << y;
      ASSERT_NEAR(pixel.y(), y, 2e-3) << x << "," << y;
      // The normal and albedo of the scene there.
      const Eigen::Vector3d n(truth.normal_in_table(x, y, 0), truth.normal_in_table(x, y, 1),
                              truth.normal_in_table(x, y, 2));
      ASSERT_NEAR(n.norm(), 1.0, 1e-6);
      ASSERT_LT((n - scene.NormalInTable(p.x(), p.y())).norm(), 1e-4) << x << "," << y;
      const Eigen::Vector3d albedo = scene.Albedo(p.x(), p.y());
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(truth.albedo(x, y, c), albedo[c], 1e-4);
      ASSERT_EQ(truth.sample_mask(x, y), scene.OnSample(p.x(), p.y()) ? 1 : 0);
      on_sample += truth.sample_mask(x, y);
    }
  }
  // The sample covers most of the frame.
  const int checked = ((options.height + 6) / 7) * ((options.width + 4) / 5);
  EXPECT_GT(on_sample, checked / 2);
  EXPECT_LT(on_sample, checked);
}

// ----------------------------------------------------------------------------
// Light model.

TEST(SimulatedRig, FlatPatchMatchesTheLightModel) {
  // No folds, no weave relief: a plane at constant height over the sample.
  TextileSceneOptions flat;
  flat.fold_amplitude_mm = 0;
  flat.thread_height_mm = 0;
  flat.crossing_amplitude_mm = 0;
  const TextileScene scene(flat);
  SimulatedRigOptions options;
  const SimulatedRig sim(options, scene, MakeDefaultSimulatedRig(options.width, options.height));
  const double plane_z = scene.HeightMm(0, 0);
  EXPECT_EQ(scene.HeightMm(10, -20), plane_z);

  // Independently of the renderer's intersection: the calibration library's
  // rays met with the plane z = plane_z.
  const ImageF rays = ComputeRayDirectionsInTable(sim.rig().camera);
  const Eigen::Vector3d camera_centre = CameraCentreInTable(sim.rig().camera);
  const std::vector<std::pair<int, int>> pixels = {{616, 408}, {300, 200}, {950, 650}, {180, 700}, {1000, 150}};
  for (int k = 0; k < sim.num_leds(); ++k) {
    const ImageF linear = sim.RenderLinear(k);
    for (auto [x, y] : pixels) {
      const Eigen::Vector3d ray(rays(x, y, 0), rays(x, y, 1), rays(x, y, 2));
      const Eigen::Vector3d point = camera_centre + ((plane_z - camera_centre.z()) / ray.z()) * ray;
      ASSERT_TRUE(scene.OnSample(point.x(), point.y()));
      // The sensor sees the Mallett upsampling of the scene's Rec.709 colour.
      const Eigen::Vector3d albedo =
          SimulatedSensorColor(options.color).camera_from_linear_rec709 * scene.Albedo(point.x(), point.y());
      for (int c = 0; c < 3; ++c) {
        const double expected =
            albedo[c] * (ExpectedDirect(sim.rig().leds[k], point, Eigen::Vector3d::UnitZ(), c) + options.ambient);
        EXPECT_NEAR(linear(x, y, c), expected, 1e-4 * expected) << "LED " << k << " pixel " << x << "," << y;
      }
    }
  }
}

TEST(SimulatedRig, NoiseFreeRawFrameIsTheRoundedLinearRenderOnTheCfa) {
  SimulatedRigOptions options = SmallOptions();
  options.add_noise = false;
  const SimulatedRig sim = MakeRig(options);
  const ImageF linear = sim.RenderLinear(4);
  const RawImage raw = sim.RenderFrame(4, 0);
  EXPECT_EQ(raw.cfa, CfaPattern::kRGGB);
  EXPECT_EQ(raw.white_level, 16383);
  EXPECT_EQ(raw.BlackAt(1, 1), 600);
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const double expected =
          std::round(linear(x, y, CfaColorAt(options.cfa, x, y)) * Range(options) + options.black_level);
      ASSERT_NEAR(raw.mosaic(x, y), expected, 1.0) << x << "," << y;  // float vs double rounding
    }
  }
}

TEST(SimulatedRig, CastShadowsDarkenTheSlopeBehindAFoldCrest) {
  // One steep fold (slope up to 0.94 > tan 30 deg) so the low ring of LEDs
  // casts shadows behind its crests.
  TextileSceneOptions steep;
  steep.num_fold_waves = 1;
  steep.fold_amplitude_mm = 3.0;
  steep.fold_min_wavelength_mm = steep.fold_max_wavelength_mm = 20.0;
  SimulatedRigOptions with = SmallOptions();
  with.width = kD5100Width / 8;
  with.height = kD5100Height / 8;
  SimulatedRigOptions without = with;
  without.cast_shadows = false;
  const SimulatedRig sim_with = MakeRig(with, steep);
  const SimulatedRig sim_without = MakeRig(without, steep);
  const TextileScene& scene = sim_with.scene();
  const GroundTruthMaps truth = sim_with.RenderGroundTruth();

  // Highest point on the segment from p to the LED relative to the segment,
  // by brute force over the analytic surface (0.01 mm steps).
  auto worst_clearance = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& led) {
    const Eigen::Vector3d l = (led - p).normalized();
    double worst = -1e9;
    for (double s = 0.05; s < 40; s += 0.01) {
      const Eigen::Vector3d q = p + s * l;
      if (q.z() > scene.MaxHeightMm()) break;
      worst = std::max(worst, scene.HeightMm(q.x(), q.y()) - q.z());
    }
    return worst;
  };

  int shadowed_total = 0;
  for (int k = 0; k < 5; ++k) {  // the 30 deg ring
    const Eigen::Vector3d led = sim_with.rig().leds[k].position_in_table_mm;
    const ImageF lit = sim_with.RenderLinear(k);
    const ImageF unshadowed = sim_without.RenderLinear(k);
    int shadowed = 0, clearly_shadowed = 0, checked_lit = 0;
    for (int y = 0; y < with.height; ++y) {
      for (int x = 0; x < with.width; ++x) {
        const double ambient_only = truth.albedo_white_balanced_camera(x, y, 1) * with.ambient;
        ASSERT_LE(lit(x, y, 1), unshadowed(x, y, 1) + 1e-7);
        const Eigen::Vector3d p(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1),
                                truth.point_in_table(x, y, 2));
        if (lit(x, y, 1) < unshadowed(x, y, 1)) {
          // Dark with shadows on, lit with them off: directly lit in n.l but
          // the surface is in the way.
          EXPECT_NEAR(lit(x, y, 1), ambient_only, 1e-6);
          if (unshadowed(x, y, 1) > ambient_only + 0.02) ++clearly_shadowed;
          if (shadowed++ % 17 == 0) {
            EXPECT_GT(worst_clearance(p, led), -0.03) << "LED " << k << " pixel " << x << "," << y;
          }
        } else if (unshadowed(x, y, 1) > ambient_only + 1e-3 && truth.sample_mask(x, y) && (x + 3 * y) % 61 == 0) {
          ++checked_lit;
          EXPECT_LT(worst_clearance(p, led), 0.03) << "LED " << k << " pixel " << x << "," << y;
        }
      }
    }
    EXPECT_GT(clearly_shadowed, 200) << "LED " << k;
    EXPECT_GT(checked_lit, 500) << "LED " << k;
    shadowed_total += shadowed;
  }
  // The shadow mask tells the same.
  const ImageU8 mask = sim_with.RenderShadowMask(0);
  const ImageF lit0 = sim_with.RenderLinear(0);
  for (int y = 0; y < with.height; ++y) {
    for (int x = 0; x < with.width; ++x) {
      const bool dark = lit0(x, y, 1) <= truth.albedo_white_balanced_camera(x, y, 1) * with.ambient + 1e-7;
      ASSERT_EQ(mask(x, y), dark ? 1 : 0) << x << "," << y;
    }
  }
  RecordProperty("shadowed_pixels", shadowed_total);
}

// ----------------------------------------------------------------------------
// Sensor.

TEST(SimulatedRig, NoiseMatchesTheShotAndReadNoiseModel) {
  const SimulatedRigOptions options = SmallOptions();
  const SimulatedRig sim = MakeRig(options);
  const GroundTruthMaps truth = sim.RenderGroundTruth();
  const ImageF linear = sim.RenderLinear(7);
  // Temporal statistics of a block of table pixels (uniform grey albedo)
  // over 64 captures of the same LED: mean and variance of DN - black.
  constexpr int kFrames = 64;
  const int x0 = 2, y0 = 60, size = 16;  // left of the sample
  for (int y = y0; y < y0 + size; ++y) {
    for (int x = x0; x < x0 + size; ++x) ASSERT_EQ(truth.sample_mask(x, y), 0);
  }
  std::vector<double> sum(size * size, 0.0), sum2(size * size, 0.0);
  for (int f = 0; f < kFrames; ++f) {
    const RawImage raw = sim.RenderFrame(7, 100 + f);
    for (int y = y0; y < y0 + size; ++y) {
      for (int x = x0; x < x0 + size; ++x) {
        const double dn = raw.mosaic(x, y) - options.black_level;
        sum[(y - y0) * size + (x - x0)] += dn;
        sum2[(y - y0) * size + (x - x0)] += dn * dn;
      }
    }
  }
  for (int c = 0; c < 3; ++c) {
    double mean_error = 0, expected_mean = 0, variance = 0, expected_variance = 0;
    int n = 0;
    for (int y = y0; y < y0 + size; ++y) {
      for (int x = x0; x < x0 + size; ++x) {
        if (CfaColorAt(options.cfa, x, y) != c) continue;
        const int i = (y - y0) * size + (x - x0);
        const double mean = sum[i] / kFrames;
        const double signal = linear(x, y, c) * Range(options);
        mean_error += mean - signal;
        expected_mean += signal;
        variance += (sum2[i] - kFrames * mean * mean) / (kFrames - 1);
        // Shot noise in electrons, read noise and 1/12 DN^2 of rounding.
        expected_variance += signal / options.gain_e_per_dn + options.read_noise_dn * options.read_noise_dn + 1.0 / 12;
        ++n;
      }
    }
    ASSERT_GT(n, 0);
    EXPECT_GT(expected_mean / n, 1000.0) << "channel " << c;  // a strong signal, well above black
    EXPECT_LT(std::abs(mean_error) / expected_mean, 0.005) << "channel " << c;
    EXPECT_NEAR(variance / expected_variance, 1.0, 0.05) << "channel " << c;
  }

  // The same over a whole frame, each pixel against its own expectation.
  const RawImage raw = sim.RenderFrame(7, 5);
  double sum_z = 0, sum_z2 = 0;
  int n = 0;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const double signal = linear(x, y, CfaColorAt(options.cfa, x, y)) * Range(options);
      const double sigma = std::sqrt(signal / options.gain_e_per_dn + std::pow(options.read_noise_dn, 2) + 1.0 / 12);
      const double z = (raw.mosaic(x, y) - options.black_level - signal) / sigma;
      sum_z += z;
      sum_z2 += z * z;
      ++n;
    }
  }
  EXPECT_NEAR(sum_z / n, 0.0, 0.02);
  EXPECT_NEAR(sum_z2 / n, 1.0, 0.03);
}

TEST(SimulatedRig, DarkFrameIsBlackPlusAmbient) {
  const SimulatedRigOptions options = SmallOptions();
  const SimulatedRig sim = MakeRig(options);
  const GroundTruthMaps truth = sim.RenderGroundTruth();
  const RawImage dark = sim.RenderFrame(std::nullopt, 0);
  double sum[3] = {0, 0, 0}, expected[3] = {0, 0, 0};
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const int c = CfaColorAt(options.cfa, x, y);
      sum[c] += dark.mosaic(x, y) - options.black_level;
      expected[c] += truth.albedo_white_balanced_camera(x, y, c) * options.ambient * Range(options);
    }
  }
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(expected[c], 0.0);
    EXPECT_NEAR(sum[c] / expected[c], 1.0, 0.01) << "channel " << c;
  }
  // Ambient is a small fraction of the LED signal.
  const ImageF lit = sim.RenderLinear(0);
  const ImageF ambient = sim.RenderLinear(std::nullopt);
  const int cx = options.width / 2, cy = options.height / 2;
  EXPECT_LT(ambient(cx, cy, 1), 0.05 * lit(cx, cy, 1));
  EXPECT_GT(ambient(cx, cy, 1), 0.0);
}

TEST(SimulatedRig, ClipsAtTheWhiteLevelAndAtZero) {
  SimulatedRigOptions options = SmallOptions();
  options.black_level = 0;
  options.ambient = 0;
  options.read_noise_dn = 4;
  RigDescription rig = MakeDefaultSimulatedRig(options.width, options.height);
  for (LedDescription& led : rig.leds) led.rgb_intensity *= 4.0;  // overexpose
  const SimulatedRig sim(options, TextileScene(), rig);
  const ImageF linear = sim.RenderLinear(2);
  const RawImage raw = sim.RenderFrame(2, 3);
  int saturated = 0, at_zero = 0;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const uint16_t dn = raw.mosaic(x, y);
      ASSERT_LE(dn, options.white_level);
      const double value = linear(x, y, CfaColorAt(options.cfa, x, y));
      if (value > 1.05) {
        ASSERT_EQ(dn, options.white_level) << x << "," << y;
      }
      if (value == 0.0) {
        ASSERT_LT(dn, 30) << "negative read noise must clip at 0, not wrap";
        at_zero += dn == 0;
      }
      saturated += dn == options.white_level;
    }
  }
  EXPECT_GT(saturated, 1000);
  EXPECT_GT(at_zero, 10);  // shadowed pixels with no ambient: half their read noise is clipped
}

TEST(SimulatedRig, SameSeedAndFrameGiveIdenticalFramesWhateverTheThreadCount) {
  SimulatedRigOptions one = SmallOptions();
  one.num_threads = 1;
  SimulatedRigOptions two = one;
  two.num_threads = 2;
  SimulatedRigOptions other_seed = two;
  other_seed.seed = one.seed + 1;
  const SimulatedRig a = MakeRig(one), b = MakeRig(two), c = MakeRig(other_seed);
  const RawImage a3 = a.RenderFrame(3, 42);
  const RawImage b3 = b.RenderFrame(3, 42);
  const RawImage a3_again = a.RenderFrame(3, 42);
  const RawImage c3 = c.RenderFrame(3, 42);
  const RawImage a3_next = a.RenderFrame(3, 43);
  const auto differing = [](const RawImage& x, const RawImage& y) {
    int count = 0;
    for (size_t i = 0; i < x.mosaic.size(); ++i) count += x.mosaic.data()[i] != y.mosaic.data()[i];
    return count;
  };
  EXPECT_EQ(differing(a3, b3), 0);
  EXPECT_EQ(differing(a3, a3_again), 0);
  const int n = static_cast<int>(a3.mosaic.size());
  EXPECT_GT(differing(a3, c3), n / 2);
  EXPECT_GT(differing(a3, a3_next), n / 2);
}

TEST(SimulatedRig, CfaLayoutIsHonoured) {
  // Red-only albedo everywhere: only red sites see light (on the camera with
  // Rec.709 primaries; a real sensor's green and blue see some of any red).
  TextileSceneOptions red;
  red.warp_rgb = red.weft_rgb = red.table_rgb = Eigen::Vector3d(0.6, 0, 0);
  for (CfaPattern pattern : {CfaPattern::kRGGB, CfaPattern::kBGGR, CfaPattern::kGRBG, CfaPattern::kGBRG}) {
    SimulatedRigOptions options = SmallOptions();
    options.color = SensorColorModel::kSrgbPrimaries;
    options.cfa = pattern;
    options.add_noise = false;
    const SimulatedRig sim = MakeRig(options, red);
    const RawImage raw = sim.RenderFrame(6, 0);
    EXPECT_EQ(raw.cfa, pattern);
    for (int y = 0; y < options.height; ++y) {
      for (int x = 0; x < options.width; ++x) {
        if (CfaColorAt(pattern, x, y) == 0) {
          ASSERT_GT(raw.mosaic(x, y), options.black_level) << CfaPatternName(pattern) << " " << x << "," << y;
        } else {
          ASSERT_EQ(raw.mosaic(x, y), options.black_level) << CfaPatternName(pattern) << " " << x << "," << y;
        }
      }
    }
  }
}

// ----------------------------------------------------------------------------
// Threads, progress, size.

TEST(SimulatedRig, ProgressIsReportedAndCancelStops) {
  const SimulatedRigOptions options = SmallOptions();
  std::vector<double> fractions;
  const SimulatedRig sim(options, TextileScene(), MakeDefaultSimulatedRig(options.width, options.height),
                         [&](double f) {
                           fractions.push_back(f);
                           return true;
                         });
  ASSERT_GT(fractions.size(), 2u);
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);

  fractions.clear();
  const RawImage raw = sim.RenderFrame(0, 0, [&](double f) {
    fractions.push_back(f);
    return true;
  });
  EXPECT_EQ(raw.width(), options.width);
  ASSERT_FALSE(fractions.empty());
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);

  int calls = 0;
  EXPECT_THROW(sim.RenderFrame(0, 0, [&](double) { return ++calls < 2; }), Cancelled);
  EXPECT_THROW(sim.RenderLinear(0, [](double) { return false; }), Cancelled);
  EXPECT_THROW(SimulatedRig(options, TextileScene(), MakeDefaultSimulatedRig(options.width, options.height),
                            [](double) { return false; }),
               Cancelled);
}

TEST(SimulatedRig, FullResolutionD5100FrameRenders) {
  SimulatedRigOptions options;
  options.width = kD5100Width;
  options.height = kD5100Height;
  const auto start = std::chrono::steady_clock::now();
  const SimulatedRig sim = MakeRig(options);
  const auto built = std::chrono::steady_clock::now();
  const RawImage raw = sim.RenderFrame(5, 1);
  const auto rendered = std::chrono::steady_clock::now();
  ASSERT_EQ(raw.width(), kD5100Width);
  ASSERT_EQ(raw.height(), kD5100Height);
  // A green site near the centre reads a plausible fraction of the range.
  const int x = kD5100Width / 2 + 1, y = kD5100Height / 2;
  ASSERT_EQ(CfaColorAt(options.cfa, x, y), 1);
  double mean = 0;
  int n = 0;
  for (int dy = -20; dy <= 20; dy += 2) {
    for (int dx = -20; dx <= 20; dx += 2) {
      mean += raw.mosaic(x + dx, y + dy) - options.black_level;
      ++n;
    }
  }
  mean /= n * Range(options);
  EXPECT_GT(mean, 0.02);
  EXPECT_LT(mean, 0.8);
  EXPECT_NEAR(sim.mm_per_pixel(), 0.029, 0.002);
  RecordProperty("construct_seconds", std::to_string(std::chrono::duration<double>(built - start).count()));
  RecordProperty("frame_seconds", std::to_string(std::chrono::duration<double>(rendered - built).count()));
}

}  // namespace
}  // namespace scanbench

// ----------------------------------------------------------------------------
// Colour (issue #12).
namespace scanbench {
namespace {

SimulatedRig MakeColorCheckerRig(SensorColorModel color) {
  SimulatedRigOptions options;
  options.width = kD5100Width / 8;
  options.height = kD5100Height / 8;
  options.color = color;
  TextileSceneOptions scene;
  scene.sample = SampleKind::kColorChecker;
  return MakeRig(options, scene);
}

// Pixels well inside each patch (the centre 10 x 10 mm of its 16 mm).
std::vector<std::vector<std::pair<int, int>>> PatchPixels(const SimulatedRig& rig, const GroundTruthMaps& truth) {
  std::vector<std::vector<std::pair<int, int>>> pixels(24);
  for (int y = 0; y < rig.height(); ++y) {
    for (int x = 0; x < rig.width(); ++x) {
      const double u = truth.point_in_table(x, y, 0), v = truth.point_in_table(x, y, 1);
      const int patch = ColorCheckerPatchIndexAt(u, v, 10.0, 20.0);
      if (patch >= 0) pixels[patch].push_back({x, y});
    }
  }
  return pixels;
}

TEST(SimulatedRigColor, ColorCheckerGroundTruthIsEachPatchsRec709AndTheCameraSeesItsSpectrum) {
  const SimulatedRig rig = MakeColorCheckerRig(SensorColorModel::kNikonD5100);
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  const auto pixels = PatchPixels(rig, truth);
  for (int k = 0; k < 24; ++k) {
    const ColorCheckerPatch& patch = ColorCheckerClassic()[k];
    ASSERT_GT(pixels[k].size(), 1000u) << patch.name << ": the whole card is in view";
    const Eigen::Vector3d camera = WhiteBalancedCameraRgbOf(SensorColorModel::kNikonD5100, patch.reflectance);
    for (auto [x, y] : pixels[k]) {
      for (int c = 0; c < 3; ++c) {
        ASSERT_FLOAT_EQ(truth.albedo(x, y, c), static_cast<float>(patch.linear_rec709[c])) << patch.name;
        ASSERT_FLOAT_EQ(truth.albedo_white_balanced_camera(x, y, c), static_cast<float>(camera[c])) << patch.name;
        ASSERT_NEAR(truth.normal_in_table(x, y, c), c == 2 ? 1.0 : 0.0, 1e-9) << "flat card";
      }
      ASSERT_EQ(truth.sample_mask(x, y), 1);
    }
  }
  // The surround and the table around the card.
  EXPECT_FLOAT_EQ(truth.albedo(rig.width() / 2, rig.height() / 2, 0), 0.03f);  // the gap at the card's centre
  EXPECT_FLOAT_EQ(truth.albedo(2, rig.height() / 2, 1), 0.35f);                 // the table
}

TEST(SimulatedRigColor, TheD5100IsNotColorimetricButWhiteStaysWhite) {
  const SimulatedRig rig = MakeColorCheckerRig(SensorColorModel::kNikonD5100);
  const GroundTruthMaps truth = rig.RenderGroundTruth();
  const auto pixels = PatchPixels(rig, truth);
  auto camera_of = [&](int patch) {
    const auto [x, y] = pixels[patch][0];
    return Eigen::Vector3d(truth.albedo_white_balanced_camera(x, y, 0), truth.albedo_white_balanced_camera(x, y, 1),
                           truth.albedo_white_balanced_camera(x, y, 2));
  };
  // Red (patch 15): the camera's red channel reads far less than Rec.709's, green and blue more.
  const Eigen::Vector3d red_camera = camera_of(14);
  const Eigen::Vector3d red_rec709 = ColorCheckerClassic()[14].linear_rec709;
  EXPECT_GT((red_camera - red_rec709).cwiseAbs().maxCoeff(), 0.1) << red_camera.transpose();
  EXPECT_GT(Ciede2000(LabFromLinearRec709(red_camera), ColorCheckerClassic()[14].lab_d65), 5.0);
  // The neutral patches stay neutral (white balance): within 2 % of each other.
  for (int patch = 18; patch < 24; ++patch) {
    const Eigen::Vector3d rgb = camera_of(patch);
    EXPECT_LT((rgb.maxCoeff() - rgb.minCoeff()) / rgb.mean(), 0.03) << ColorCheckerClassic()[patch].name;
  }
  // A perfect white textile reads (1, 1, 1) in camera space.
  TextileSceneOptions white;
  white.warp_rgb = white.weft_rgb = white.table_rgb = Eigen::Vector3d::Ones();
  white.color_variation = 0;
  white.gap_darkening = 0;
  SimulatedRigOptions options = SmallOptions();
  const GroundTruthMaps white_truth = MakeRig(options, white).RenderGroundTruth();
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(white_truth.albedo_white_balanced_camera(40, 30, c), 1.0, 2e-3) << c;
    EXPECT_FLOAT_EQ(white_truth.albedo(40, 30, c), 1.0f) << c;
  }
}

TEST(SimulatedRigColor, LedsCarryTheCamerasRawWhiteAndTheChartIsGlossy) {
  const RigDescription d5100 = MakeDefaultSimulatedRig(616, 408, SensorColorModel::kNikonD5100);
  const RigDescription srgb = MakeDefaultSimulatedRig(616, 408, SensorColorModel::kSrgbPrimaries);
  const Eigen::Vector3d raw_white = SimulatedSensorColor(SensorColorModel::kNikonD5100).raw_white_relative_to_green;
  // LED 7's tint is (1.00, 1, 0.97): its channel ratios are the raw white's.
  EXPECT_NEAR(d5100.leds[7].rgb_intensity[0] / d5100.leds[7].rgb_intensity[1], raw_white[0], 1e-12);
  EXPECT_NEAR(d5100.leds[7].rgb_intensity[2] / d5100.leds[7].rgb_intensity[1], 0.97 * raw_white[2], 1e-12);
  EXPECT_NEAR(srgb.leds[7].rgb_intensity[0] / srgb.leds[7].rgb_intensity[1], 0.48, 1e-12);
  EXPECT_GT(std::abs(raw_white[0] - 0.48), 0.02);

  // Gloss: the same chart with and without it; the 60 deg LEDs' mirror
  // direction lies near the camera, so some pixels gain up to a few % of white.
  SimulatedRigOptions options;
  options.width = kD5100Width / 8;
  options.height = kD5100Height / 8;
  TextileSceneOptions glossy;
  glossy.sample = SampleKind::kColorChecker;
  TextileSceneOptions matte = glossy;
  matte.chart_gloss = 0;
  const ImageF with = MakeRig(options, glossy).RenderLinear(7);
  const ImageF without = MakeRig(options, matte).RenderLinear(7);
  double most = 0;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      ASSERT_GE(with(x, y, 1), without(x, y, 1) - 1e-7);
      most = std::max(most, static_cast<double>(with(x, y, 1) - without(x, y, 1)));
    }
  }
  EXPECT_GT(most, 0.003);
  EXPECT_LT(most, 0.05);
}

}  // namespace
}  // namespace scanbench
