// The material preview page of an export (issue #16): one self-contained
// preview.html that shows the sample on a flat tile of its physical aspect
// and on a dome under a light the mouse drags, and lists the maps and the
// export's files. The sample is the export's tileable crop where there is
// one, else a centred crop of the frame (the border of a scan is often the
// table or the sample's lifted edge); the whole frame is shown on the tile
// only on request (issue #36). The dome is a spherical cap seen from above
// whose UVs are the plane's (u right, v up), so the texture lies on it once,
// with no seam and the tile's tangent frame. It opens from file:// with no
// network and no server: three.js (third_party/three, compiled in) rides
// along as a data: module URL and every texture as a data: PNG (8-bit, the
// frame's at most max_texture_px on the long side, the sample's at most
// max_sphere_texture_px), because Chrome refuses file:// textures in WebGL
// and file:// modules.
//
// Options after '#' in the URL: normal=off (render without the normal map),
// light=AZ,EL (degrees; azimuth from the image's +x towards +y, elevation above
// the sample plane; default 120,40), frame=on (the whole frame on the tile,
// also a checkbox on the panel), panel=off (the render alone).
// Layout with panel=off, which the tests rely on: the tile is centred in the
// left half of the window, fitted into 85 % of that half's width and of the
// height; the dome is centred in the right half, its outline's radius 40 % of
// min(half width, height). Orthographic view down the sample's normal.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/progress.h"
#include "core/summary.h"

namespace scanbench {

// The maps as the export holds them in memory, all the same size.
struct PreviewPageMaps {
  ImageF basecolor_linear_rec709;  // 3 channels, linear RGB (the export's albedo); shown through the sRGB curve
  ImageF normal_in_tangent;        // 3 channels, unit normals: x right, y up (OpenGL), z out of the sample
  ImageF roughness_alpha;          // 1 channel, GGX alpha in [0, 1]; shown as perceptual roughness sqrt(alpha)
  ImageF occlusion;                // 1 channel, ambient occlusion in [0, 1], 1 = open
  ImageF height_mm;                // 1 channel, mm (listed with its range; not displaced)
  ImageU8 valid;                   // 1 channel, nonzero = solved; empty = every pixel solved
};

// One file of the export, as the page lists it.
struct PreviewPageFile {
  std::string path;    // relative to the page, e.g. "twill/twill_normal.png"
  uintmax_t bytes = 0;
};

struct PreviewPageOptions {
  int max_texture_px = 1024;   // long side of the whole frame's textures, px, [16, 8192]; smaller maps stay as they are
  // Without a tileable crop the sample shown is a centred crop: this fraction
  // of each side, (0, 1]. The sample's textures (the crop's or the tileable
  // crop's) have at most max_sphere_texture_px on the long side, [16, 8192].
  double sphere_crop = 0.6;
  int max_sphere_texture_px = 512;
  std::string title;           // the page's heading, e.g. the material name; "" = "scanbench material"
  std::string basecolor_note;  // what the base colour is, e.g. "linear Rec.709 (D65), absolute"
  void Check() const;
};

struct PreviewPageSummary : AlgorithmSummary {
  int texture_width = 0, texture_height = 0;  // of the tile's textures
  uintmax_t bytes = 0;                        // of the page written
  double seconds = 0;
  // "preview.html: 5.1 MB, textures 1024x678".
  std::string BriefReport() const;
};

// Writes the page to `html_path` (temporary name, fsync, rename; an existing
// file is never overwritten). Maps of different sizes, a missing base colour
// or normal map, or a non-positive mm_per_pixel throw std::invalid_argument
// naming the map before any work; an empty roughness, occlusion or height map
// is left out of the page. Progress over the textures; cancelling writes nothing.
// The same as MakePreviewTextures, then the page from them.
PreviewPageSummary WritePreviewPage(const PreviewPageOptions& options, const PreviewPageMaps& maps,
                                    double mm_per_pixel, const std::vector<PreviewPageFile>& files,
                                    const std::filesystem::path& html_path, const ProgressCallback& progress = {});

// The page in two steps, so that the slow one (a downsample and two PNGs per
// map) can run while the files the page lists are still being written (the
// export): the textures need only the maps, the page only the textures and
// the files' sizes.
struct PreviewPageTexture {
  std::string use, label, note;  // three.js slot ("" = listed only), what the map is
  std::string uri, sphere_uri;   // data: PNGs of the whole frame's and the sample's texture ("" = not on the sample)
};
struct PreviewPageTextures {
  PreviewPageSummary summary;    // success, cancelled (no textures), the texture size and the seconds so far
  std::vector<PreviewPageTexture> textures;
  double mm_per_pixel = 0;
  int image_width = 0, image_height = 0;  // of the maps, px
  int crop_width = 0, crop_height = 0;    // of the sample (the tileable or the centred crop), px
  bool tileable = false;                  // the sample is the export's tileable crop
  double height_min_mm = 0, height_max_mm = 0;
};
// The maps borrowed (null = an empty map), e.g. while they are also being
// written to files: the same fields as PreviewPageMaps.
struct PreviewPageMapViews {
  const ImageF* basecolor_linear_rec709 = nullptr;
  const ImageF* normal_in_tangent = nullptr;
  const ImageF* roughness_alpha = nullptr;
  const ImageF* occlusion = nullptr;
  const ImageF* height_mm = nullptr;
  const ImageU8* valid = nullptr;
  // The export's tileable crop (maps/tileable_crop.h), shown as the sample
  // instead of the centred crop: null, or at least its base colour and
  // normals (3 channels each, one size), its roughness and occlusion (1
  // channel) optional.
  const ImageF* tile_basecolor_linear_rec709 = nullptr;
  const ImageF* tile_normal_in_tangent = nullptr;
  const ImageF* tile_roughness_alpha = nullptr;
  const ImageF* tile_occlusion = nullptr;
  static PreviewPageMapViews Of(const PreviewPageMaps& maps);
};
// The textures of the maps: throws like WritePreviewPage (naming `html_path`,
// where the page will go), progress up to 0.9; a cancel gives a cancelled
// summary and no textures.
PreviewPageTextures MakePreviewTextures(const PreviewPageOptions& options, const PreviewPageMapViews& maps,
                                        double mm_per_pixel, const std::filesystem::path& html_path,
                                        const ProgressCallback& progress = {});
PreviewPageTextures MakePreviewTextures(const PreviewPageOptions& options, const PreviewPageMaps& maps,
                                        double mm_per_pixel, const std::filesystem::path& html_path,
                                        const ProgressCallback& progress = {});
// The page from textures made by MakePreviewTextures with the same options
// (throws std::invalid_argument for cancelled ones) and the files it lists;
// `progress` is asked once before the page is written.
PreviewPageSummary WritePreviewPage(const PreviewPageOptions& options, const PreviewPageTextures& textures,
                                    const std::vector<PreviewPageFile>& files,
                                    const std::filesystem::path& html_path, const ProgressCallback& progress = {});

// The URL fragment for the options above, e.g. PreviewPageFragment(false, 90, 30, false)
// = "#normal=off&light=90,30&panel=off"; whole_frame adds "&frame=on".
std::string PreviewPageFragment(bool normal_map, double light_azimuth_deg, double light_elevation_deg,
                                bool panel, bool whole_frame = false);

}  // namespace scanbench
