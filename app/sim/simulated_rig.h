// The simulated scan bench: renders the RAW frames that the real rig would
// capture of a TextileScene, plus the ground truth to score a solve against.
//
// Light model (must match calibration/rig.h exactly, the solver inverts it):
// LED k adds to raw colour channel c, as a fraction of the raw range above
// black,
//   albedo_c * max(0, n.l) * rgb_intensity_c * cos(angle off axis)^mu * (1000 / d_mm)^2
// with l the unit vector from the surface point to the LED, d its distance and
// the angle off axis between the LED's axis and (point - LED); zero where the
// height field casts a shadow. Ambient light adds albedo_c * ambient to every
// frame, the dark frame included. A glossy sample (the ColorChecker card) adds
// a small specular term to albedo_c for the direct light only, which the
// solver's Lambertian model does not know: as on a real card.
//
// Colour (issue #12). albedo_c above is the WHITE-BALANCED CAMERA RGB of the
// surface: what the sensor reads of it under the LEDs, divided per channel by
// what it reads of a perfect white (so a perfect white is (1, 1, 1) and the
// LEDs' rgb_intensity carries the raw white balance). With
// SensorColorModel::kNikonD5100 (default) the camera is spectral and not
// colorimetric: every reflectance spectrum is integrated against the CIE
// LED-B5 white LED and the measured Nikon D5100 sensitivities
// (app/sim/sensor_color.h); textile colours, given in linear Rec.709, are
// upsampled to smooth spectra first (Mallett & Yuksel 2019). With
// kSrgbPrimaries (the camera before issue #12) camera RGB is linear Rec.709.
// The ground truth albedo (GroundTruthMaps::albedo) is ALWAYS linear Rec.709
// under D65 (the colour a solve with a correct colour calibration must give),
// whatever the camera.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <vector>

#include <Eigen/Core>

#include "app/sim/textile_scene.h"
#include "calibration/raw_image.h"
#include "calibration/rig.h"
#include "core/cancellation.h"
#include "core/image.h"
#include "core/progress.h"

namespace scanbench {

// Nikon D5100 sensor (APS-C, 4.78 um pixels) at native resolution.
inline constexpr int kD5100Width = 4928;            // pixels
inline constexpr int kD5100Height = 3264;           // pixels
inline constexpr double kD5100SensorWidthMm = 23.6;
inline constexpr double kD5100SensorHeightMm = 15.6;

// The simulated camera's colour response (see the header comment).
enum class SensorColorModel {
  kNikonD5100,     // spectral: measured D5100 curves under the LED-B5 white LED
  kSrgbPrimaries,  // camera RGB = linear Rec.709 (the camera before issue #12)
};

// The bench as built, the truth the calibration should recover: a D5100 with an
// 85 mm prime focused at 600 mm looking straight down (1 deg tilt), 10 LEDs on
// two rings (30 and 60 deg elevation, 500 mm from the sample centre), each aimed
// at the centre. `width` x `height` keep the field of view of the full sensor
// (a smaller size is a binned sensor). The LEDs' rgb_intensity channel ratios
// are the raw white of `color` (its white LED through its sensor), times each
// LED's own slight tint. Throws std::invalid_argument if either size is not
// positive.
RigDescription MakeDefaultSimulatedRig(int width = 1232, int height = 816,
                                       SensorColorModel color = SensorColorModel::kNikonD5100);

struct SimulatedRigOptions {
  int width = kD5100Width / 4;       // pixels; must equal the rig camera's intrinsics.width
  int height = kD5100Height / 4;     // pixels; must equal the rig camera's intrinsics.height
  uint64_t seed = 0x5CA9BE9C;        // sensor noise seed; with the frame index it fixes every noise value
  CfaPattern cfa = CfaPattern::kRGGB;  // Bayer layout of the mosaic (D5100: RGGB)
  int black_level = 600;             // DN added to every pixel, [0, white_level)
  int white_level = 16383;           // DN saturation (14-bit), (black_level, 65535]
  double gain_e_per_dn = 2.5;        // electrons per DN (D5100 at ISO 100), > 0
  double read_noise_dn = 1.2;        // Gaussian read noise, DN rms, >= 0
  bool add_noise = true;             // false: shot and read noise off (values are still rounded and clipped)
  double ambient = 0.006;            // fraction of the raw range an albedo-1 surface reads from stray light, [0, 1]
  bool cast_shadows = true;          // march towards the LED over the height field
  double shadow_grid_mm = 0.05;      // spacing of the height grid that shadow rays march over, (0, 1]
  double shadow_bias_mm = 0.01;      // a ray is occluded only if the surface is this much above it, [0, 1]
  int num_threads = 0;               // worker threads; 0 = std::thread::hardware_concurrency(), [0, 256]
  // Cloth and satin: the fibre-scale tilt (TextileSceneOptions::fibre_tilt_deg)
  // is below the pixel, so each pixel reads the AVERAGE response over its
  // footprint, as a sensor integrates it: this many stratified (Latin
  // hypercube, seeded per pixel) sub-samples of the fibre tilt over a
  // mm_per_pixel square around the pixel's surface point.
  int footprint_samples = 6;         // [1, 64]
  SensorColorModel color = SensorColorModel::kNikonD5100;  // camera colour response; the rig's LEDs must match it

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

// Renders take a ProgressCallback (core/progress.h), called from the calling
// thread only; false from it makes the render throw Cancelled.

// Fills values[x], x in [0, width), with the noise-free linear value of row y
// for the colour the CFA puts at (x, y), as a fraction of the raw range above
// black. May be called from several threads at once for different rows.
using SensorRowFunction = std::function<void(int y, double* values)>;

// The sensor model alone, for anything rendered in front of the camera
// (scenes, calibration targets): scales to DN, adds shot and read noise (a pure
// function of options.seed, frame_index and the pixel), rounds, adds the black
// level and clips at 0 and the white level. Throws Cancelled if
// `progress` returns false.
RawImage RenderSensorMosaic(const SimulatedRigOptions& options, uint64_t frame_index,
                            const SensorRowFunction& linear_row, const ProgressCallback& progress = {});

struct GroundTruthMaps {
  ImageF point_in_table;   // 3 channels, mm: where each pixel's ray meets the surface
  ImageF normal_in_table;  // 3 channels, unit, z > 0; on cloth and satin threads the mean of the footprint's fibre shading normals
  ImageF albedo;           // 3 channels, linear Rec.709 (D65) reflectance in [0, 1], whatever the camera
  ImageF albedo_white_balanced_camera;  // 3 channels: what the sensor sees of it (the albedo_c of the light model)
  ImageF height_mm;        // 1 channel, surface height above the table
  ImageU8 sample_mask;     // 1 channel: 1 on the sample, 0 on the table
  double mm_per_pixel = 0; // footprint on the table plane of one pixel at the image centre
};

// Immutable once built: the Render* calls are const and may run concurrently.
class SimulatedRig {
 public:
  // Traces every pixel's ray to the surface once (the heavy part at 16 MP).
  // Throws std::invalid_argument for bad options or a rig that does not match
  // them, Cancelled if `progress` returns false.
  SimulatedRig(const SimulatedRigOptions& options, TextileScene scene, RigDescription rig,
               const ProgressCallback& progress = {});

