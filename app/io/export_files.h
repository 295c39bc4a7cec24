// The files of a material export (app/controllers/export_controller.h): each
// map, mask or document as planned -- where it goes, how its values are stored,
// what its metadata says -- and the writer that stores it in the encodings
// measured for the export (docs/export.md, "File encodings").
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "app/io/image_io.h"
#include "core/image.h"

namespace scanbench {

// How a float map becomes 16-bit integers: clamp(value * scale + offset, 0, 1) * 65535,
// through the sRGB transfer curve when `srgb` (base colour).
struct IntegerEncoding {
  double scale = 1, offset = 0;
  std::string text;  // for the manifest, e.g. "value * 65535"
  bool srgb = false;
};

struct ExportFile {
  std::string kind;                       // manifest key, e.g. "normal", "roughness_mip02"
  std::string relative_path;              // inside the export folder
  std::string format;                     // "exr", "png", "tiff"
  int bits_per_sample = 0;
  bool is_float = false;
  int width = 0, height = 0, channels = 0;
  std::string color_space;                // "Linear", "sRGB", "Raw"
  std::string encoding;                   // how values map to what is stored
  double mm_per_pixel = 0;
  std::vector<std::string> channel_names; // EXR only
  // The pixels: borrowed from the export's inputs or maps (an empty owner, so
  // no copy of a 16 MP map per file), or owned when made for this file only.
  std::shared_ptr<const ImageF> float_image;
  std::shared_ptr<const ImageU8> u8_image;  // stored as it is (mask)
  bool srgb8 = false;                       // float_image (linear RGB) as 8-bit sRGB (previews, engine base colour)
  std::shared_ptr<const std::string> document;  // a text or binary document (.gltf, .bin, .mtlx), stored as it is
  IntegerEncoding integer;
  ImageMetadata metadata;
  std::string sha256;
  uintmax_t bytes = 0;
};

// Writes `file` at `path` (never over an existing file): a document as it is,
// an EXR as 32-bit float compressed per map (ExportExrEncoding in the .cc), a
// PNG a band of rows at a time (8-bit as stored or through the sRGB curve,
// else 16-bit through `integer`), a TIFF as 16-bit through `integer`.
void WriteExportFile(const std::filesystem::path& path, const ExportFile& file);

}  // namespace scanbench
