#include "app/io/raw_decoder.h"

#include <libraw/libraw.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <ctime>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <vector>

#include "app/io/file_util.h"

namespace scanbench {
namespace {

std::runtime_error Fail(const std::string& name, const std::string& problem) {
  return std::runtime_error(name + ": " + problem);
}

std::string Num(uint64_t value) { return std::to_string(value); }

// ---- TIFF container check --------------------------------------------------
// Most RAW formats (NEF, DNG, CR2, ARW, PEF) are TIFF containers. Walking the
// directories tells a truncated file apart from an unknown one before LibRaw
// sees it, and catches strips that end past the end of the file.

class TiffView {
 public:
  explicit TiffView(std::span<const uint8_t> bytes) : bytes_(bytes) {
    if (bytes.size() >= 4) {
      little_ = bytes[0] == 'I' && bytes[1] == 'I' && bytes[2] == 42 && bytes[3] == 0;
      const bool big = bytes[0] == 'M' && bytes[1] == 'M' && bytes[2] == 0 && bytes[3] == 42;
      is_tiff_ = little_ || big;
    }
  }
  bool is_tiff() const { return is_tiff_; }
  uint64_t size() const { return bytes_.size(); }
  bool Has(uint64_t offset, uint64_t length) const {
    return offset <= bytes_.size() && length <= bytes_.size() - offset;
  }
  uint32_t U16(uint64_t offset) const {
    const uint8_t* p = bytes_.data() + offset;
    return little_ ? (p[0] | p[1] << 8) : (p[0] << 8 | p[1]);
  }
  uint32_t U32(uint64_t offset) const {
    const uint8_t* p = bytes_.data() + offset;
    return little_ ? (uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24)
                   : (uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]));
  }

 private:
  std::span<const uint8_t> bytes_;
  bool little_ = false;
  bool is_tiff_ = false;
};

// Values of a SHORT/LONG/IFD entry; empty if the type is not integral or
// the values lie outside the file (reported separately).
std::vector<uint32_t> EntryValues(const TiffView& tiff, uint64_t entry, uint32_t type, uint32_t count) {
  const uint32_t item = type == 3 ? 2 : (type == 4 || type == 13) ? 4 : 0;
  constexpr uint32_t kMaxValues = 1u << 20;  // far more strips than any camera writes
  if (item == 0 || count == 0 || count > kMaxValues) return {};
  uint64_t at = entry + 8;
  if (uint64_t(item) * count > 4) at = tiff.U32(entry + 8);
  if (!tiff.Has(at, uint64_t(item) * count)) return {};
  std::vector<uint32_t> values(count);
  for (uint32_t i = 0; i < count; ++i) {
    values[i] = item == 2 ? tiff.U16(at + 2 * i) : tiff.U32(at + 4 * i);
  }
  return values;
}

