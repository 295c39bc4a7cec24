// The simulated camera from before the spectral one (issue #12), kept as
// SensorColorModel::kSrgbPrimaries: camera RGB is linear Rec.709 and the
// LEDs' raw white the old fixed (0.48, 1, 0.70). Its frames -- of the
// textile, the gray chart and the white sheet -- are checked by what they must
// show, in statistics over many pixels that a last-bit change in libm cannot
// move: the scene's Rec.709 albedo read back through the light model, the
// primaries' order in the threads' colours, the neutral patches read in order,
// the black level and the sensor's noise. (Until issue #32: FNV-1a hashes of
// the same frames, measured before the spectral camera came, commit 6e1f54f.)
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "app/sim/sensor_color.h"
#include "app/sim/simulated_rig.h"
#include "app/sim/target_renderer.h"
#include "calibration/raw_image.h"
#include "tests/app/sim/light_model.h"

namespace scanbench {
namespace {

using testing::ExpectedDirect;

constexpr SensorColorModel kCamera = SensorColorModel::kSrgbPrimaries;

SimulatedRigOptions Sensor() {
  SimulatedRigOptions options;
  options.color = kCamera;
  options.width = kD5100Width / 16;   // 308 x 204, 0.46 mm per pixel
  options.height = kD5100Height / 16;
  return options;
}

RigDescription Rig() { return MakeDefaultSimulatedRig(Sensor().width, Sensor().height, kCamera); }

double Range(const SimulatedRigOptions& o) { return o.white_level - o.black_level; }

Eigen::Vector3d PixelVector(const ImageF& image, int x, int y) {
  return Eigen::Vector3d(image(x, y, 0), image(x, y, 1), image(x, y, 2));
}

// Per raw colour, the sum of what a frame reads ((DN - black) / range) and of
// what the light model expects for unit reflectance, over chosen pixels.
struct ChannelSums {
  std::array<double, 3> read{}, expected{}, count{};
  void Add(int c, double read_value, double expected_value) {
    read[c] += read_value;
    expected[c] += expected_value;
    count[c] += 1;
  }
  // The reflectance the frame shows in colour c: what it read over what unit
  // reflectance would read there.
  double Reflectance(int c) const { return read[c] / expected[c]; }
};

TEST(SrgbPrimariesCamera, SeesLinearRec709UnderTheOldRawWhite) {
  const SensorColor& color = SimulatedSensorColor(kCamera);
  EXPECT_TRUE(color.camera_from_linear_rec709.isIdentity(0.0));
  EXPECT_EQ(color.raw_white_relative_to_green, Eigen::Vector3d(0.48, 1.0, 0.70));
  // Every LED: the raw white times its own slight tint (3 % at most).
  constexpr double kTint = 0.03 + 1e-12;
  for (const LedDescription& led : Rig().leds) {
    EXPECT_NEAR(led.rgb_intensity[0] / led.rgb_intensity[1] / 0.48, 1.0, kTint) << "LED " << led.id;
    EXPECT_NEAR(led.rgb_intensity[2] / led.rgb_intensity[1] / 0.70, 1.0, kTint) << "LED " << led.id;
  }
}

class SrgbPrimariesScan : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    rig_ = new SimulatedRig(Sensor(), TextileScene(), Rig());
    truth_ = new GroundTruthMaps(rig_->RenderGroundTruth());
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete rig_;
  }
  static const SimulatedRig* rig_;
  static const GroundTruthMaps* truth_;
};
const SimulatedRig* SrgbPrimariesScan::rig_ = nullptr;
const GroundTruthMaps* SrgbPrimariesScan::truth_ = nullptr;

// The default textile: an indigo warp (0.10, 0.17, 0.50) and an ochre weft
// (0.78, 0.62, 0.34) on a neutral grey table (0.35).
enum class Region { kTable, kWarp, kWeft, kMixed };

Region RegionOf(const GroundTruthMaps& truth, int x, int y) {
  if (truth.sample_mask(x, y) == 0) return Region::kTable;
  const Eigen::Vector3d albedo = PixelVector(truth.albedo, x, y);
  const double blue_share = albedo[2] / albedo.sum();
  return blue_share > 0.55 ? Region::kWarp : blue_share < 0.25 ? Region::kWeft : Region::kMixed;
}

