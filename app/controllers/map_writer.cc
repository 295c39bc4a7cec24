#include "app/controllers/map_writer.h"

#include <algorithm>
#include <cmath>

#include "app/io/file_util.h"
#include "app/io/image_io.h"

namespace scanbench {

ImageU16 EncodeNormalsPng16(const ImageF& normal_in_tangent) {
  ImageU16 encoded(normal_in_tangent.width(), normal_in_tangent.height(), 3);
  for (size_t i = 0; i < encoded.size(); ++i) {
    const double value = std::clamp((double(normal_in_tangent.data()[i]) + 1.0) * 0.5, 0.0, 1.0);
    encoded.data()[i] = static_cast<uint16_t>(std::lround(value * 65535.0));
  }
  return encoded;
}

ImageU8 EncodeSrgbPreview(const ImageF& linear_rgb) {
  ImageU8 encoded(linear_rgb.width(), linear_rgb.height(), linear_rgb.channels());
  for (size_t i = 0; i < encoded.size(); ++i) {
    const double linear = std::clamp(double(linear_rgb.data()[i]), 0.0, 1.0);
    const double srgb = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
    encoded.data()[i] = static_cast<uint8_t>(std::lround(srgb * 255.0));
  }
  return encoded;
}

std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution) {
  const auto policy = OverwritePolicy::kRefuse;
  std::map<std::string, std::string> files;
  WriteExr(folder / "normal.exr", solution.normal_in_table, policy);
  files["normal_exr"] = "normal.exr";
  WritePng(folder / "normal.png", EncodeNormalsPng16(solution.normal_in_table), policy);
  files["normal_png16_opengl"] = "normal.png";
  WriteExr(folder / "albedo.exr", solution.albedo, policy);
  files["albedo_exr"] = "albedo.exr";
  WritePng(folder / "albedo_srgb.png", EncodeSrgbPreview(solution.albedo), policy);
  files["albedo_srgb_preview"] = "albedo_srgb.png";
  WritePng(folder / "status.png", solution.status, policy);
  files["status"] = "status.png";
  ImageU8 solved(solution.status.width(), solution.status.height(), 1);
  for (size_t i = 0; i < solved.size(); ++i) {
    solved.data()[i] = solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved) ? 255 : 0;
  }
  WritePng(folder / "solved_mask.png", solved, policy);
  files["solved_mask"] = "solved_mask.png";
  ImageF confidence(solution.status.width(), solution.status.height(), 3);
  for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
    confidence.data()[3 * i + 0] = solution.lights_used.data()[i];
    confidence.data()[3 * i + 1] = solution.condition_number.data()[i];
    confidence.data()[3 * i + 2] = solution.residual.data()[i];
  }
  WriteExr(folder / "confidence.exr", confidence, policy, {"lights_used", "condition_number", "residual"});
  files["confidence"] = "confidence.exr";
  return files;
}

}  // namespace scanbench