// Returns a description of the first sign of truncation, or "".
std::string FindTiffTruncation(const TiffView& tiff) {
  const uint64_t size = tiff.size();
  const std::string ends = "the file ends at byte " + Num(size);
  if (!tiff.Has(0, 8)) return "it is " + Num(size) + " bytes, shorter than a TIFF header";
  std::vector<uint64_t> pending = {tiff.U32(4)};
  std::set<uint64_t> visited;
  while (!pending.empty() && visited.size() < 256) {
    const uint64_t ifd = pending.back();
    pending.pop_back();
    if (ifd == 0 || !visited.insert(ifd).second) continue;
    if (!tiff.Has(ifd, 2)) return "an image directory starts at byte " + Num(ifd) + " but " + ends;
    const uint32_t entries = tiff.U16(ifd);
    const uint64_t table_end = ifd + 2 + 12ull * entries;
    if (table_end > size) {
      return "the image directory at byte " + Num(ifd) + " (" + Num(entries) + " entries) needs bytes up to " +
             Num(table_end) + " but " + ends;
    }
    std::vector<uint32_t> offsets, counts;
    for (uint32_t i = 0; i < entries; ++i) {
      const uint64_t entry = ifd + 2 + 12ull * i;
      const uint32_t tag = tiff.U16(entry);
      const uint32_t type = tiff.U16(entry + 2);
      const uint32_t count = tiff.U32(entry + 4);
      if (tag == 273 || tag == 324) offsets = EntryValues(tiff, entry, type, count);  // Strip/TileOffsets
      if (tag == 279 || tag == 325) counts = EntryValues(tiff, entry, type, count);   // Strip/TileByteCounts
      if (tag == 330) {                                                               // SubIFDs
        for (uint32_t sub : EntryValues(tiff, entry, type, count)) pending.push_back(sub);
      }
    }
    for (size_t i = 0; i < std::min(offsets.size(), counts.size()); ++i) {
      const uint64_t end = uint64_t(offsets[i]) + counts[i];
      if (counts[i] > 0 && end > size) {
        return "the image directory at byte " + Num(ifd) + " stores pixel data up to byte " + Num(end) +
               " but " + ends;
      }
    }
    if (tiff.Has(table_end, 4)) pending.push_back(tiff.U32(table_end));
  }
  return "";
}

// ---- LibRaw callbacks ------------------------------------------------------

struct DataErrors {
  int end_of_file = 0;
  int corrupt = 0;
  int first_corrupt_offset = -1;
};

// Replaces LibRaw's default handler, which prints to stderr.
void OnDataError(void* data, const char* /*file*/, const int offset) {
  auto* errors = static_cast<DataErrors*>(data);
  if (offset < 0) {
    ++errors->end_of_file;
  } else {
    if (errors->corrupt++ == 0) errors->first_corrupt_offset = offset;
  }
}

void OnMemoryError(void*, const char*, const char*) {}

std::string LibRawMessage(int code) { return std::string("LibRaw: ") + LibRaw::strerror(code); }

// ---- checks on what LibRaw identified -------------------------------------

void CheckIsBayer(LibRaw& processor, const std::string& name) {
  const libraw_iparams_t& idata = processor.imgdata.idata;
  const auto& unpacker = processor.get_internal_data_pointer()->unpacker_data;
  if (processor.is_floating_point()) {
    throw Fail(name, "holds floating-point samples; only integer Bayer mosaics are supported");
  }
  if (idata.filters == 0) {
    throw Fail(name, "holds a " + Num(std::max<unsigned>(unpacker.tiff_samples, 1)) +
                         "-channel image with " + Num(idata.colors) +
                         " colours per pixel (linear/demosaiced, e.g. a LinearRaw DNG), not a Bayer CFA mosaic");
  }
  if (idata.filters == 9) {
    throw Fail(name, "has an X-Trans 6x6 CFA; only 2x2 Bayer mosaics are supported");
  }
  if (idata.filters < 1000) {
    throw Fail(name, "has a CFA that repeats over more than 2x2 pixels (LibRaw filters = " +
                         Num(idata.filters) + "); only 2x2 Bayer mosaics are supported");
  }
  if (idata.colors != 3) {
    throw Fail(name, "has a " + Num(idata.colors) + "-colour CFA (" + std::string(idata.cdesc) +
                         "); only RGB Bayer mosaics are supported");
  }
  if (processor.is_fuji_rotated()) {
    throw Fail(name, "has a Fuji SuperCCD (45-degree) layout; only 2x2 Bayer mosaics are supported");
  }
}