  const SimulatedRigOptions& options() const { return options_; }
  const TextileScene& scene() const { return scene_; }
  const RigDescription& rig() const { return rig_; }
  int width() const { return options_.width; }
  int height() const { return options_.height; }
  int num_leds() const { return static_cast<int>(rig_.leds.size()); }
  // Footprint on the table plane of one pixel at the image centre, mm.
  double mm_per_pixel() const { return mm_per_pixel_; }

  // One RAW capture: LED `lit_led_index` (index into rig().leds) on, or all off
  // (std::nullopt = the dark frame). The noise is a pure function of
  // (options.seed, frame_index, pixel): give every capture of a session its own
  // frame_index. Throws std::out_of_range for a bad LED index.
  RawImage RenderFrame(std::optional<int> lit_led_index, uint64_t frame_index,
                       const ProgressCallback& progress = {}) const;

  // The same frame noise-free and unclipped, all three colour channels: linear
  // value as a fraction of the raw range above black (what the sensor's
  // expected DN - black divided by white - black would be).
  ImageF RenderLinear(std::optional<int> lit_led_index, const ProgressCallback& progress = {}) const;

  // 1 where LED `led_index` is hidden by the surface (cast or attached shadow,
  // or behind the LED), 0 where it lights the pixel. Ignores cast_shadows = false.
  ImageU8 RenderShadowMask(int led_index) const;

  GroundTruthMaps RenderGroundTruth() const;

  // The shading normals (table frame, unit) of pixel (x, y)'s footprint
  // sub-samples, whose material responses the pixel averages (see
  // footprint_samples): the geometric normal tilted by the fibres at each
  // sub-sample. Empty for kLambert and off the threads.
  std::vector<Eigen::Vector3d> FootprintShadingNormals(int x, int y) const;

 private:
  struct ShadowGrid {
    double origin_x = 0, origin_y = 0;  // table mm of sample (0, 0)
    double spacing = 1;                 // mm
    int nx = 0, ny = 0;                 // samples
    int tiles_x = 0, tiles_y = 0;
    std::vector<float> height;          // nx * ny, row-major
    std::vector<float> tile_max;        // max over each tile's samples, borders included
    float max_height = 0;
  };
  static constexpr int kTileCells = 16;

