// Engine presets of the export (issue #16): the channel packing, file names
// and normal convention that Unreal Engine, Unity HDRP and glTF 2.0 expect
// (sources in docs/export.md, "Engine presets"). Pure functions on maps in
// memory; ExportController writes what they return.
#pragma once

#include <string>

#include "core/image.h"

namespace scanbench {

enum class EngineTarget { kUnreal, kUnityHdrp, kGltf };

// The file names of one engine's textures (without folder), for material
// `stem` (e.g. "twill", or "twill_Tile" for the tileable crop).
struct EngineTextureNames {
  std::string basecolor;          // 8-bit sRGB RGB
  std::string normal;             // 16-bit, the engine's normal convention
  std::string packed;             // 16-bit linear: ORM (Unreal, glTF) or mask map (HDRP)
  std::string height_normalized;  // 16-bit linear height over its range; "" = the engine has no slot (glTF)
};
EngineTextureNames EngineTextureNamesOf(EngineTarget target, const std::string& stem);

// Unreal Engine reads DirectX normal maps (+Y down); Unity and glTF OpenGL (+Y up).
bool EngineNormalIsDirectX(EngineTarget target);

// Perceptual roughness sqrt(alpha) per pixel, GGX alpha clamped to [0, 1]:
// the roughness that Unreal, HDRP (as 1 - smoothness) and glTF take.
ImageF PerceptualRoughnessFromGgxAlpha(const ImageF& ggx_alpha);

// Unreal's ORM, also glTF's occlusion + metallicRoughness texture: R ambient
// occlusion (1 = open), G perceptual roughness, B metallic = 0 (a textile is
// a dielectric). Throws std::invalid_argument when the one-channel maps'
// sizes differ.
ImageF PackOcclusionRoughnessMetallic(const ImageF& occlusion, const ImageF& ggx_alpha);

// HDRP's mask map: R metallic = 0, G ambient occlusion, B detail mask = 1
// (a detail map, if the artist adds one, applies everywhere), A smoothness =
// 1 - perceptual roughness. Throws std::invalid_argument like the above.
ImageF PackHdrpMaskMap(const ImageF& occlusion, const ImageF& ggx_alpha);

}  // namespace scanbench
