// Writes a photometric solution as the files a material pipeline picks up.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "app/io/image_io.h"

#include "app/controllers/albedo_color.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// Normals in the tangent frame (x right, y up, z out of the sample) as
// 16-bit RGB: value = (n + 1) / 2 * 65535, i.e. the OpenGL (+Y up) convention.
ImageU16 EncodeNormalsPng16(const ImageF& normal_in_tangent);
// Linear RGB to 8-bit sRGB for a preview.
ImageU8 EncodeSrgbPreview(const ImageF& linear_rgb);

// Writes normal.exr, normal.png, albedo.exr, albedo_srgb.png, status.png,
// solved_mask.png and confidence.exr into `folder` (never overwriting).
// albedo.exr and albedo_srgb.png name their colour space (`albedo_color`):
// linear Rec.709 carries the OpenEXR chromaticities of Rec.709 / D65.
// Returns output kind -> file name.
std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution,
                                                     const AlbedoColor& albedo_color = {});

// The metadata of an albedo file in `albedo_color`'s space; `color_space` as
// ImageMetadata::color_space ("Linear" or "sRGB").
ImageMetadata AlbedoMetadata(const AlbedoColor& albedo_color, const std::string& color_space);

}  // namespace scanbench
