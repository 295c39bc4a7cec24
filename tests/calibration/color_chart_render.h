// Renders a ColorChecker Classic into a Bayer mosaic for the colour
// calibration tests: 24 patches (mcc's chart model: patch 2.5, pitch 2.75)
// on a black card, on a gray table, placed through a homography, with known
// per-channel camera values, noise, optional blur, vignetting and clipping.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "calibration/color_calibration.h"
#include "calibration/color_checker.h"
#include "calibration/raw_image.h"

namespace scanbench::testing {

struct ChartRender {
  int width = 1400;
  int height = 1000;
  CfaPattern cfa = CfaPattern::kRGGB;
  ColorChartQuad quad;  // where the patch grid goes (chart order)
  // Camera value (1 = exposure * raw range) of each patch, chart order, 24.
  std::vector<Eigen::Vector3d> patch_camera;
  Eigen::Vector3d card_camera = Eigen::Vector3d::Constant(0.03);   // the black card between the patches
  Eigen::Vector3d table_camera = Eigen::Vector3d::Constant(0.25);  // around the card
  double card_margin = 1.0;   // card border beyond the grid, in patch units (patch = 2.5)
  double exposure = 0.6;      // raw fraction of the range for camera value 1
  double noise_sigma = 0.002; // Gaussian read noise, fraction of the raw range
  double blur_sigma_px = 0;   // Gaussian blur before the mosaic
  double vignetting = 0;      // relative loss at the image corners (cos^4-like falloff ~ 1 - v r^2)
  uint16_t black = 600;
  uint16_t white = 16383;
  uint64_t seed = 5;
};

// A quad from centre, width of the grid in pixels, rotation (degrees, image
// y down) and a perspective tilt (0: none; the far edge shrinks by `tilt`).
inline ColorChartQuad PlacedQuad(Eigen::Vector2d centre, double grid_width_px, double rotation_deg,
                                 double tilt = 0) {
  const double aspect = 10.75 / 16.25;
  const double hw = 0.5 * grid_width_px, hh = 0.5 * grid_width_px * aspect;
  // Tilt: the top edge (dark skin row) narrower than the bottom.
  const std::array<Eigen::Vector2d, 4> local = {Eigen::Vector2d(-hw * (1 - tilt), -hh * (1 - 0.5 * tilt)),
                                                Eigen::Vector2d(hw * (1 - tilt), -hh * (1 - 0.5 * tilt)),
                                                Eigen::Vector2d(hw, hh), Eigen::Vector2d(-hw, hh)};
  const double a = rotation_deg * M_PI / 180.0;
  const Eigen::Matrix2d rotation = (Eigen::Matrix2d() << std::cos(a), -std::sin(a), std::sin(a), std::cos(a)).finished();
  ColorChartQuad quad;
  for (int i = 0; i < 4; ++i) quad.corners_px[i] = centre + rotation * local[i];
  return quad;
}

// Camera values that the matrix `rec709_from_camera` maps exactly onto the
// chart's linear Rec.709 reference.
inline std::vector<Eigen::Vector3d> CameraValuesFor(const Eigen::Matrix3d& rec709_from_camera) {
  std::vector<Eigen::Vector3d> values;
  const Eigen::Matrix3d camera_from_rec709 = rec709_from_camera.inverse();
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) values.push_back(camera_from_rec709 * patch.linear_rec709);
  return values;
}

inline RawImage RenderColorChart(const ChartRender& render) {
  const int w = render.width, h = render.height;
  // Chart-unit coordinates of each pixel through the inverse homography;
  // 4x4 supersampling for the patch edges.
  const Eigen::Matrix3d uv_from_image = ColorChartImageFromUv(render.quad).inverse();
  const double grid_w = 16.25, grid_h = 10.75, pitch = 2.75, side = 2.5;
  auto colour_at = [&](double x, double y) -> Eigen::Vector3d {
    const Eigen::Vector3d q = uv_from_image * Eigen::Vector3d(x, y, 1);
    const double cx = q.x() / q.z() * grid_w, cy = q.y() / q.z() * grid_h;
    const double m = render.card_margin;
    if (cx < -m || cx > grid_w + m || cy < -m || cy > grid_h + m) return render.table_camera;
    const int column = static_cast<int>(std::floor(cx / pitch)), row = static_cast<int>(std::floor(cy / pitch));
    if (column < 0 || column >= 6 || row < 0 || row >= 4) return render.card_camera;
    if (cx - column * pitch > side || cy - row * pitch > side) return render.card_camera;
    return render.patch_camera[row * 6 + column];
  };
  std::vector<Eigen::Vector3d> rgb(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int sy = 0; sy < 4; ++sy) {
        for (int sx = 0; sx < 4; ++sx) sum += colour_at(x - 0.375 + 0.25 * sx, y - 0.375 + 0.25 * sy);
      }
      rgb[static_cast<size_t>(y) * w + x] = sum / 16.0;
    }
  }
  if (render.blur_sigma_px > 0) {
    const int radius = static_cast<int>(std::ceil(3 * render.blur_sigma_px));
    std::vector<double> kernel(2 * radius + 1);
    double total = 0;
    for (int k = -radius; k <= radius; ++k) total += kernel[k + radius] = std::exp(-0.5 * k * k / (render.blur_sigma_px * render.blur_sigma_px));
    for (double& k : kernel) k /= total;
    std::vector<Eigen::Vector3d> pass(rgb.size());
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        Eigen::Vector3d s = Eigen::Vector3d::Zero();
        for (int k = -radius; k <= radius; ++k) s += kernel[k + radius] * rgb[static_cast<size_t>(y) * w + std::clamp(x + k, 0, w - 1)];
        pass[static_cast<size_t>(y) * w + x] = s;
      }
    }
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        Eigen::Vector3d s = Eigen::Vector3d::Zero();
        for (int k = -radius; k <= radius; ++k) s += kernel[k + radius] * pass[static_cast<size_t>(std::clamp(y + k, 0, h - 1)) * w + x];
        rgb[static_cast<size_t>(y) * w + x] = s;
      }
    }
  }
  RawImage raw;
  raw.mosaic = ImageU16(w, h, 1);
  raw.cfa = render.cfa;
  raw.black_level = {render.black, render.black, render.black, render.black};
  raw.white_level = render.white;
  std::mt19937_64 random(render.seed);
  std::normal_distribution<double> noise(0.0, render.noise_sigma);
  const double range = double(render.white) - render.black;
  const double r_max2 = 0.25 * (double(w) * w + double(h) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double r2 = ((x - 0.5 * w) * (x - 0.5 * w) + (y - 0.5 * h) * (y - 0.5 * h)) / r_max2;
      const double falloff = 1.0 - render.vignetting * r2;
      const double value = render.exposure * falloff * rgb[static_cast<size_t>(y) * w + x][CfaColorAt(render.cfa, x, y)];
      const double dn = render.black + (value + noise(random)) * range;
      raw.mosaic(x, y) = static_cast<uint16_t>(std::clamp(std::lround(dn), 0L, long(render.white)));
    }
  }
  return raw;
}

}  // namespace scanbench::testing