TEST_F(SrgbPrimariesScan, TheCameraSeesTheGroundTruthsRec709Albedo) {
  const GroundTruthMaps& truth = *truth_;
  size_t differing = 0, table_pixels = 0;
  for (size_t i = 0; i < truth.albedo.size(); ++i) {
    differing += truth.albedo_white_balanced_camera.data()[i] != truth.albedo.data()[i];
  }
  EXPECT_EQ(differing, 0u) << "albedo values the camera sees otherwise than the ground truth's linear Rec.709";
  for (int y = 0; y < truth.albedo.height(); ++y) {
    for (int x = 0; x < truth.albedo.width(); ++x) {
      if (truth.sample_mask(x, y) != 0) continue;
      ++table_pixels;
      for (int c = 0; c < 3; ++c) ASSERT_FLOAT_EQ(truth.albedo(x, y, c), 0.35f) << "table at " << x << "," << y;
    }
  }
  EXPECT_GT(table_pixels, 1000u);
}

TEST_F(SrgbPrimariesScan, DarkFrameIsBlackPlusAmbientWithTheSensorsNoise) {
  const SimulatedRigOptions options = Sensor();
  const GroundTruthMaps& truth = *truth_;
  const RawImage dark = rig_->RenderFrame(std::nullopt, 3);
  // On the table (albedo 0.35 everywhere): 33 DN of stray light above black,
  // with its shot noise, the read noise and the rounding's 1/12 DN^2.
  std::array<double, 3> sum{}, sum_squares{}, count{};
  ChannelSums on_sample;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const int c = CfaColorAt(options.cfa, x, y);
      const double dn = dark.mosaic(x, y) - options.black_level;
      if (truth.sample_mask(x, y) == 0) {
        sum[c] += dn;
        sum_squares[c] += dn * dn;
        count[c] += 1;
      } else {
        on_sample.Add(c, dn / Range(options), truth.albedo(x, y, c) * options.ambient);  // shown / expected
      }
    }
  }
  const double signal = 0.35 * options.ambient * Range(options);
  const double variance = signal / options.gain_e_per_dn + options.read_noise_dn * options.read_noise_dn + 1.0 / 12;
  for (int c = 0; c < 3; ++c) {
    ASSERT_GT(count[c], 500) << "channel " << c;
    const double mean = sum[c] / count[c];
    EXPECT_NEAR(mean / signal, 1.0, 0.02) << "channel " << c << ": table reads " << mean << " DN above black";
    EXPECT_NEAR((sum_squares[c] / count[c] - mean * mean) / variance, 1.0, 0.1) << "channel " << c;
    EXPECT_NEAR(on_sample.Reflectance(c), 1.0, 0.02) << "channel " << c << ": the sample's ambient light";
  }
}

TEST_F(SrgbPrimariesScan, LedFramesShowTheRec709AlbedoThroughTheLightModel) {
  const SimulatedRigOptions options = Sensor();
  const GroundTruthMaps& truth = *truth_;
  for (const int led : {0, 7}) {
    SCOPED_TRACE("LED " + std::to_string(led));
    const RawImage raw = rig_->RenderFrame(led, 3);
    const ImageU8 shadow = rig_->RenderShadowMask(led);
    const LedDescription& light = rig_->rig().leds[led];
    // Per region: the albedo each pixel shows (what it read over what the
    // light model says an albedo of 1 reads there), against the truth's.
    std::array<ChannelSums, 3> shown, true_albedo;
    for (int y = 0; y < options.height; ++y) {
      for (int x = 0; x < options.width; ++x) {
        const Region region = RegionOf(truth, x, y);
        if (region == Region::kMixed || shadow(x, y) != 0) continue;
        const int c = CfaColorAt(options.cfa, x, y);
        const double unit = ExpectedDirect(light, PixelVector(truth.point_in_table, x, y),
                                           PixelVector(truth.normal_in_table, x, y), c) +
                            options.ambient;
        if (unit < 0.05) continue;  // grazing light: mostly noise
        const double read = (raw.mosaic(x, y) - options.black_level) / Range(options);
        shown[int(region)].Add(c, read / unit, 1.0);
        true_albedo[int(region)].Add(c, truth.albedo(x, y, c), 1.0);
      }
    }
    const char* names[] = {"table", "warp", "weft"};
    std::array<Eigen::Vector3d, 3> colour;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        ASSERT_GT(shown[r].count[c], 200) << names[r] << " channel " << c;
        colour[r][c] = shown[r].Reflectance(c);
        EXPECT_NEAR(colour[r][c] / true_albedo[r].Reflectance(c), 1.0, 0.01)
            << names[r] << " channel " << c << ": shows " << colour[r][c] << ", its albedo is "
            << true_albedo[r].Reflectance(c);
      }
    }
    // The primaries in their order: the indigo warp blue over green over
    // red, the ochre weft the other way round, the grey table neutral.
    EXPECT_GT(colour[1][2], colour[1][1]);
    EXPECT_GT(colour[1][1], colour[1][0]);
    EXPECT_GT(colour[2][0], colour[2][1]);
    EXPECT_GT(colour[2][1], colour[2][2]);
    EXPECT_NEAR(colour[0][0] / colour[0][1], 1.0, 0.01);
    EXPECT_NEAR(colour[0][2] / colour[0][1], 1.0, 0.01);
  }
}

