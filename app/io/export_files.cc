#include "app/io/export_files.h"

#include <algorithm>
#include <cmath>

#include "app/io/file_util.h"
#include "calibration/color_science.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// Row y of a float map as 16-bit integers: lround(value * 65535) of the
// encoded value. The sRGB curve goes through SrgbQuantizer (the same
// integers without a pow per value) when the value is the sample itself.
void QuantiseRow16(const ImageF& image, int y, const IntegerEncoding& encoding, uint16_t* out) {
  const float* in = image.row(y);
  const size_t count = static_cast<size_t>(image.width()) * image.channels();
  if (encoding.srgb && encoding.scale == 1 && encoding.offset == 0) {
    const SrgbQuantizer& srgb = SrgbQuantizer::Of(16);
    for (size_t i = 0; i < count; ++i) out[i] = srgb(in[i]);
    return;
  }
  for (size_t i = 0; i < count; ++i) {
    double value = std::clamp(double(in[i]) * encoding.scale + encoding.offset, 0.0, 1.0);
    if (encoding.srgb) value = SrgbEncode(value);
    // lround for a value in [0, 65535]: the fraction is exact, halves round up.
    const double scaled = value * 65535.0, whole = std::trunc(scaled);
    out[i] = static_cast<uint16_t>(whole) + (scaled - whole >= 0.5 ? 1 : 0);
  }
}

ImageU16 Quantise16(const ImageF& image, const IntegerEncoding& encoding) {
  ImageU16 quantised(image.width(), image.height(), image.channels());
  for (int y = 0; y < image.height(); ++y) QuantiseRow16(image, y, encoding, quantised.row(y));
  return quantised;
}

// The export's PNGs through WritePngRows: the
// rows are quantised a band at a time, so no 16-bit copy of a map is held.
PngRowSource PngRowsOf(const ExportFile& file) {
  PngRowSource rows;
  if (file.u8_image) {
    const ImageU8& image = *file.u8_image;
    rows = {image.width(), image.height(), image.channels(), 8, [&image](int y, void* row) {
              std::copy_n(image.row(y), static_cast<size_t>(image.width()) * image.channels(),
                          static_cast<uint8_t*>(row));
            }};
  } else if (file.srgb8) {
    const ImageF& image = *file.float_image;
    rows = {image.width(), image.height(), image.channels(), 8, [&image](int y, void* row) {
              const SrgbQuantizer& srgb = SrgbQuantizer::Of(8);
              const float* in = image.row(y);
              uint8_t* out = static_cast<uint8_t*>(row);
              for (size_t i = 0; i < static_cast<size_t>(image.width()) * image.channels(); ++i) {
                out[i] = static_cast<uint8_t>(srgb(in[i]));
              }
            }};
  } else {
    const ImageF& image = *file.float_image;
    const IntegerEncoding& encoding = file.integer;
    rows = {image.width(), image.height(), image.channels(), 16, [&image, &encoding](int y, void* row) {
              QuantiseRow16(image, y, encoding, static_cast<uint16_t*>(row));
            }};
  }
  return rows;
}

// The export's lossless encodings, chosen by measurement on a 16 MP export
// (benchmarks/export_encoding_benchmark.cc; docs/export.md, "File
// encodings"). Every PNG: zlib level 1, libpng's up filter and zlib's
// run-length strategy, which leaves the match search out: the most CPU of
// the PNG writes went to it.
PngEncoding ExportPngEncoding() {
  PngEncoding encoding;
  encoding.zlib_level = 1;
  encoding.filter = PngFilter::kUp;
  encoding.strategy = PngStrategy::kRle;
  return encoding;
}

// Float EXRs (the exr preset's maps, and every preset's height and
// confidence): 32-bit float, values as in memory, compressed by what packs
// each map for the least CPU: the float height's low mantissa bits are noise
// (no compression gains enough to pay its time), the cavity is mostly exactly
// 1 (zip packs the runs), the rest piz. Tiles like their map.
ExrEncoding ExportExrEncoding(const std::string& kind) {
  const std::string map = kind.rfind("tile_", 0) == 0 ? kind.substr(5) : kind;
  if (map == "height") return {ExrSampleType::kFloat32, ExrCompression::kNone};
  if (map == "cavity") return {ExrSampleType::kFloat32, ExrCompression::kZip};
  return {ExrSampleType::kFloat32, ExrCompression::kPiz};
}

}  // namespace

void WriteExportFile(const fs::path& path, const ExportFile& file) {
  const auto policy = OverwritePolicy::kRefuse;
  if (file.document) {
    WriteFileAtomic(path, *file.document, policy);
  } else if (file.format == "exr") {
    WriteExr(path, *file.float_image, policy, file.channel_names, file.metadata, ExportExrEncoding(file.kind));
  } else if (file.format == "png") {
    WritePngRows(path, PngRowsOf(file), policy, file.metadata, ExportPngEncoding());
  } else {
    WriteTiff(path, Quantise16(*file.float_image, file.integer), policy, file.metadata);
  }
}

}  // namespace scanbench