  // The steps of the constructor.
  void PrepareColor();    // the camera's colour response to the scene's albedo and the chart's spectra
  void CheckRig() const;  // the camera matches the options and clears the scene; finite LEDs
  double CentrePixelFootprintMm(const ImageF& rays, const Eigen::Vector3d& camera_centre) const;
  void TraceRow(int y, const ImageF& rays, const Eigen::Vector3d& camera_centre);
  // Table z where `ray` from `camera_centre` first meets the surface.
  double SurfaceHeightAlongRay(const Eigen::Vector3d& camera_centre, const Eigen::Vector3d& ray) const;

  int NumThreads() const;
  void BuildShadowGrid(const ProgressCallback& progress);
  double GridHeight(double x_mm, double y_mm) const;
  bool Occluded(const Eigen::Vector3d& point_in_table, const Eigen::Vector3d& light_dir_in_table,
                double distance_mm) const;
  // LED irradiance factor n.l * cos^mu * (1000/d)^2 (times 0 in shadow) at pixel index i.
  double DirectFactor(size_t i, const LedDescription& led, bool cast_shadows) const;
  // Non-Lambertian textile (scene material kCloth, kSatin) at pixel index i:
  // the LED's raw irradiance factor times the material's diffuse and specular
  // response (app/sim/cloth_brdf.h), averaged over the pixel's footprint
  // sub-samples and blended over the warp and weft by their share of the
  // surface; the table pixels stay Lambertian. 0 in shadow (the geometry's).
  void MaterialDirect(size_t i, const LedDescription& led, bool cast_shadows, double* diffuse,
                      double* specular) const;
  bool HasMaterial() const { return !warp_weight_.empty(); }
  // Specular reflectance the gloss adds at pixel index i for `led` (0 for a matte scene).
  double SpecularAt(size_t i, const LedDescription& led) const;
  // White-balanced camera RGB of a surface sample (see the header comment).
  Eigen::Vector3d CameraRgbOf(const SurfaceSample& sample) const;
  Eigen::Vector3d PointAt(size_t i) const;
  Eigen::Vector3d NormalAt(size_t i) const;
  // Shading normal of footprint sub-sample `k` of pixel i; `gradient` is the
  // pixel's geometric (dz/dx, dz/dy).
  Eigen::Vector3d FootprintNormal(size_t i, int k, const Eigen::Vector2d& gradient) const;
  // (dz/dx, dz/dy) of the geometric surface at pixel i.
  Eigen::Vector2d GradientAt(size_t i) const;
  // The ground-truth normal of pixel i: the geometric normal, or on the
  // threads of a non-Lambertian textile the normalised mean of its footprint's
  // shading normals (the fibres the pixel resolves are geometry too).
  Eigen::Vector3d TrueNormalAt(size_t i) const;

  SimulatedRigOptions options_;
  TextileScene scene_;
  RigDescription rig_;
  ShadowGrid grid_;
  double mm_per_pixel_ = 0;
  Eigen::Vector3d camera_centre_in_table_ = Eigen::Vector3d::Zero();
  // Colour: camera RGB = linear Rec.709 (kSrgbPrimaries), or the Mallett
  // matrix for textile colours and the patches' spectral camera RGB.
  bool camera_is_rec709_ = true;
  Eigen::Matrix3d camera_from_linear_rec709_ = Eigen::Matrix3d::Identity();
  std::vector<Eigen::Vector3d> patch_camera_rgb_;  // per ColorCheckerClassic() patch
  double gloss_tan2_width_ = 1;
  // Per pixel, compact (32 bytes): surface point xyz, normal xy (z > 0 is
  // implied), albedo rgb as the camera sees it (white-balanced camera RGB).
  // Only when the camera is not Rec.709: the ground-truth linear Rec.709
  // albedo (12 bytes more); only for a glossy scene: the gloss.
  std::vector<float> point_in_table_;
  std::vector<float> normal_xy_in_table_;
  std::vector<float> albedo_;
  std::vector<float> albedo_linear_rec709_;
  std::vector<float> gloss_;
  // Only for a non-Lambertian textile: the fibre tilt (a gradient offset) at
  // each footprint sub-sample, quantised to int16 (steps of kFibreTiltStep,
  // ~6e-4 deg: 4 bytes a sub-sample, 24 a pixel at the default 6), the warp's
  // share (-1 off the threads) and both thread indices.
  std::vector<int16_t> fibre_tilt_;
  std::vector<float> warp_weight_;
  std::vector<int32_t> thread_index_;
  std::vector<ThreadBrdf> warp_brdf_, weft_brdf_;  // per thread index - thread_index_base_
  int64_t warp_index_base_ = 0, weft_index_base_ = 0;
};

}  // namespace scanbench