void CheckPixelDataInFile(LibRaw& processor, const TiffView& tiff, const std::string& name) {
  const libraw_image_sizes_t& sizes = processor.imgdata.sizes;
  const auto& unpacker = processor.get_internal_data_pointer()->unpacker_data;
  const uint64_t file_size = tiff.size();
  const auto data_offset = static_cast<uint64_t>(std::max<INT64>(unpacker.data_offset, 0));
  if (sizes.raw_width == 0 || sizes.raw_height == 0) {
    throw Fail(name, "has no pixel data (LibRaw found a " + Num(sizes.raw_width) + "x" + Num(sizes.raw_height) +
                         " raw image)");
  }
  // Offset 0 in a TIFF container points at the header itself: the raw image
  // directory has no StripOffsets/TileOffsets.
  if (tiff.is_tiff() && data_offset < 8) {
    throw Fail(name, "has no pixel data (the raw image directory gives no data offset)");
  }
  if (data_offset >= file_size) {
    throw Fail(name, "is truncated or has no pixel data: its pixel data should start at byte " +
                         Num(data_offset) + " but the file ends at byte " + Num(file_size));
  }
  // LibRaw reads an uncompressed DNG as one run from the first strip and
  // rounds a short final read up, so a file cut by a byte decodes "cleanly".
  // Tiled files (tile_width < INT_MAX) are left to the TIFF directory check.
  const bool tiled = unpacker.tile_width != static_cast<unsigned>(INT_MAX);
  if (processor.imgdata.idata.dng_version != 0 && unpacker.tiff_compress == 1 && !tiled) {
    if (unpacker.data_size == 0) {
      throw Fail(name, "has no pixel data (the raw image's byte count is 0)");
    }
    const uint64_t row_bytes =
        (uint64_t(sizes.raw_width) * std::max<unsigned>(unpacker.tiff_samples, 1) * unpacker.tiff_bps + 7) / 8;
    const uint64_t end = data_offset + row_bytes * sizes.raw_height;
    if (end > file_size) {
      throw Fail(name, "is truncated: its " + Num(sizes.raw_width) + "x" + Num(sizes.raw_height) + " " +
                           Num(unpacker.tiff_bps) + "-bit pixel data needs bytes " + Num(data_offset) + ".." +
                           Num(end) + " but the file ends at byte " + Num(file_size));
    }
  }
}

CfaPattern ReadCfa(LibRaw& processor, const std::string& name) {
  const char* cdesc = processor.imgdata.idata.cdesc;
  auto color_name = [&](int row, int col) -> char {
    const int c = processor.COLOR(row, col);
    return (c >= 0 && c < 4) ? cdesc[c] : '?';
  };
  std::string tile;
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 2; ++col) tile.push_back(color_name(row, col));
  }
  // LibRaw's `filters` describes 8 rows x 2 columns; a Bayer CFA repeats every 2.
  for (int row = 2; row < 8; ++row) {
    for (int col = 0; col < 2; ++col) {
      if (color_name(row, col) != tile[(row & 1) * 2 + col]) {
        throw Fail(name, "has a CFA that does not repeat every 2x2 pixels (rows 0-1 are " + tile +
                             "); only 2x2 Bayer mosaics are supported");
      }
    }
  }
  try {
    return CfaPatternFromName(tile);
  } catch (const std::invalid_argument&) {
    throw Fail(name, "has CFA tile " + tile + ", which is not one of RGGB, BGGR, GRBG, GBRG");
  }
}

