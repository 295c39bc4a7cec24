// Choosing a few of a dataset's many lights so that they resemble the
// scanner's LED layout (e.g. 10 of DiLiGenT's 96), for measuring methods in
// the regime the bench works in.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace scanbench {

// Indices (ascending) of `count` distinct lights of `light_dirs` (unit or
// not, z towards the viewer) nearest to RingLightDirections(count, 30, 60)
// (solver/synthetic_scene.h: the rig's two LED rings), turned by the azimuth
// that fits best (searched in 1 deg steps): each layout direction in turn
// takes the nearest light not yet taken. Deterministic. Throws
// std::invalid_argument when count is outside [3, light_dirs.size()] or a
// direction is zero or not finite.
std::vector<int> SelectRingLights(const std::vector<Eigen::Vector3d>& light_dirs, int count);

}  // namespace scanbench
