// Writes a photometric solution as the files a material pipeline picks up.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "solver/photometric_solver.h"

namespace scanbench {

// Normals in the tangent frame (x right, y up, z out of the sample) as
// 16-bit RGB: value = (n + 1) / 2 * 65535, i.e. the OpenGL (+Y up) convention.
ImageU16 EncodeNormalsPng16(const ImageF& normal_in_tangent);
// Linear RGB to 8-bit sRGB for a preview.
ImageU8 EncodeSrgbPreview(const ImageF& linear_rgb);

// Writes normal.exr, normal.png, albedo.exr, albedo_srgb.png, status.png,
// solved_mask.png and confidence.exr into `folder` (never overwriting).
// Returns output kind -> file name.
std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution);

}  // namespace scanbench