// What a target's frame shows: per raw colour, what it read over what unit
// reflectance reads there, over the pixels `use` picks.
template <typename Use>
ChannelSums TargetSums(const PreparedTarget& prepared, const RawImage& raw, const LedDescription& led, Use use) {
  const SimulatedRigOptions options = Sensor();
  ChannelSums sums;
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const Eigen::Vector3d point = PixelVector(prepared.point_in_table, x, y);
      if (!use(point)) continue;
      const int c = CfaColorAt(options.cfa, x, y);
      const double unit =
          ExpectedDirect(led, point, PixelVector(prepared.normal_in_table, x, y), c) + options.ambient;
      sums.Add(c, (raw.mosaic(x, y) - options.black_level) / Range(options), unit);
    }
  }
  return sums;
}

TEST(SrgbPrimariesCamera, GrayChartReadsItsNeutralScaleInOrder) {
  const TargetRenderer renderer(Sensor(), Rig());
  const SimulatedTarget target = SimulatedTarget::GrayChart(GrayChartTarget::MunsellNeutralScale());
  const PreparedTarget prepared = renderer.Prepare(target);
  const RawImage raw = renderer.RenderFrame(target, 2, 5);
  std::vector<std::pair<double, double>> by_reflectance;  // (true, shown in green)
  for (const GrayPatch& patch : target.gray_chart.patches) {
    // The patch's inside, a millimetre (two pixels) clear of its edges.
    const double half = patch.size_mm / 2 - 1.0;
    const ChannelSums sums = TargetSums(prepared, raw, renderer.rig().leds[2], [&](const Eigen::Vector3d& p) {
      return std::abs(p.x() - patch.centre_in_table_mm.x()) < half &&
             std::abs(p.y() - patch.centre_in_table_mm.y()) < half;
    });
    for (int c = 0; c < 3; ++c) {
      ASSERT_GT(sums.count[c], 100) << patch.name;
      // Every colour alike: the patches are neutral and the camera white-balanced.
      EXPECT_NEAR(sums.Reflectance(c) / patch.reflectance, 1.0, 0.02)
          << patch.name << " channel " << c << ": shows " << sums.Reflectance(c) << ", is " << patch.reflectance;
    }
    by_reflectance.emplace_back(patch.reflectance, sums.Reflectance(1));
  }
  std::sort(by_reflectance.begin(), by_reflectance.end());
  for (size_t k = 1; k < by_reflectance.size(); ++k) {
    EXPECT_GT(by_reflectance[k].second, by_reflectance[k - 1].second) << "patch of reflectance "
                                                                      << by_reflectance[k].first;
  }
}

TEST(SrgbPrimariesCamera, WhiteSheetIsNeutralWithTheSensorsNoise) {
  const SimulatedRigOptions options = Sensor();
  const TargetRenderer renderer(options, Rig());
  const SimulatedTarget target = SimulatedTarget::WhiteSheet({});
  const PreparedTarget prepared = renderer.Prepare(target);
  const LedDescription& led = renderer.rig().leds[2];
  const RawImage raw = renderer.RenderFrame(target, 2, 5);
  const ChannelSums sums = TargetSums(prepared, raw, led, [](const Eigen::Vector3d&) { return true; });
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(sums.Reflectance(c) / target.white_sheet.reflectance, 1.0, 0.005) << "channel " << c;
  }
  // A second capture: the difference of the two holds the noise alone (the
  // paper's texture and the light cancel), twice each frame's variance.
  const RawImage again = renderer.RenderFrame(target, 2, 6);
  std::array<double, 3> difference_squares{}, expected_variance{}, count{};
  for (int y = 0; y < options.height; ++y) {
    for (int x = 0; x < options.width; ++x) {
      const int c = CfaColorAt(options.cfa, x, y);
      const double difference = double(raw.mosaic(x, y)) - again.mosaic(x, y);
      const double signal = prepared.reflectance(x, y) * Range(options) *
                            (ExpectedDirect(led, PixelVector(prepared.point_in_table, x, y),
                                            PixelVector(prepared.normal_in_table, x, y), c) +
                             options.ambient);
      difference_squares[c] += difference * difference;
      expected_variance[c] +=
          signal / options.gain_e_per_dn + options.read_noise_dn * options.read_noise_dn + 1.0 / 12;
      count[c] += 1;
    }
  }
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(difference_squares[c] / 2 / expected_variance[c], 1.0, 0.05) << "channel " << c;
  }
}

}  // namespace
}  // namespace scanbench
