#include "calibration/sampled_light_field.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/field_error.h"

namespace scanbench {
namespace {

// Cell index and fraction along one axis; the fraction leaves [0, 1] beyond
// the outermost nodes (linear extrapolation).
void Locate(double position, double origin, double step, int nodes, int* cell, double* fraction) {
  const double u = (position - origin) / step;
  const int i = std::clamp(static_cast<int>(std::floor(u)), 0, nodes - 2);
  *cell = i;
  *fraction = u - i;
}

}  // namespace

LightFieldGrid LightFieldGrid::Covering(int width, int height, int step) {
  SCANBENCH_REQUIRE_GE("LightFieldGrid", "step", step, 1);
  LightFieldGrid grid;
  grid.width = width;
  grid.height = height;
  grid.step = step;
  grid.nodes_x = std::max(2, (width - 1 + step - 1) / step + 1);
  grid.nodes_y = std::max(2, (height - 1 + step - 1) / step + 1);
  grid.Check();
  return grid;
}

void LightFieldGrid::Check() const {
  SCANBENCH_REQUIRE_GT("LightFieldGrid", "width", width, 0);
  SCANBENCH_REQUIRE_GT("LightFieldGrid", "height", height, 0);
  SCANBENCH_REQUIRE_FINITE_GT("LightFieldGrid", "step", step, 0);
  SCANBENCH_REQUIRE_FINITE("LightFieldGrid", "origin_x", origin_x);
  SCANBENCH_REQUIRE_FINITE("LightFieldGrid", "origin_y", origin_y);
  SCANBENCH_REQUIRE_GE("LightFieldGrid", "nodes_x", nodes_x, 2);
  SCANBENCH_REQUIRE_GE("LightFieldGrid", "nodes_y", nodes_y, 2);
}

SampledLightField::SampledLightField(LightFieldGrid grid, int num_lights, std::vector<float> light_dirs_in_table,
                                     std::vector<float> rgb_intensities)
    : grid_(grid), num_lights_(num_lights), light_dirs_(std::move(light_dirs_in_table)),
      rgb_intensities_(std::move(rgb_intensities)) {
  grid_.Check();
  if (num_lights_ < 1) {
    throw std::invalid_argument("sampled light field: num_lights = " + std::to_string(num_lights_) + " must be >= 1");
  }
  const size_t expected = grid_.num_nodes() * num_lights_ * 3;
  if (light_dirs_.size() != expected || rgb_intensities_.size() != expected) {
    throw std::invalid_argument("sampled light field: " + std::to_string(light_dirs_.size()) + " direction and " +
                                std::to_string(rgb_intensities_.size()) + " intensity values given; " +
                                std::to_string(grid_.nodes_x) + "x" + std::to_string(grid_.nodes_y) + " nodes x " +
                                std::to_string(num_lights_) + " lights x 3 = " + std::to_string(expected) +
                                " required for each");
  }
  for (size_t n = 0; n < grid_.num_nodes(); ++n) {
    for (int k = 0; k < num_lights_; ++k) {
      const size_t base = (n * num_lights_ + k) * 3;
      const float* d = &light_dirs_[base];
      const float* e = &rgb_intensities_[base];
      const std::string where = "sampled light field: node " + std::to_string(n % grid_.nodes_x) + "," +
                                std::to_string(n / grid_.nodes_x) + ", light " + std::to_string(k) + ": ";
      if (!std::isfinite(d[0]) || !std::isfinite(d[1]) || !std::isfinite(d[2]) ||
          d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < 1e-12f) {
        throw std::invalid_argument(where + "direction must be finite and non-zero");
      }
      for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(e[c]) || e[c] < 0) {
          throw std::invalid_argument(where + "rgb_intensity[" + std::to_string(c) + "] = " + std::to_string(e[c]) +
                                      " must be finite and >= 0");
        }
      }
    }
  }
}

SampledLightField SampledLightField::Sample(const LightField& field, int step) {
  LightFieldGrid grid = LightFieldGrid::Covering(field.width(), field.height(), step);
  const int num_lights = field.num_lights();
  std::vector<float> dirs(grid.num_nodes() * num_lights * 3), intensities(dirs.size());
  for (int j = 0; j < grid.nodes_y; ++j) {
    for (int i = 0; i < grid.nodes_x; ++i) {
      // The last node may lie beyond the image: sample the border pixel and
      // place the node there, so that the grid stays regular only where exact.
      const int x = std::min(field.width() - 1, static_cast<int>(std::lround(grid.NodeX(i))));
      const int y = std::min(field.height() - 1, static_cast<int>(std::lround(grid.NodeY(j))));
      const size_t base = (static_cast<size_t>(j) * grid.nodes_x + i) * num_lights * 3;
      field.Evaluate(x, y, &dirs[base], &intensities[base]);
    }
  }
  // Nodes clamped onto the border pixel make the border cells shorter than
  // `step`; instead of a non-uniform grid, extrapolate those nodes linearly
  // from the border pixel to their nominal position.
  auto fix_axis = [&](bool along_x) {
    const int nodes = along_x ? grid.nodes_x : grid.nodes_y;
    const int size = along_x ? field.width() : field.height();
    const double last_nominal = (nodes - 1) * grid.step;
    const double last_actual = size - 1;
    if (last_nominal == last_actual) return;
    // Value at nominal = prev + (actual value - prev) * step / (actual - prev position).
    const double scale = grid.step / (last_actual - (nodes - 2) * grid.step);
    const int other = along_x ? grid.nodes_y : grid.nodes_x;
    for (int o = 0; o < other; ++o) {
      const size_t last = along_x ? static_cast<size_t>(o) * grid.nodes_x + nodes - 1
                                  : static_cast<size_t>(nodes - 1) * grid.nodes_x + o;
      const size_t prev = along_x ? last - 1 : last - grid.nodes_x;
      for (int v = 0; v < num_lights * 3; ++v) {
        for (std::vector<float>* values : {&dirs, &intensities}) {
          float& a = (*values)[last * num_lights * 3 + v];
          const float b = (*values)[prev * num_lights * 3 + v];
          a = static_cast<float>(b + (a - b) * scale);
        }
      }
      for (int k = 0; k < num_lights; ++k) {
        for (int c = 0; c < 3; ++c) {
          float& e = intensities[(last * num_lights + k) * 3 + c];
          e = std::max(e, 0.0f);
        }
      }
    }
  };
  fix_axis(true);
  fix_axis(false);
  return SampledLightField(grid, num_lights, std::move(dirs), std::move(intensities));
}