// Black level per 2x2 tile position of the visible area: black + cblack[colour]
// + the cblack[6..] pattern (cblack[4] rows x cblack[5] columns). After
// unpack() LibRaw has moved the part common to all channels into `black`.
std::array<uint16_t, 4> ReadBlackLevels(LibRaw& processor, const std::string& name) {
  const libraw_colordata_t& color = processor.imgdata.color;
  const unsigned rows = color.cblack[4];
  const unsigned cols = color.cblack[5];
  if (uint64_t(rows) * cols > LIBRAW_CBLACK_SIZE - 6) {
    throw Fail(name, "has a " + Num(rows) + "x" + Num(cols) + " black level pattern, larger than LibRaw stores");
  }
  auto black_at = [&](unsigned row, unsigned col) -> uint64_t {
    uint64_t value = uint64_t(color.black) + color.cblack[processor.COLOR(row, col) & 3];
    if (rows > 0 && cols > 0) value += color.cblack[6 + (row % rows) * cols + col % cols];
    return value;
  };
  std::array<uint16_t, 4> tile{};
  for (unsigned i = 0; i < 4; ++i) {
    const uint64_t value = black_at(i >> 1, i & 1);
    if (value > 0xffff) {
      throw Fail(name, "black level " + Num(value) + " at tile position (" + Num(i & 1) + ", " + Num(i >> 1) +
                           ") exceeds 65535");
    }
    tile[i] = static_cast<uint16_t>(value);
  }
  // A 2x2 tile can only describe a pattern that repeats every 2 pixels.
  const unsigned period_rows = 2 * std::max(rows, 1u);
  const unsigned period_cols = 2 * std::max(cols, 1u);
  for (unsigned row = 0; row < period_rows; ++row) {
    for (unsigned col = 0; col < period_cols; ++col) {
      if (black_at(row, col) != tile[(row & 1) * 2 + (col & 1)]) {
        throw Fail(name, "has a " + Num(rows) + "x" + Num(cols) + " black level pattern that does not repeat every "
                             "2x2 pixels (pixel (" + Num(col) + ", " + Num(row) + ") has " +
                             Num(black_at(row, col)) + " but pixel (" + Num(col & 1) + ", " + Num(row & 1) +
                             ") has " + Num(tile[(row & 1) * 2 + (col & 1)]) + ")");
      }
    }
  }
  return tile;
}

std::string FormatTimestamp(time_t timestamp) {
  if (timestamp <= 0) return "";
  std::tm local{};
  if (localtime_r(&timestamp, &local) == nullptr) return "";
  char text[32];
  if (std::strftime(text, sizeof(text), "%Y:%m:%d %H:%M:%S", &local) == 0) return "";
  return text;
}

// Opens the buffer: a file LibRaw does not recognise, a truncated header and a
// non-Bayer sensor are refused here, before any pixel is read.
std::unique_ptr<LibRaw> OpenRaw(std::span<const uint8_t> bytes, const TiffView& tiff, DataErrors* errors,
                                const std::string& name) {
  auto processor = std::make_unique<LibRaw>(LIBRAW_OPTIONS_NONE);
  processor->set_dataerror_handler(&OnDataError, errors);
  processor->set_memerror_handler(&OnMemoryError, nullptr);
  // open_buffer takes a non-const pointer but only reads through it.
  const int rc = processor->open_buffer(const_cast<uint8_t*>(bytes.data()), bytes.size());
  if (rc != LIBRAW_SUCCESS) {
    if (rc == LIBRAW_FILE_UNSUPPORTED) {
      throw Fail(name, "is not a RAW file LibRaw recognises (" + LibRawMessage(rc) + ")");
    }
    if (rc == LIBRAW_IO_ERROR || errors->end_of_file > 0) {
      // Only a known container can be called truncated; a short text file is simply not a RAW file.
      if (tiff.is_tiff()) {
        throw Fail(name, "is truncated: LibRaw reached the end of the file while reading its header (" +
                             LibRawMessage(rc) + ")");
      }
      throw Fail(name, "is not a RAW file LibRaw recognises (it ends after " + Num(bytes.size()) +
                           " bytes without a RAW header; " + LibRawMessage(rc) + ")");
    }
    throw Fail(name, "cannot be opened (" + LibRawMessage(rc) + ")");
  }
  CheckIsBayer(*processor, name);
  CheckPixelDataInFile(*processor, tiff, name);
  return processor;
}

