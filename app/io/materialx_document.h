// MaterialX (ASWF) document of an exported material: a standard_surface
// shader and a displacement from the height map, both fed by a node graph
// that reads the export's textures with their colour spaces. Only nodes of
// MaterialX's standard libraries (stdlib, pbrlib, bxdf) are used, so any
// MaterialX 1.38 or later loader reads it without custom definitions.
#pragma once

#include <string>

namespace scanbench {

struct MaterialXMaterialOptions {
  // How the roughness texture holds roughness.
  enum class Roughness {
    kGgxAlpha,     // GGX alpha (the generic presets): sqrt gives standard_surface's perceptual roughness
    kPerceptual,   // perceptual roughness itself (Unreal ORM G, glTF G)
    kSmoothness,   // 1 - perceptual roughness (HDRP mask map A)
  };
  std::string name;                 // material name (any characters; element names are made valid from it)
  // File names relative to the .mtlx, not empty.
  std::string basecolor_file;
  std::string basecolor_colorspace = "srgb_texture";  // MaterialX colour space: srgb_texture, lin_rec709, acescg
  std::string normal_file;          // tangent-space normals, (n + 1) / 2
  bool normal_y_down = false;       // DirectX normal map: green flipped back before normalmap
  std::string roughness_file;
  int roughness_channels = 1;       // 1, 3 or 4 channels in the file
  int roughness_channel = 0;        // which channel holds it, 0 .. roughness_channels - 1
  Roughness roughness = Roughness::kGgxAlpha;
  std::string height_file;          // float height (the export's _height.exr, mm)
  double height_scale = 0.001;      // scene units per stored height unit: mm -> metres; finite, > 0
  void Check() const;               // FieldError naming the field
};

// The XML text (MaterialX version 1.38, working colour space lin_rec709).
// Data maps are read as float / vector3 / vector4 images, which MaterialX
// never colour-manages; only the base colour (color3) carries a colorspace.
std::string MaterialXDocument(const MaterialXMaterialOptions& options);

}  // namespace scanbench