void SampledLightField::Evaluate(int x, int y, float* light_dirs, float* rgb_intensities) const {
  EvaluateAt(x, y, light_dirs, rgb_intensities);
}

void SampledLightField::EvaluateAt(double x, double y, float* light_dirs, float* rgb_intensities) const {
  int i, j;
  double fx, fy;
  Locate(x, grid_.origin_x, grid_.step, grid_.nodes_x, &i, &fx);
  Locate(y, grid_.origin_y, grid_.step, grid_.nodes_y, &j, &fy);
  const float w00 = static_cast<float>((1 - fx) * (1 - fy)), w10 = static_cast<float>(fx * (1 - fy));
  const float w01 = static_cast<float>((1 - fx) * fy), w11 = static_cast<float>(fx * fy);
  const size_t stride = static_cast<size_t>(num_lights_) * 3;
  const size_t n00 = (static_cast<size_t>(j) * grid_.nodes_x + i) * stride;
  const size_t n10 = n00 + stride;
  const size_t n01 = n00 + grid_.nodes_x * stride;
  const size_t n11 = n01 + stride;
  for (size_t v = 0; v < stride; ++v) {
    light_dirs[v] = w00 * light_dirs_[n00 + v] + w10 * light_dirs_[n10 + v] + w01 * light_dirs_[n01 + v] +
                    w11 * light_dirs_[n11 + v];
    const float e = w00 * rgb_intensities_[n00 + v] + w10 * rgb_intensities_[n10 + v] +
                    w01 * rgb_intensities_[n01 + v] + w11 * rgb_intensities_[n11 + v];
    rgb_intensities[v] = std::max(e, 0.0f);
  }
  for (int k = 0; k < num_lights_; ++k) {
    float* d = light_dirs + 3 * k;
    const float norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    // Interpolating unit vectors that differ by a few degrees never nears 0;
    // keep a valid direction anyway.
    if (norm > 1e-12f) {
      d[0] /= norm;
      d[1] /= norm;
      d[2] /= norm;
    } else {
      d[0] = 0;
      d[1] = 0;
      d[2] = 1;
    }
  }
}

void SampledLightField::SetViewDirections(std::vector<float> view_dirs_in_table) {
  if (view_dirs_in_table.size() != grid_.num_nodes() * 3) {
    throw FieldError("SampledLightField", "view_dirs_in_table", std::to_string(view_dirs_in_table.size()) + " values",
                     "must hold 3 per grid node (" + std::to_string(grid_.num_nodes() * 3) + ")");
  }
  for (size_t n = 0; n < grid_.num_nodes(); ++n) {
    const float* d = &view_dirs_in_table[3 * n];
    const float norm2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if (!std::isfinite(norm2) || !(norm2 > 0)) {
      throw FieldError("SampledLightField", "view_dirs_in_table[node " + std::to_string(n) + "]", "zero or non-finite",
                       "must be a finite non-zero direction");
    }
  }
  view_dirs_ = std::move(view_dirs_in_table);
}

void SampledLightField::ViewDirection(int x, int y, float* view_dir) const {
  if (view_dirs_.empty()) {
    LightField::ViewDirection(x, y, view_dir);
    return;
  }
  int i, j;
  double fx, fy;
  Locate(x, grid_.origin_x, grid_.step, grid_.nodes_x, &i, &fx);
  Locate(y, grid_.origin_y, grid_.step, grid_.nodes_y, &j, &fy);
  const size_t n00 = (static_cast<size_t>(j) * grid_.nodes_x + i) * 3, n10 = n00 + 3;
  const size_t n01 = n00 + static_cast<size_t>(grid_.nodes_x) * 3, n11 = n01 + 3;
  double d[3], norm2 = 0;
  for (int c = 0; c < 3; ++c) {
    d[c] = (1 - fx) * (1 - fy) * view_dirs_[n00 + c] + fx * (1 - fy) * view_dirs_[n10 + c] +
           (1 - fx) * fy * view_dirs_[n01 + c] + fx * fy * view_dirs_[n11 + c];
    norm2 += d[c] * d[c];
  }
  const double norm = std::sqrt(norm2);
  for (int c = 0; c < 3; ++c) view_dir[c] = norm > 1e-12 ? static_cast<float>(d[c] / norm) : (c == 2 ? 1.0f : 0.0f);
}

}  // namespace scanbench