// Decodes the pixel data; truncation and corrupt data reported by LibRaw's
// handlers are errors, not silently wrong pixels.
void UnpackRaw(LibRaw& processor, const DataErrors& errors, const std::string& name) {
  const int rc = processor.unpack();
  if (rc != LIBRAW_SUCCESS) {
    if (rc == LIBRAW_IO_ERROR || errors.end_of_file > 0) {
      throw Fail(name, "is truncated: LibRaw reached the end of the file while reading pixel data (" +
                           LibRawMessage(rc) + ")");
    }
    throw Fail(name, "pixel data cannot be decoded (" + LibRawMessage(rc) + ")");
  }
  if (errors.end_of_file > 0) {
    throw Fail(name, "is truncated: LibRaw reached the end of the file while reading pixel data");
  }
  if (processor.error_count() > 0 || errors.corrupt > 0) {
    throw Fail(name, "has corrupt pixel data: LibRaw reported " +
                         Num(std::max(processor.error_count(), errors.corrupt)) + " decoding error(s)" +
                         (errors.first_corrupt_offset >= 0 ? ", the first near byte " + Num(errors.first_corrupt_offset)
                                                           : std::string()));
  }
}

// The decoded data must be one integer Bayer plane whose visible area lies
// inside the raw frame.
void CheckDecodedLayout(const LibRaw& processor, const std::string& name) {
  const libraw_rawdata_t& rawdata = processor.imgdata.rawdata;
  if (rawdata.raw_image == nullptr) {
    if (rawdata.color3_image || rawdata.color4_image) {
      throw Fail(name, "decodes to a " + std::string(rawdata.color3_image ? "3" : "4") +
                           "-channel image, not a Bayer CFA mosaic");
    }
    if (rawdata.float_image || rawdata.float3_image || rawdata.float4_image) {
      throw Fail(name, "decodes to floating-point samples; only integer Bayer mosaics are supported");
    }
    throw Fail(name, "has no pixel data (LibRaw decoded no raw image)");
  }
  const libraw_image_sizes_t& sizes = processor.imgdata.sizes;
  if (sizes.width == 0 || sizes.height == 0 || sizes.left_margin + sizes.width > sizes.raw_width ||
      sizes.top_margin + sizes.height > sizes.raw_height || sizes.raw_pitch < 2u * sizes.raw_width) {
    throw Fail(name, "has an inconsistent layout: visible " + Num(sizes.width) + "x" + Num(sizes.height) +
                         " at (" + Num(sizes.left_margin) + ", " + Num(sizes.top_margin) + ") in a " +
                         Num(sizes.raw_width) + "x" + Num(sizes.raw_height) + " raw frame");
  }
}

// CFA, black and white levels; the white level must lie above every black level.
void ReadLevels(LibRaw& processor, const std::string& name, RawImage* image) {
  image->cfa = ReadCfa(processor, name);
  image->black_level = ReadBlackLevels(processor, name);
  const unsigned maximum = processor.imgdata.color.maximum;
  if (maximum == 0 || maximum > 0xffff) {
    throw Fail(name, "white level " + Num(maximum) + " is outside 1..65535");
  }
  image->white_level = static_cast<uint16_t>(maximum);
  for (int i = 0; i < 4; ++i) {
    if (image->white_level <= image->black_level[i]) {
      throw Fail(name, "white level " + Num(image->white_level) + " is not above the black level " +
                           Num(image->black_level[i]) + " at tile position (" + Num(i & 1) + ", " + Num(i >> 1) +
                           ")");
    }
  }
}

// The visible area of the raw plane, margins cut off.
ImageU16 CopyVisibleMosaic(const LibRaw& processor) {
  const libraw_image_sizes_t& sizes = processor.imgdata.sizes;
  ImageU16 mosaic(sizes.width, sizes.height, 1);
  const size_t pitch = sizes.raw_pitch / 2;  // raw_pitch is in bytes
  for (int y = 0; y < sizes.height; ++y) {
    const uint16_t* source =
        processor.imgdata.rawdata.raw_image + (size_t(y) + sizes.top_margin) * pitch + sizes.left_margin;
    std::copy_n(source, sizes.width, mosaic.row(y));
  }
  return mosaic;
}

