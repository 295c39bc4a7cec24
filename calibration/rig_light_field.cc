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
// kPieceWidth pixels of a row, keyed by instance, row and piece, each pixel
// made when first asked for (`made`, bit i: pixel i of the piece), since one
// call of OpenCV's undistortion costs about two points' work and most callers
// want few pixels of a piece:
// - a pixel after one already made (a caller walking the row) makes the rest
//   of the piece at once;
// - a pixel kLatticeStep px (or a multiple) from one already made makes the
//   piece's pixels on that lattice: the tile classifier's probes (its nodes
//   16 px apart, the checks half-way between them; a tile's last column and
//   the checks before it 8 px apart too);
// - any other is made alone.
// On the 16 MP session's solve (2.2 million points asked for) that makes 3.2
// million points in 0.44 million calls, against 10.2 million in 0.16 million
// with whole pieces. Each pixel is undistorted on its own either way
// (ComputeTablePointsOfRow), so the floats are the same.
constexpr int kPieceWidth = 64;
constexpr int kCachedPieces = 128;
constexpr int kLatticeStep = 8;
constexpr uint64_t kLatticeMask = 0x0101010101010101ull;  // bits 0, 8, ..., 56
struct CachedPiece {
  uint64_t owner = 0;  // 0 = empty (instance ids start at 1)
  int y = -1, piece = -1;
  uint64_t made = 0;
  float xyz[3 * kPieceWidth];
};

CachedPiece& SlotOf(std::vector<CachedPiece>& cache, int y, int piece) {
  return cache[static_cast<size_t>(y * 31 + piece) % kCachedPieces];
}

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
  const int piece = x / kPieceWidth, x0 = piece * kPieceWidth, i = x - x0;
  CachedPiece& cached = SlotOf(cache, y, piece);
  if (cached.owner != id_ || cached.y != y || cached.piece != piece) {
    cached.owner = id_, cached.y = y, cached.piece = piece, cached.made = 0;
  }
  const uint64_t bit = uint64_t{1} << i;
  if (!(cached.made & bit)) {
    // The caller walks the row when the pixel before this one in the piece
    // is made: the rest of the piece at once (pixels already made on a
    // lattice are made again, the same floats). Not across pieces: the
    // classifier's probes at a tile's last column and the next tile's first
    // are neighbours too.
    const int piece_count = std::min(kPieceWidth, width() - x0);
    if (i > 0 && (cached.made & (bit >> 1))) {
      const int count = piece_count - i;
      ComputeTablePointsOfSpan(camera_, x, y, count, cached.xyz + 3 * i);
      cached.made |= ~uint64_t{0} << i;
    } else if (cached.made & (kLatticeMask << (i % kLatticeStep))) {
      // The piece's pixels on this pixel's lattice (those made already are
      // made again: the same floats).
      const int phase = i % kLatticeStep;
      const int count = (piece_count - phase + kLatticeStep - 1) / kLatticeStep;
      float xyz[3 * (kPieceWidth / kLatticeStep)];
      ComputeTablePointsOfRow(camera_, x0 + phase, kLatticeStep, y, count, xyz);
      for (int m = 0; m < count; ++m) {
        const int at = phase + m * kLatticeStep;
        std::copy(xyz + 3 * m, xyz + 3 * m + 3, cached.xyz + 3 * at);
      }
      cached.made |= kLatticeMask << phase;
    } else {
      ComputeTablePointsOfSpan(camera_, x, y, 1, cached.xyz + 3 * i);
      cached.made |= bit;
    }
  }
  const float* p = cached.xyz + 3 * i;
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
