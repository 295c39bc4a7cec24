#include "solver/light_subset.h"

#include "solver/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace scanbench {
namespace {

void CheckCount(int count, size_t available) {
  if (count < 3 || static_cast<size_t>(count) > available) {
    throw std::invalid_argument("SelectRingLights: count = " + std::to_string(count) + " must lie in [3, " +
                                std::to_string(available) + "] (the number of lights)");
  }
}

}  // namespace

std::vector<int> SelectRingLights(const std::vector<Eigen::Vector3d>& light_dirs, int count) {
  CheckCount(count, light_dirs.size());
  std::vector<Eigen::Vector3d> unit;
  unit.reserve(light_dirs.size());
  for (size_t i = 0; i < light_dirs.size(); ++i) {
    const double norm = light_dirs[i].norm();
    if (!(norm > 0) || !std::isfinite(norm)) {
      throw std::invalid_argument("SelectRingLights: light_dirs[" + std::to_string(i) +
                                  "] must be finite and non-zero");
    }
    unit.push_back(light_dirs[i] / norm);
  }
  // The layout repeats every 360 / ceil(count / 2) degrees of turn.
  const int period_deg = static_cast<int>(std::ceil(360.0 / ((count + 1) / 2)));
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<int> best;
  for (int turn = 0; turn < period_deg; ++turn) {
    std::vector<bool> taken(unit.size(), false);
    std::vector<int> chosen;
    double cost = 0;
    for (const Eigen::Vector3d& target : RingLightDirections(count, 30, 60, turn)) {
      int nearest = -1;
      double nearest_angle = std::numeric_limits<double>::infinity();
      for (size_t i = 0; i < unit.size(); ++i) {
        if (taken[i]) continue;
        const double angle = std::acos(std::clamp(unit[i].dot(target), -1.0, 1.0));
        if (angle < nearest_angle) nearest_angle = angle, nearest = static_cast<int>(i);
      }
      taken[nearest] = true;
      chosen.push_back(nearest);
      cost += nearest_angle;
    }
    if (cost < best_cost) best_cost = cost, best = chosen;
  }
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace scanbench