void ReadCaptureInfo(const LibRaw& processor, DecodedRaw* decoded) {
  decoded->make = processor.imgdata.idata.make;
  decoded->model = processor.imgdata.idata.model;
  decoded->software = processor.imgdata.idata.software;
  decoded->serial = processor.imgdata.shootinginfo.BodySerial;
  decoded->capture_time = FormatTimestamp(processor.imgdata.other.timestamp);
  decoded->exposure_time_s = processor.imgdata.other.shutter;
  decoded->iso = processor.imgdata.other.iso_speed;
  decoded->f_number = processor.imgdata.other.aperture;
  decoded->lens = processor.imgdata.lens.Lens;
  decoded->orientation = processor.imgdata.sizes.flip;
}

// ---- colour data ------------------------------------------------------------

// LibRaw's colour index (row of its matrices, entry of cam_mul) of camera R, G
// and B, from its colour description ("RGBG"); nullopt for other CFAs.
std::optional<std::array<int, 3>> RgbColorIndices(const LibRaw& processor) {
  const std::string cdesc = processor.imgdata.idata.cdesc;
  std::array<int, 3> index{};
  for (int c = 0; c < 3; ++c) {
    const size_t found = cdesc.find("RGB"[c]);
    if (found == std::string::npos || found >= 4) return std::nullopt;
    index[c] = static_cast<int>(found);
  }
  return index;
}

bool IsDaylightIlluminant(int illuminant) {
  return illuminant == LIBRAW_WBI_D65 || illuminant == LIBRAW_WBI_Daylight || illuminant == LIBRAW_WBI_D55 ||
         illuminant == LIBRAW_WBI_D75 || illuminant == LIBRAW_WBI_D50 || illuminant == LIBRAW_WBI_Flash;
}

template <int Rows, int Cols>
bool AllZero(const float (&m)[Rows][Cols]) {
  for (int r = 0; r < Rows; ++r) {
    for (int c = 0; c < Cols; ++c) {
      if (m[r][c] != 0) return false;
    }
  }
  return true;
}

// Which of the DNG's two calibrations to use: D65, else another daylight
// one, else the only matrix present; -1 if none.
int ChooseDngCalibration(const libraw_colordata_t& color) {
  const bool present[2] = {!AllZero(color.dng_color[0].colormatrix), !AllZero(color.dng_color[1].colormatrix)};
  for (int i = 0; i < 2; ++i) {
    if (present[i] && color.dng_color[i].illuminant == LIBRAW_WBI_D65) return i;
  }
  for (int i = 0; i < 2; ++i) {
    if (present[i] && IsDaylightIlluminant(color.dng_color[i].illuminant)) return i;
  }
  return present[0] ? 0 : (present[1] ? 1 : -1);
}

// A DNG's rows are its colour planes, which LibRaw indexes like cdesc.
void ReadDngColorMatrices(const LibRaw& processor, const std::array<int, 3>& rgb, DecodedRaw* decoded) {
  const libraw_colordata_t& color = processor.imgdata.color;
  const int chosen = ChooseDngCalibration(color);
  if (chosen < 0) return;
  const libraw_dng_color_t& dng = color.dng_color[chosen];
  // XYZ -> camera = AnalogBalance * CameraCalibration * ColorMatrix (DNG 1.4, chapter 6).
  const bool has_calibration = !AllZero(dng.calibration);
  Eigen::Matrix3d color_matrix, calibration;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      color_matrix(r, c) = dng.colormatrix[rgb[r]][c];
      calibration(r, c) = has_calibration ? dng.calibration[rgb[r]][rgb[c]] : (r == c ? 1.0 : 0.0);
    }
  }
  Eigen::Vector3d analog_balance;
  for (int c = 0; c < 3; ++c) {
    const float balance = color.dng_levels.analogbalance[rgb[c]];
    analog_balance[c] = (std::isfinite(balance) && balance > 0) ? balance : 1.0;
  }
  const Eigen::Matrix3d camera_from_xyz = analog_balance.asDiagonal() * calibration * color_matrix;
  if (camera_from_xyz.allFinite()) {
    decoded->camera_from_xyz = camera_from_xyz;
    decoded->camera_from_xyz_illuminant = dng.illuminant;
  }
  if (!AllZero(dng.forwardmatrix)) {
    Eigen::Matrix3d forward;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) forward(r, c) = dng.forwardmatrix[r][rgb[c]];
    }
    if (forward.allFinite()) decoded->forward_matrix_d50 = forward;
  }
}

