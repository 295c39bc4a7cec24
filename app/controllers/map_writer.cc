#include "app/controllers/map_writer.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <future>
#include <vector>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "calibration/color_science.h"

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
    encoded.data()[i] = static_cast<uint8_t>(std::lround(SrgbEncode(linear_rgb.data()[i]) * 255.0));
  }
  return encoded;
}

ImageMetadata AlbedoMetadata(const AlbedoColor& albedo_color, const std::string& color_space) {
  ImageMetadata metadata;
  metadata.color_space = color_space;
  metadata.description = albedo_color.IsLinearRec709()
                             ? "diffuse albedo, linear Rec.709 primaries, D65 white (" + albedo_color.scale + ")"
                             : "diffuse albedo, white-balanced camera RGB: not colour calibrated (" +
                                   albedo_color.scale + ")";
  if (color_space == "sRGB") metadata.description += ", sRGB transfer curve";
  metadata.attributes["scanbench:albedo_color_space"] = albedo_color.color_space;
  metadata.attributes["scanbench:albedo_scale"] = albedo_color.scale;
  metadata.attributes["scanbench:albedo_color_source"] = AlbedoColorSourceName(albedo_color.source);
  if (albedo_color.IsLinearRec709()) {
    const Chromaticities c = Rec709Chromaticities();
    metadata.chromaticities =
        ImageChromaticities{c.red_x, c.red_y, c.green_x, c.green_y, c.blue_x, c.blue_y, c.white_x, c.white_y};
  }
  return metadata;
}

std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution,
                                                     const AlbedoColor& albedo_color) {
  const auto policy = OverwritePolicy::kRefuse;
  ImageU8 solved(solution.status.width(), solution.status.height(), 1);
  for (size_t i = 0; i < solved.size(); ++i) {
    solved.data()[i] = solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved) ? 255 : 0;
  }
  ImageF confidence(solution.status.width(), solution.status.height(), 3);
  for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
    confidence.data()[3 * i + 0] = solution.lights_used.data()[i];
    confidence.data()[3 * i + 1] = solution.condition_number.data()[i];
    confidence.data()[3 * i + 2] = solution.residual.data()[i];
  }

  // Compression dominates at 16 MP (seconds per file) and the files are
  // independent, so they are written concurrently.
  struct MapFile {
    const char* kind;
    const char* name;
    std::function<void(const std::filesystem::path&)> write;
  };
  const std::vector<MapFile> files = {
      {"normal_exr", "normal.exr", [&](const auto& path) { WriteExr(path, solution.normal_in_table, policy); }},
      {"normal_png16_opengl", "normal.png",
       [&](const auto& path) { WritePng(path, EncodeNormalsPng16(solution.normal_in_table), policy); }},
      {"albedo_exr", "albedo.exr",
       [&](const auto& path) {
         WriteExr(path, solution.albedo, policy, {}, AlbedoMetadata(albedo_color, "Linear"));
       }},
      {"albedo_srgb_preview", "albedo_srgb.png",
       [&](const auto& path) {
         WritePng(path, EncodeSrgbPreview(solution.albedo), policy, AlbedoMetadata(albedo_color, "sRGB"));
       }},
      {"status", "status.png", [&](const auto& path) { WritePng(path, solution.status, policy); }},
      {"solved_mask", "solved_mask.png", [&](const auto& path) { WritePng(path, solved, policy); }},
      {"confidence", "confidence.exr",
       [&](const auto& path) {
         WriteExr(path, confidence, policy, {"lights_used", "condition_number", "residual"});
       }},
  };
  std::vector<std::future<void>> pending;
  std::map<std::string, std::string> written;
  for (const MapFile& file : files) {
    pending.push_back(std::async(std::launch::async, file.write, folder / file.name));
    written[file.kind] = file.name;
  }
  for (std::future<void>& task : pending) task.get();  // rethrows a failure
  return written;
}

}  // namespace scanbench
