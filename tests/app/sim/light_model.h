// The light model of calibration/rig.h written out again, independently of
// the renderers, for their tests.
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "calibration/rig.h"

namespace scanbench::testing {

// What a Lambertian surface with unit `normal` at `point` (table frame, mm)
// reads per unit reflectance from `led` in raw colour `channel`, as a
// fraction of the raw range above black (no shadow, no ambient).
inline double ExpectedDirect(const LedDescription& led, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                             int channel) {
  const Eigen::Vector3d to_led = led.position_in_table_mm - point;
  const double d = to_led.norm();
  const Eigen::Vector3d l = to_led / d;
  const double cos_off_axis = led.axis_in_table.dot(-l);
  return std::max(0.0, normal.dot(l)) * led.rgb_intensity[channel] * std::pow(cos_off_axis, led.mu) *
         std::pow(1000.0 / d, 2);
}

}  // namespace scanbench::testing