// Channel values normalised to green = 1; nullopt unless all are finite and > 0.
std::optional<Eigen::Vector3d> RelativeToGreen(const float (&values)[4], const std::array<int, 3>& rgb) {
  Eigen::Vector3d v(values[rgb[0]], values[rgb[1]], values[rgb[2]]);
  if (!v.allFinite() || (v.array() <= 0).any()) return std::nullopt;
  return v / v[1];
}

void ReadColorData(const LibRaw& processor, DecodedRaw* decoded) {
  const std::optional<std::array<int, 3>> rgb = RgbColorIndices(processor);
  if (!rgb) return;
  const libraw_colordata_t& color = processor.imgdata.color;
  if (processor.imgdata.idata.dng_version != 0) {
    ReadDngColorMatrices(processor, *rgb, decoded);
  } else if (!AllZero(color.cam_xyz)) {
    Eigen::Matrix3d camera_from_xyz;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) camera_from_xyz(r, c) = color.cam_xyz[(*rgb)[r]][c];
    }
    if (camera_from_xyz.allFinite()) {
      decoded->camera_from_xyz = camera_from_xyz;
      decoded->camera_from_xyz_illuminant = LIBRAW_WBI_D65;  // LibRaw's table holds Adobe's D65 matrices
    }
  }
  // cam_mul are multipliers (1 / neutral); inverting and normalising gives the neutral.
  if (const auto multipliers = RelativeToGreen(color.cam_mul, *rgb)) {
    decoded->as_shot_neutral = multipliers->cwiseInverse();
  }
  if (const auto daylight = RelativeToGreen(color.pre_mul, *rgb)) decoded->daylight_multipliers = *daylight;
}

}  // namespace

DecodedRaw DecodeRawWithInfo(std::span<const uint8_t> bytes, const std::string& name) {
  if (bytes.empty()) throw Fail(name, "is empty (0 bytes); not a RAW file");
  const TiffView tiff(bytes);
  if (tiff.is_tiff()) {
    const std::string truncation = FindTiffTruncation(tiff);
    if (!truncation.empty()) throw Fail(name, "is truncated: " + truncation);
  }
  DataErrors errors;
  const std::unique_ptr<LibRaw> processor = OpenRaw(bytes, tiff, &errors, name);
  UnpackRaw(*processor, errors, name);
  CheckDecodedLayout(*processor, name);

  DecodedRaw decoded;
  ReadLevels(*processor, name, &decoded.image);
  decoded.image.mosaic = CopyVisibleMosaic(*processor);
  ReadCaptureInfo(*processor, &decoded);
  ReadColorData(*processor, &decoded);
  return decoded;
}

RawImage DecodeRaw(std::span<const uint8_t> bytes, const std::string& name_for_errors) {
  return DecodeRawWithInfo(bytes, name_for_errors).image;
}

DecodedRaw DecodeRawFileWithInfo(const std::filesystem::path& path) {
  const std::vector<uint8_t> bytes = ReadFileBytes(path);
  return DecodeRawWithInfo(bytes, path.string());
}

RawImage DecodeRawFile(const std::filesystem::path& path) { return DecodeRawFileWithInfo(path).image; }

void CheckRawSize(const RawImage& image, int width, int height, const std::string& name) {
  if (!image.mosaic.SameSize(width, height)) {
    throw std::runtime_error(name + ": image is " + std::to_string(image.width()) + "x" +
                             std::to_string(image.height()) + " but the session records " +
                             std::to_string(width) + "x" + std::to_string(height));
  }
}

}  // namespace scanbench
