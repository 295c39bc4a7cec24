// The light each LED casts on each pixel: direction and RGB intensity.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"

namespace scanbench {

// Per-pixel lighting in the frame the normals are solved in (the table frame).
class LightField {
 public:
  virtual ~LightField() = default;
  virtual int num_lights() const = 0;
  virtual int width() const = 0;
  virtual int height() const = 0;
  // Writes, for every light k, the unit direction from the pixel's surface
  // point towards the light (light_dirs[3k..3k+2]) and the RGB intensity that
  // a white Lambertian surface facing the light would read there
  // (rgb_intensities[3k..3k+2]).
  virtual void Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const = 0;
  // Evaluate for the `count` pixels (x0 + i, y), in planar form: component c
  // of light k at pixel i is light_dirs[(3k + c) * stride + i] (likewise the
  // intensities); stride >= count. The same values as Evaluate per pixel.
  // Fields with a per-pixel model override it with one loop over the span
  // (the exact-lights solve calls it for every row).
  virtual void EvaluateSpan(int x0, int y, int count, int stride, float* light_dirs, float* rgb_intensities) const;
  // True when Evaluate gives the same values at every pixel (distant lights):
  // the solver then shares one light matrix between all pixels.
  virtual bool IsUniform() const { return false; }
  // Unit direction from the pixel's surface point towards the camera, in the
  // same frame (what a specular model needs). The default is an orthographic
  // camera looking down -z, as in DiLiGenT; perspective fields override it.
  virtual void ViewDirection(int x, int y, float* view_dir) const {
    (void)x, (void)y;
    view_dir[0] = 0, view_dir[1] = 0, view_dir[2] = 1;
  }
};

// Distant lights: the same direction and intensity at every pixel.
class DirectionalLightField final : public LightField {
 public:
  // Directions need not be unit length; they are normalised. Throws
  // std::invalid_argument on a zero or non-finite direction or intensity.
  DirectionalLightField(int width, int height, std::vector<Eigen::Vector3d> light_dirs,
                        std::vector<Eigen::Vector3d> rgb_intensities);
  int num_lights() const override { return static_cast<int>(light_dirs_.size()); }
  int width() const override { return width_; }
  int height() const override { return height_; }
  void Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const override;
  bool IsUniform() const override { return true; }

 private:
  int width_, height_;
  std::vector<Eigen::Vector3d> light_dirs_;
  std::vector<Eigen::Vector3d> rgb_intensities_;
};

// A near-field point source with angular falloff cos(angle off axis)^mu and
// inverse-square falloff.
struct PointLight {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      // same frame and unit as the surface points
  Eigen::Vector3d axis = -Eigen::Vector3d::UnitZ();        // unit, where the LED points
  double mu = 0;                                           // angular falloff exponent, >= 0
  Eigen::Vector3d rgb_intensity = Eigen::Vector3d::Ones(); // reading on axis at reference_distance
  double reference_distance = 1;                           // > 0, unit of the positions
};

// The surface point each pixel sees, in the lights' frame: held per pixel, or
// made on request (the table plane from the camera model: 12 bytes a pixel,
// 193 MB at 16 MP, not held; calibration/rig_light_field.h).
class SurfacePoints {
 public:
  virtual ~SurfacePoints() = default;
  virtual int width() const = 0;
  virtual int height() const = 0;
  // Pixel (x, y)'s point.
  virtual Eigen::Vector3f Point(int x, int y) const = 0;
  // The points of pixels (x0 + i, y), i < count, interleaved (x, y, z): a
  // pointer into the held points, or `scratch` filled with them.
  virtual const float* Span(int x0, int y, int count, std::vector<float>* scratch) const = 0;
};

// Points held per pixel: an image of 3 channels.
class HeldSurfacePoints final : public SurfacePoints {
 public:
  explicit HeldSurfacePoints(ImageF points);  // throws std::invalid_argument unless 3 channels
  int width() const override { return points_.width(); }
  int height() const override { return points_.height(); }
  Eigen::Vector3f Point(int x, int y) const override {
    return Eigen::Vector3f(points_(x, y, 0), points_(x, y, 1), points_(x, y, 2));
  }
  const float* Span(int x0, int y, int, std::vector<float>*) const override {
    return points_.row(y) + static_cast<size_t>(x0) * 3;
  }

 private:
  ImageF points_;
};

// Point lights shining on a known surface point per pixel (e.g. where each
// pixel's ray meets the table).
class PointLightField final : public LightField {
 public:
  // surface_points: 3 channels, one point per pixel. camera_centre (same
  // frame): where the view directions point; none = orthographic, +z. Throws
  // std::invalid_argument on invalid light parameters or a non-finite centre.
  PointLightField(std::vector<PointLight> lights, ImageF surface_points,
                  std::optional<Eigen::Vector3d> camera_centre = std::nullopt);
  // The same with the points from `surface_points` (not null).
  PointLightField(std::vector<PointLight> lights, std::unique_ptr<const SurfacePoints> surface_points,
                  std::optional<Eigen::Vector3d> camera_centre = std::nullopt);
  int num_lights() const override { return static_cast<int>(lights_.size()); }
  int width() const override { return surface_points_->width(); }
  int height() const override { return surface_points_->height(); }
  void Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const override;
  void EvaluateSpan(int x0, int y, int count, int stride, float* light_dirs, float* rgb_intensities) const override;
  // Towards the camera centre when one was given (else the orthographic default).
  void ViewDirection(int x, int y, float* view_dir) const override;

  const std::vector<PointLight>& lights() const { return lights_; }

 private:
  std::vector<PointLight> lights_;
  std::unique_ptr<const SurfacePoints> surface_points_;
  std::optional<Eigen::Vector3d> camera_centre_;
};

}  // namespace scanbench
