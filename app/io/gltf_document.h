// glTF 2.0 (Khronos) of a material sample: a flat tile of the sample's
// physical size with a metallicRoughness material that references the
// export's textures. Built in memory; the export writes the two files with
// its atomic writer and lists them in material.json.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

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
GltfTileFiles BuildGltfTile(const GltfTileOptions& options);

}  // namespace scanbench
