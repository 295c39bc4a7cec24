// A seamless tileable crop of aligned maps (albedo, normal, height, ...): a
// window inside the valid region, with a band beyond its edges blended across
// the wrap so the tile repeats without a visible seam.
#pragma once

#include <string>
#include <vector>

#include "maps/map_summary.h"
#include "solver/image.h"

namespace scanbench {

struct TileableCropOptions {
  int tile_width = 0;            // px; 0 = the largest power of two that fits, >= 0
  int tile_height = 0;           // px; 0 = tile_width (or the largest that fits), >= 0
  int blend_width_px = 32;       // width of the cross-fade band at each seam, px, >= 1
  bool search_position = true;   // place the window where the wrap seam differs least
  void Check() const;
};

// How each map is blended: normals are blended in slope space and
// re-normalised, everything else linearly.
enum class TileMapKind { kLinear, kNormal };

struct TileableMapInput {
  const ImageF* image = nullptr;
  TileMapKind kind = TileMapKind::kLinear;
};

struct TileableCropSummary {
  MapTermination termination = MapTermination::kFailure;
  std::string message;
  int x0 = 0, y0 = 0;            // top-left of the tile in the source, px
  int tile_width = 0, tile_height = 0;
  double seam_cost = 0;          // mean difference across the wrap before blending, first map
  double seconds = 0;
};

// All maps must share one size; valid (optional) marks pixels the tile may
// use (window plus blend band must lie inside). Fills `tiles` in the order
// of `maps`. Failure (e.g. no window fits) is reported in the summary.
TileableCropSummary MakeTileableCrop(const std::vector<TileableMapInput>& maps, const ImageU8* valid,
                                     const TileableCropOptions& options, std::vector<ImageF>* tiles);

}  // namespace scanbench
