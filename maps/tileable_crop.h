// A seamless tileable crop of aligned maps (albedo, normal, height, ...): a
// window inside the valid region, with a band beyond its edges blended across
// the wrap so the tile repeats without a visible seam.
//
// Method (cross-fade of the continuation): the tile is the window
// [x0, x0 + W) x [y0, y0 + H) of the source; in its first B columns the
// source's continuation past the right edge, columns x0 + W + x, is faded in,
// with weight 1 - t(x), t = smoothstep((x + 0.5) / B), and the same in the
// first B rows with rows y0 + H + y (both at once in the corner, bilinearly).
// Tile column 0 is then mostly source column x0 + W, the natural neighbour of
// tile column W - 1 = source x0 + W - 1, so the wrap is as smooth as any
// interior step; the band fades back to the plain window by column B. The
// price is some ghosting (two copies mixed) inside the band, which the window
// search keeps small: it picks, among all positions whose window plus band is
// valid, the one where the two copies mixed in the bands differ least (first
// map, mean absolute difference, every position by integral images).
#pragma once

#include <string>
#include <vector>

#include "core/progress.h"
#include "core/summary.h"
#include "core/image.h"

namespace scanbench {

struct TileableCropOptions {
  int tile_width = 0;            // px; 0 = the largest power of two that fits, >= 0
  int tile_height = 0;           // px; 0 = tile_width (or the largest power of two that fits), >= 0
  int blend_width_px = 32;       // width of the cross-fade band at each seam, px, [1, tile size]
  bool search_position = true;   // place the window where the wrap seam differs least; false = nearest the centre
  void Check() const;
};

// How each map is blended: normals are blended in slope space (nx/nz, ny/nz;
// nz clamped to >= 0.01, zero or non-finite normals taken as (0, 0, 1)) and
// re-normalised, everything else linearly. Pixels outside the bands are
// copied unchanged (normals normalised, zero or non-finite ones (0, 0, 1)).
enum class TileMapKind { kLinear, kNormal };

struct TileableMapInput {
  const ImageF* image = nullptr;
  TileMapKind kind = TileMapKind::kLinear;
};

struct TileableCropSummary : AlgorithmSummary {
  int x0 = 0, y0 = 0;            // top-left of the tile in the source, px
  int tile_width = 0, tile_height = 0;
  int blend_width_px = 0;
  // Figures of the first map, mean absolute difference per channel:
  double seam_cost = 0;              // between the two copies mixed in the bands (what the search minimises)
  double wrap_difference = 0;        // across the wrap of the tile, |tile(0, y) - tile(W-1, y)| and rows alike
  double naive_wrap_difference = 0;  // the same for the plain window without blending
  double neighbour_difference = 0;   // between interior neighbours of the tile, for scale
  double seconds = 0;
  // "Tileable crop: success, 512x512 at (300, 140), blend 32 px, wrap difference 0.012 (plain crop 0.094), 0.20 s".
  std::string BriefReport() const;
};

// All maps must share one size; valid (optional, 1 channel, non-zero = usable)
// marks pixels the tile may use (window plus blend band, (W + B) x (H + B),
// must lie inside). Fills `tiles` in the order of `maps`. Failure (no window
// fits; the message names the sizes) is reported in the summary and leaves
// `tiles` empty, as does a cancel (`progress` is asked after the window
// search and after each map). Throws std::invalid_argument before any work
// for bad options, no maps, a null or empty image, sizes that differ, a
// normal map without 3 channels, a mask of another size, or tiles == nullptr.
TileableCropSummary MakeTileableCrop(const TileableCropOptions& options, const std::vector<TileableMapInput>& maps,
                                     const ImageU8* valid, std::vector<ImageF>* tiles,
                                     const ProgressCallback& progress = {});

}  // namespace scanbench
