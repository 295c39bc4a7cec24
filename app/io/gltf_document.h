// glTF 2.0 (Khronos) of a material sample: a flat tile of the sample's
// physical size with a metallicRoughness material that references the
// export's textures. Built in memory; the export writes the two files with
// its atomic writer and lists them in material.json.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"

namespace scanbench {

struct GltfTileOptions {
  std::string name;                         // material, mesh and node name, not empty
  double width_m = 0, height_m = 0;         // size of the tile, metres (glTF's unit), finite and > 0
  // Texture URIs relative to the .gltf, not empty.
  std::string basecolor_uri;                // sRGB base colour
  std::string normal_uri;                   // OpenGL tangent-space normals (+Y up)
  std::string occlusion_roughness_metallic_uri;  // R occlusion, G perceptual roughness, B metallic
  std::string buffer_uri;                   // the .bin, relative to the .gltf
  std::string generator = "scanbench";      // asset.generator
  // The displaced mesh (when BuildGltfTile gets a height map): at most this
  // many grid vertices, [4, 65536] (16-bit indices); metres per height unit.
  int displaced_max_vertices = 65536;
  double height_unit_m = 0.001;             // the export's heights are mm; finite, > 0
  void Check() const;                       // FieldError naming the field
};

struct GltfTileFiles {
  std::string json;                         // the .gltf text
  std::vector<uint8_t> buffer;              // the .bin: positions, normals, tangents, UVs, indices
};

// The tile lies in the XZ plane facing +Y (glTF's up), centred on the origin;
// image x runs along +X and image y (downwards) along +Z, so UV (0, 0) is the
// image's top-left corner as glTF samples it. Every vertex has the normal +Y
// and the tangent (+X, w = +1): the bitangent cross(N, T) * w = -Z points to
// the image's top, which is where an OpenGL normal map's +Y points.
//
// With `height` (one channel, the maps' size) the file gets a second node,
// beside the tile at +X (1.1 tile widths): a grid decimated from the height
// map to at most displaced_max_vertices vertices (each the box mean of the
// pixels around it), heights along +Y, with normals from the grid itself. Its
// material is the tile's without the normal map: the grid carries the relief
// to its own resolution, and the normal map's tilts would count twice.
// Throws std::invalid_argument when `height` is not one channel.
GltfTileFiles BuildGltfTile(const GltfTileOptions& options, const ImageF* height = nullptr);

// The displaced grid's size for a `width` x `height` map: the coarsest whole
// pixel step that keeps nodes_x * nodes_y <= max_vertices.
struct GltfGridSize {
  int nodes_x = 0, nodes_y = 0, step_px = 0;
};
GltfGridSize DisplacedGridSize(int width, int height, int max_vertices);

}  // namespace scanbench
