// The light field the rig description predicts before any light calibration:
// every LED a point source, every pixel's surface point on the table plane.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "calibration/rig.h"
#include "solver/light_field.h"

namespace scanbench {

// The rig's LEDs as point lights, in the order of rig.leds. Throws
// std::invalid_argument naming the LED that is unusable.
std::vector<PointLight> RigPointLights(const RigDescription& rig);

// Where each pixel's ray meets the table plane, made on request from the
// camera model (ComputeTablePointsOfSpan: the same floats as
// ComputeTablePoints) rather than held: 193 MB at 16 MP. Point() keeps a
// small per-thread cache of 64-pixel row pieces filled as they are asked
// for: a caller walking a row makes the rest of a piece in one call, one
// asking for pixels 8 px apart (the tile classifier's probes) the piece's
// pixels on that lattice, any other one pixel: sparse callers pay about per
// point, not per piece.
class TablePlanePoints final : public SurfacePoints {
 public:
  // Throws std::invalid_argument when the camera is unusable or a ray of the
  // image's border (the most oblique ones) does not reach the table.
  explicit TablePlanePoints(const CameraGeometry& camera);
  int width() const override { return camera_.intrinsics.width; }
  int height() const override { return camera_.intrinsics.height; }
  Eigen::Vector3f Point(int x, int y) const override;
  const float* Span(int x0, int y, int count, std::vector<float>* scratch) const override;

 private:
  CameraGeometry camera_;
  uint64_t id_;  // names this instance in the per-thread cache
};

// Lights in the order of rig.leds, on the table plane's points made on
// request (TablePlanePoints). Throws std::invalid_argument naming the LED or
// camera field that is unusable.
std::unique_ptr<PointLightField> MakeRigLightField(const RigDescription& rig);

}  // namespace scanbench
