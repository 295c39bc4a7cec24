#include "tests/app/io/test_dng_util.h"

#include <tiffio.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>

#include "app/io/file_util.h"

namespace scanbench::testing {
namespace fs = std::filesystem;

std::vector<uint8_t> MakeTestDng(const TestDngOptions& o) {
  TempDir dir;
  const fs::path path = dir / "test.dng";
  TIFF* tif = TIFFOpen(path.c_str(), "wl");
  if (!tif) throw std::runtime_error("MakeTestDng: TIFFOpen failed");
  TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(o.width));
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(o.height));
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, o.samples_per_pixel);
  TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, o.photometric);
  TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, static_cast<uint32_t>(o.height));
  TIFFSetField(tif, TIFFTAG_MAKE, "scanbench");
  TIFFSetField(tif, TIFFTAG_MODEL, "Test Rig");
  if (!o.cfa_pattern.empty()) {
    uint16_t dim[2] = {o.cfa_rows, o.cfa_cols};
    TIFFSetField(tif, TIFFTAG_CFAREPEATPATTERNDIM, dim);
    TIFFSetField(tif, TIFFTAG_CFAPATTERN, static_cast<int>(o.cfa_pattern.size()), o.cfa_pattern.data());
  }
  uint8_t version[4] = {1, 4, 0, 0};
  TIFFSetField(tif, TIFFTAG_DNGVERSION, version);
  TIFFSetField(tif, TIFFTAG_UNIQUECAMERAMODEL, "scanbench Test Rig");
  uint16_t black_dim[2] = {o.black_rows, o.black_cols};
  TIFFSetField(tif, TIFFTAG_BLACKLEVELREPEATDIM, black_dim);
  TIFFSetField(tif, TIFFTAG_BLACKLEVEL, static_cast<int>(o.black_levels.size()), o.black_levels.data());
  std::vector<uint32_t> white(static_cast<size_t>(o.samples_per_pixel), o.white_level);
  TIFFSetField(tif, TIFFTAG_WHITELEVEL, static_cast<int>(white.size()), white.data());
  if (!o.color_matrix1.empty()) {
    TIFFSetField(tif, TIFFTAG_COLORMATRIX1, static_cast<int>(o.color_matrix1.size()), o.color_matrix1.data());
    TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT1, o.illuminant1);
  }
  if (!o.color_matrix2.empty()) {
    TIFFSetField(tif, TIFFTAG_COLORMATRIX2, static_cast<int>(o.color_matrix2.size()), o.color_matrix2.data());
    TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT2, o.illuminant2);
  }
  if (!o.camera_calibration2.empty()) {
    TIFFSetField(tif, TIFFTAG_CAMERACALIBRATION2, static_cast<int>(o.camera_calibration2.size()),
                 o.camera_calibration2.data());
  }
  if (!o.as_shot_neutral.empty()) {
    TIFFSetField(tif, TIFFTAG_ASSHOTNEUTRAL, static_cast<int>(o.as_shot_neutral.size()), o.as_shot_neutral.data());
  }
  std::vector<uint16_t> row(static_cast<size_t>(o.width) * o.samples_per_pixel);
  for (int y = 0; y < o.height; ++y) {
    for (size_t i = 0; i < row.size(); ++i) {
      row[i] = static_cast<uint16_t>((i / o.samples_per_pixel + y) % o.white_level);
    }
    if (TIFFWriteScanline(tif, row.data(), static_cast<uint32_t>(y), 0) != 1) {
      TIFFClose(tif);
      throw std::runtime_error("MakeTestDng: TIFFWriteScanline failed");
    }
  }
  TIFFClose(tif);
  return ReadFileBytes(path);
}

namespace {
uint32_t U16(const std::vector<uint8_t>& b, size_t at) { return b.at(at) | b.at(at + 1) << 8; }
uint32_t U32(const std::vector<uint8_t>& b, size_t at) { return U16(b, at) | U16(b, at + 2) << 16; }

size_t FindEntry(const std::vector<uint8_t>& bytes, uint16_t tag) {
  if (bytes.size() < 8 || bytes[0] != 'I') throw std::runtime_error("not a little-endian TIFF");
  const size_t ifd = U32(bytes, 4);
  const uint32_t entries = U16(bytes, ifd);
  for (uint32_t i = 0; i < entries; ++i) {
    const size_t entry = ifd + 2 + 12 * i;
    if (U16(bytes, entry) == tag) {
      if (U32(bytes, entry + 4) != 1) throw std::runtime_error("tag " + std::to_string(tag) + " has count != 1");
      return entry;
    }
  }
  throw std::runtime_error("tag " + std::to_string(tag) + " not in IFD0");
}
}  // namespace

uint32_t ReadIfd0Value(const std::vector<uint8_t>& bytes, uint16_t tag) {
  const size_t entry = FindEntry(bytes, tag);
  return U16(bytes, entry + 2) == 3 ? U16(bytes, entry + 8) : U32(bytes, entry + 8);
}

void PatchIfd0Value(std::vector<uint8_t>& bytes, uint16_t tag, uint32_t value) {
  const size_t entry = FindEntry(bytes, tag);
  const int size = U16(bytes, entry + 2) == 3 ? 2 : 4;
  for (int i = 0; i < size; ++i) bytes[entry + 8 + i] = static_cast<uint8_t>(value >> (8 * i));
}

}  // namespace scanbench::testing
