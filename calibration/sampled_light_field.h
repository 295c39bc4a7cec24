// A per-pixel light field stored on a coarse grid of pixel positions and
// interpolated bilinearly: what a light calibration measures (any angular
// pattern, any falloff), at bounded memory. At 16 MP with a node every 16
// pixels, 10 lights take 15 MB instead of 3.8 GB at every pixel.
#pragma once

#include <cstddef>
#include <vector>

#include "solver/light_field.h"

namespace scanbench {

// Node (i, j) of the grid sits at pixel (origin_x + i * step, origin_y + j * step).
struct LightFieldGrid {
  int width = 0;          // image size the field serves, pixels, > 0
  int height = 0;         // pixels, > 0
  double origin_x = 0;    // pixel position of node (0, 0), pixels
  double origin_y = 0;
  double step = 1;        // node spacing, pixels, > 0
  int nodes_x = 0;        // >= 2
  int nodes_y = 0;        // >= 2

  // The smallest grid with spacing `step` (>= 1) whose nodes cover every pixel
  // centre of a width x height image, starting at pixel (0, 0).
  static LightFieldGrid Covering(int width, int height, int step);
  size_t num_nodes() const { return static_cast<size_t>(nodes_x) * nodes_y; }
  double NodeX(int i) const { return origin_x + i * step; }
  double NodeY(int j) const { return origin_y + j * step; }
  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

class SampledLightField final : public LightField {
 public:
  // light_dirs_in_table and rgb_intensities: num_nodes * num_lights * 3 values,
  // node-major, then light, then component: value[(node * num_lights + k) * 3 + c],
  // node = j * nodes_x + i. Directions need not be unit (they are normalised
  // after interpolation). Throws std::invalid_argument for a bad grid, wrong
  // sizes, a non-finite value, a zero direction or a negative intensity.
  SampledLightField(LightFieldGrid grid, int num_lights, std::vector<float> light_dirs_in_table,
                    std::vector<float> rgb_intensities);

  // Samples `field` at the nodes of a covering grid with spacing `step` pixels
  // (the grid's nodes must lie on pixels of `field`: node positions are
  // rounded and clamped to the image).
  static SampledLightField Sample(const LightField& field, int step);

  int num_lights() const override { return num_lights_; }
  int width() const override { return grid_.width; }
  int height() const override { return grid_.height; }
  // Bilinear between the four surrounding nodes; beyond the outermost nodes
  // linear extrapolation from the border cell. The direction is renormalised,
  // intensities below 0 are clamped to 0.
  void Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const override;
  // The same at a sub-pixel position.
  void EvaluateAt(double x, double y, float* light_dirs, float* rgb_intensities) const;

  // View directions (surface towards the camera, table frame) at the nodes:
  // num_nodes * 3 values, node-major like the lights, need not be unit. Empty
  // (the default) = orthographic, +z. Throws std::invalid_argument on a wrong
  // size, a non-finite value or a zero direction.
  void SetViewDirections(std::vector<float> view_dirs_in_table);
  // Bilinear between the nodes like the lights, renormalised.
  void ViewDirection(int x, int y, float* view_dir) const override;

  const LightFieldGrid& grid() const { return grid_; }
  const std::vector<float>& node_light_dirs() const { return light_dirs_; }
  const std::vector<float>& node_rgb_intensities() const { return rgb_intensities_; }
  size_t MemoryBytes() const { return (light_dirs_.size() + rgb_intensities_.size()) * sizeof(float); }

 private:
  LightFieldGrid grid_;
  int num_lights_;
  std::vector<float> light_dirs_;
  std::vector<float> rgb_intensities_;
  std::vector<float> view_dirs_;  // per node, or empty
};

}  // namespace scanbench
