#include "app/sim/bench_template.h"

#include <Eigen/Geometry>
#include <cmath>

#include "app/sim/simulated_rig.h"
#include "core/field_error.h"

namespace scanbench {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct CameraPreset {
  int width, height;  // full RAW size, pixels
  double sensor_width_mm, sensor_height_mm;
};

CameraPreset PresetOf(const std::string& camera) {
  if (camera == "d5100") return {kD5100Width, kD5100Height, kD5100SensorWidthMm, kD5100SensorHeightMm};
  throw FieldError("BenchTemplateOptions", "camera", "'" + camera + "'", "must be \"d5100\"");
}

}  // namespace

void BenchTemplateOptions::Check() const {
  const char* where = "BenchTemplateOptions";
  if (name.empty()) throw FieldError(where, "name", "''", "must not be empty");
  SCANBENCH_REQUIRE_GE_LE(where, "num_leds", num_leds, 1, 10);
  if (ring_radii_mm.empty()) throw FieldError(where, "ring_radii_mm", "[]", "needs at least one ring");
  if (ring_heights_mm.size() != ring_radii_mm.size()) {
    throw FieldError(where, "ring_heights_mm", std::to_string(ring_heights_mm.size()) + " values",
                     "must have one height per ring radius (" + std::to_string(ring_radii_mm.size()) + ")");
  }
  if (static_cast<int>(ring_radii_mm.size()) > num_leds) {
    throw FieldError(where, "ring_radii_mm", std::to_string(ring_radii_mm.size()) + " rings",
                     "must not exceed num_leds (" + std::to_string(num_leds) + ")");
  }
  for (size_t r = 0; r < ring_radii_mm.size(); ++r) {
    SCANBENCH_REQUIRE_GT_LT(where, "ring_radii_mm[" + std::to_string(r) + "]", ring_radii_mm[r], 0, 10000, "mm");
    SCANBENCH_REQUIRE_GT_LT(where, "ring_heights_mm[" + std::to_string(r) + "]", ring_heights_mm[r], 0, 10000, "mm");
  }
  PresetOf(camera);
  SCANBENCH_REQUIRE_GT_LE(where, "lens_focal_mm", lens_focal_mm, 0, 1000, "mm");
  if (!(camera_height_mm > lens_focal_mm && camera_height_mm < 10000)) {
    throw FieldError(where, "camera_height_mm", camera_height_mm, "must lie in (lens_focal_mm, 10000) mm");
  }
  SCANBENCH_REQUIRE_GE_LT(where, "mu", mu, 0, 100);
}

RigDescription MakeBenchTemplate(const BenchTemplateOptions& options) {
  options.Check();
  RigDescription rig;
  rig.name = options.name;

  // A thin lens focused on the table: the pinhole focal length is the image
  // distance f * s / (s - f); no distortion until the camera is calibrated.
  const CameraPreset preset = PresetOf(options.camera);
  const double f = options.lens_focal_mm, s = options.camera_height_mm;
  const double image_distance_mm = f * s / (s - f);
  CameraIntrinsics& k = rig.camera.intrinsics;
  k.width = preset.width;
  k.height = preset.height;
  k.fx = image_distance_mm / (preset.sensor_width_mm / preset.width);
  k.fy = image_distance_mm / (preset.sensor_height_mm / preset.height);
  k.cx = 0.5 * (preset.width - 1);
  k.cy = 0.5 * (preset.height - 1);

  // Straight down: a half turn about table x makes image x = table +x and
  // image up = table +y; the camera centre is above the table origin.
  // The half turn is its own inverse; written out so the JSON holds exact zeros.
  rig.camera.cam_from_table = Eigen::Isometry3d::Identity();
  rig.camera.cam_from_table.linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  rig.camera.cam_from_table.translation() = Eigen::Vector3d(0, 0, s);

  const int rings = static_cast<int>(options.ring_radii_mm.size());
  for (int i = 0; i < options.num_leds; ++i) {
    const int ring = i % rings;
    const int on_ring = (options.num_leds - ring + rings - 1) / rings;  // LEDs dealt to this ring
    const int slot = i / rings;
    const double azimuth = 2 * kPi * (slot + 0.5 * ring) / on_ring;
    LedDescription led;
    led.id = i;  // firmware channel i: Arduino pin D(2 + i)
    led.position_in_table_mm =
        Eigen::Vector3d(options.ring_radii_mm[ring] * std::cos(azimuth),
                        options.ring_radii_mm[ring] * std::sin(azimuth), options.ring_heights_mm[ring]);
    led.axis_in_table = -led.position_in_table_mm.normalized();  // aimed at the sample centre
    led.mu = options.mu;
    led.rgb_intensity = Eigen::Vector3d::Ones();  // unknown until calibrated
    rig.leds.push_back(led);
  }
  return rig;
}

std::vector<std::string> BenchFieldsToMeasure(const RigDescription& rig) {
  const std::string leds = "leds[0.." + std::to_string(rig.leds.size() - 1) + "]";
  return {
      "camera.intrinsics (fx, fy, cx, cy, k1, k2, k3, p1, p2): nominal (thin lens, no distortion); "
      "`scanbench calibrate camera` on checkerboard captures",
      "camera.cam_from_table: nominal (straight down, lens " +
          std::to_string(static_cast<int>(std::lround(rig.camera.cam_from_table.translation().z()))) +
          " mm above the table centre); measure the height, or "
          "`scanbench calibrate camera` with the board flat at the sample position",
      leds + ".id: the firmware channel the LED's driver is wired to (channel k = Arduino pin D(2 + k))",
      leds +
          ".position_in_table_mm: the LED's centre from the sample centre, x right and y up in the image, z up, "
          "mm: measure each with a tape or rule",
      leds +
          ".axis_in_table: where each LED points (nominal: at the sample centre); correct it if one is aimed "
          "elsewhere",
      leds +
          ".mu, .rgb_intensity: nominal (mu from the LED's datasheet, intensity 1, 1, 1); `scanbench "
          "calibrate white` and `scanbench calibrate lights` measure them",
  };
}

}  // namespace scanbench
