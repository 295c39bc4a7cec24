#include "calibration/rig_light_field.h"

#include <algorithm>
#include <atomic>
#include <string>
#include <vector>

#include "calibration/camera_model.h"

namespace scanbench {

std::vector<PointLight> RigPointLights(const RigDescription& rig) {
  std::vector<PointLight> lights;
  for (size_t k = 0; k < rig.leds.size(); ++k) {
    const LedDescription& led = rig.leds[k];
    if (!(led.position_in_table_mm.z() > 0)) {
      throw std::invalid_argument("rig.leds[" + std::to_string(k) + "] (id " + std::to_string(led.id) +
                                  "): position_in_table_mm z = " + std::to_string(led.position_in_table_mm.z()) +
                                  " must be above the table (> 0)");
    }
    PointLight light;
    light.position = led.position_in_table_mm;
    light.axis = led.axis_in_table;
    light.mu = led.mu;
    light.rgb_intensity = led.rgb_intensity;
    light.reference_distance = kLedReferenceDistanceMm;
    lights.push_back(light);
  }
  return lights;
}

namespace {

// The per-thread cache of TablePlanePoints::Point: direct-mapped pieces of
// kPieceWidth pixels of a row, keyed by instance, row and piece.
constexpr int kPieceWidth = 64;
constexpr int kCachedPieces = 64;
struct CachedPiece {
  uint64_t owner = 0;  // 0 = empty (instance ids start at 1)
  int y = -1, piece = -1;
  float xyz[3 * kPieceWidth];
};

std::atomic<uint64_t> next_table_points_id{1};

}  // namespace

TablePlanePoints::TablePlanePoints(const CameraGeometry& camera) : camera_(camera), id_(next_table_points_id++) {
  CheckCameraIntrinsics(camera_.intrinsics);
  // The border's rays are the most oblique: if they reach the table, every
  // ray does, so a bad camera fails here and not inside a solve.
  const int width = camera_.intrinsics.width, height = camera_.intrinsics.height;
  std::vector<float> scratch;
  for (const int y : {0, height - 1}) Span(0, y, width, &scratch);
  for (int y = 1; y + 1 < height; ++y) {
    Point(0, y);
    Point(width - 1, y);
  }
}

Eigen::Vector3f TablePlanePoints::Point(int x, int y) const {
  thread_local std::vector<CachedPiece> cache(kCachedPieces);
  const int piece = x / kPieceWidth;
  CachedPiece& cached = cache[static_cast<size_t>(y * 31 + piece) % kCachedPieces];
  if (cached.owner != id_ || cached.y != y || cached.piece != piece) {
    const int x0 = piece * kPieceWidth;
    ComputeTablePointsOfSpan(camera_, x0, y, std::min(kPieceWidth, width() - x0), cached.xyz);
    cached.owner = id_, cached.y = y, cached.piece = piece;
  }
  const float* p = cached.xyz + 3 * (x - piece * kPieceWidth);
  return Eigen::Vector3f(p[0], p[1], p[2]);
}

const float* TablePlanePoints::Span(int x0, int y, int count, std::vector<float>* scratch) const {
  scratch->resize(static_cast<size_t>(count) * 3);
  ComputeTablePointsOfSpan(camera_, x0, y, count, scratch->data());
  return scratch->data();
}

std::unique_ptr<PointLightField> MakeRigLightField(const RigDescription& rig) {
  return std::make_unique<PointLightField>(RigPointLights(rig), std::make_unique<TablePlanePoints>(rig.camera),
                                           CameraCentreInTable(rig.camera));
}

}  // namespace scanbench
