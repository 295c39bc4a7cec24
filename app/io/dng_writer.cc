#include "app/io/dng_writer.h"

#include <tiffio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <stdexcept>

#include "app/io/file_util.h"

namespace scanbench {
namespace {

// ---- libtiff writing into a growable memory buffer -------------------------

struct MemoryFile {
  std::vector<uint8_t> bytes;
  uint64_t position = 0;
  std::string error;  // first libtiff error message
};

tmsize_t MemoryRead(thandle_t handle, void* buffer, tmsize_t size) {
  auto* file = static_cast<MemoryFile*>(handle);
  if (size <= 0 || file->position >= file->bytes.size()) return 0;
  const uint64_t n = std::min<uint64_t>(static_cast<uint64_t>(size), file->bytes.size() - file->position);
  std::memcpy(buffer, file->bytes.data() + file->position, n);
  file->position += n;
  return static_cast<tmsize_t>(n);
}

tmsize_t MemoryWrite(thandle_t handle, void* buffer, tmsize_t size) {
  auto* file = static_cast<MemoryFile*>(handle);
  if (size <= 0) return 0;
  const uint64_t end = file->position + static_cast<uint64_t>(size);
  if (end > file->bytes.size()) file->bytes.resize(end);
  std::memcpy(file->bytes.data() + file->position, buffer, static_cast<size_t>(size));
  file->position = end;
  return size;
}

toff_t MemorySeek(thandle_t handle, toff_t offset, int whence) {
  auto* file = static_cast<MemoryFile*>(handle);
  int64_t base = 0;
  if (whence == SEEK_CUR) base = static_cast<int64_t>(file->position);
  if (whence == SEEK_END) base = static_cast<int64_t>(file->bytes.size());
  const int64_t target = base + static_cast<int64_t>(offset);
  if (target < 0) return static_cast<toff_t>(-1);
  // Seeking past the end is allowed (TIFF writers pad); the gap is zero-filled on write.
  file->position = static_cast<uint64_t>(target);
  return file->position;
}

int MemoryClose(thandle_t) { return 0; }
toff_t MemorySize(thandle_t handle) { return static_cast<MemoryFile*>(handle)->bytes.size(); }
int MemoryMap(thandle_t, void**, toff_t*) { return 0; }  // no mapping: libtiff falls back to reads
void MemoryUnmap(thandle_t, void*, toff_t) {}

int CollectTiffError(TIFF*, void* user_data, const char* module, const char* format, va_list args) {
  auto* file = static_cast<MemoryFile*>(user_data);
  if (file->error.empty()) {
    char message[512];
    std::vsnprintf(message, sizeof(message), format, args);
    file->error = std::string(module ? module : "libtiff") + ": " + message;
  }
  return 1;  // handled: keep libtiff from printing to stderr
}

constexpr uint32_t kTagForwardMatrix1 = 50964;
constexpr uint16_t kIlluminantD65 = 21;  // EXIF LightSource code

int IgnoreTiffWarning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

struct TiffCloser {
  void operator()(TIFF* tif) const { TIFFClose(tif); }
};

// ---- validation ------------------------------------------------------------

std::invalid_argument Invalid(const std::string& message) {
  return std::invalid_argument("EncodeDng: " + message);
}

void CheckAscii(const std::string& field, const std::string& value) {
  if (value.find('\0') != std::string::npos) {
    throw Invalid("metadata." + field + " contains a NUL character; TIFF ASCII fields cannot hold it");
  }
}

void CheckOptionalPositive(const std::string& field, double value) {
  if (!std::isfinite(value) || value < 0) {
    throw Invalid("metadata." + field + " = " + std::to_string(value) +
                  " must be finite and >= 0 (0 = not recorded)");
  }
}

bool IsCaptureTime(const std::string& text) {
  // "YYYY:MM:DD HH:MM:SS", the EXIF DateTime layout.
  static constexpr char kLayout[] = "dddd:dd:dd dd:dd:dd";
  if (text.size() != sizeof(kLayout) - 1) return false;
  for (size_t i = 0; i < text.size(); ++i) {
    const bool digit = text[i] >= '0' && text[i] <= '9';
    if (kLayout[i] == 'd' ? !digit : text[i] != kLayout[i]) return false;
  }
  return true;
}

std::string MatrixText(const Eigen::Matrix3d& m) {
  std::string text = "[";
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) text += (r || c ? (c ? ", " : "; ") : "") + std::to_string(m(r, c));
  }
  return text + "]";
}

void CheckMatrix(const std::string& field, const std::optional<Eigen::Matrix3d>& matrix, bool may_be_zero) {
  if (!matrix) return;
  if (!matrix->allFinite()) throw Invalid("metadata." + field + " = " + MatrixText(*matrix) + " must be finite");
  if (!may_be_zero && matrix->isZero(0)) {
    throw Invalid("metadata." + field + " is all zeros; a colour matrix must map XYZ to the camera");
  }
}

void CheckColorMetadata(const DngMetadata& metadata) {
  CheckMatrix("camera_from_xyz_d65", metadata.camera_from_xyz_d65, false);
  CheckMatrix("forward_matrix_d50", metadata.forward_matrix_d50, false);
  if (metadata.as_shot_neutral) {
    const Eigen::Vector3d& n = *metadata.as_shot_neutral;
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(n[c]) || n[c] <= 0) {
        throw Invalid("metadata.as_shot_neutral[" + std::to_string(c) + "] = " + std::to_string(n[c]) +
                      " must be finite and > 0 (the DNG AsShotNeutral rule)");
      }
    }
  }
}

void Validate(const RawImage& raw, const DngMetadata& metadata) {
  const ImageU16& mosaic = raw.mosaic;
  if (mosaic.empty()) throw Invalid("the mosaic is empty");
  if (mosaic.channels() != 1) {
    throw Invalid("the mosaic has " + std::to_string(mosaic.channels()) +
                  " channels; a Bayer mosaic has exactly 1");
  }
  if (mosaic.width() < kMinDngSide || mosaic.height() < kMinDngSide ||
      mosaic.width() > kMaxDngSide || mosaic.height() > kMaxDngSide) {
    throw Invalid("the mosaic is " + std::to_string(mosaic.width()) + "x" +
                  std::to_string(mosaic.height()) + "; LibRaw reads only sides in [" +
                  std::to_string(kMinDngSide) + ", " + std::to_string(kMaxDngSide) + "]");
  }
  for (int i = 0; i < 4; ++i) {
    if (raw.black_level[i] >= raw.white_level) {
      throw Invalid("white_level " + std::to_string(raw.white_level) +
                    " must exceed black_level[" + std::to_string(i) + "] = " +
                    std::to_string(raw.black_level[i]));
    }
  }
  for (int y = 0; y < mosaic.height(); ++y) {
    const uint16_t* row = mosaic.row(y);
    for (int x = 0; x < mosaic.width(); ++x) {
      if (row[x] > raw.white_level) {
        throw Invalid("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") = " +
                      std::to_string(row[x]) + " exceeds white_level " +
                      std::to_string(raw.white_level));
      }
    }
  }
  CheckAscii("make", metadata.make);
  CheckAscii("model", metadata.model);
  CheckAscii("serial", metadata.serial);
  CheckAscii("software", metadata.software);
  if (metadata.make.empty() || metadata.model.empty()) {
    throw Invalid("metadata.make and metadata.model must not be empty (LibRaw identifies cameras by them)");
  }
  CheckOptionalPositive("exposure_time_s", metadata.exposure_time_s);
  CheckOptionalPositive("f_number", metadata.f_number);
  CheckOptionalPositive("iso", metadata.iso);
  if (metadata.iso > 65535) {
    throw Invalid("metadata.iso = " + std::to_string(metadata.iso) +
                  " exceeds 65535, the largest EXIF ISOSpeedRatings value");
  }
  if (!metadata.capture_time.empty() && !IsCaptureTime(metadata.capture_time)) {
    throw Invalid("metadata.capture_time '" + metadata.capture_time +
                  "' is not in the form YYYY:MM:DD HH:MM:SS");
  }
  CheckColorMetadata(metadata);
}

void Check(MemoryFile& file, int ok, const char* what) {
  if (!ok) {
    throw std::runtime_error(std::string("EncodeDng: libtiff failed to ") + what +
                             (file.error.empty() ? "" : " (" + file.error + ")"));
  }
}

// ---- writing ---------------------------------------------------------------

// The EXIF IFD comes first so that the image directory, written next, can
// point to it and still precede the pixel data.
uint64_t WriteExifDirectory(TIFF* tif, MemoryFile& file, const DngMetadata& metadata) {
  Check(file, TIFFCreateEXIFDirectory(tif) == 0, "create the EXIF directory");
  uint8_t exif_version[4] = {'0', '2', '3', '0'};
  Check(file, TIFFSetField(tif, EXIFTAG_EXIFVERSION, exif_version), "set ExifVersion");
  if (metadata.exposure_time_s > 0) {
    Check(file, TIFFSetField(tif, EXIFTAG_EXPOSURETIME, metadata.exposure_time_s), "set ExposureTime");
  }
  if (metadata.f_number > 0) {
    Check(file, TIFFSetField(tif, EXIFTAG_FNUMBER, metadata.f_number), "set FNumber");
  }
  if (metadata.iso > 0) {
    uint16_t iso = static_cast<uint16_t>(std::lround(metadata.iso));
    Check(file, TIFFSetField(tif, EXIFTAG_ISOSPEEDRATINGS, 1, &iso), "set ISOSpeedRatings");
  }
  if (!metadata.capture_time.empty()) {
    Check(file, TIFFSetField(tif, EXIFTAG_DATETIMEORIGINAL, metadata.capture_time.c_str()),
          "set DateTimeOriginal");
  }
  uint64_t offset = 0;
  Check(file, TIFFWriteCustomDirectory(tif, &offset), "write the EXIF directory");
  TIFFFreeDirectory(tif);
  TIFFCreateDirectory(tif);
  return offset;
}

// DNG stores a matrix row-major: rows are the output (camera channels for
// ColorMatrix, XYZ for ForwardMatrix), columns the input.
std::array<float, 9> RowMajor(const Eigen::Matrix3d& m) {
  std::array<float, 9> values{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) values[r * 3 + c] = static_cast<float>(m(r, c));
  }
  return values;
}

// libtiff 4.5 does not know ForwardMatrix1 (DNG 1.2); registered per image
// directory because TIFFCreateDirectory drops merged fields.
void RegisterForwardMatrix1(TIFF* tif, MemoryFile& file) {
  static const TIFFFieldInfo kForwardMatrix1[] = {
      {kTagForwardMatrix1, TIFF_VARIABLE, TIFF_VARIABLE, TIFF_SRATIONAL, FIELD_CUSTOM, 1, 1,
       const_cast<char*>("ForwardMatrix1")}};
  Check(file, TIFFMergeFieldInfo(tif, kForwardMatrix1, 1) == 0, "register ForwardMatrix1");
}

void SetColorTags(TIFF* tif, MemoryFile& file, const DngMetadata& metadata) {
  // Without a camera model: a camera with sRGB primaries (XYZ -> linear sRGB
  // under D65), so that LibRaw's colour pipeline has a sane matrix.
  static const Eigen::Matrix3d kSrgbFromXyz =
      (Eigen::Matrix3d() << 3.2406, -1.5372, -0.4986, -0.9689, 1.8758, 0.0415, 0.0557, -0.2040, 1.0570).finished();
  std::array<float, 9> color_matrix = RowMajor(metadata.camera_from_xyz_d65.value_or(kSrgbFromXyz));
  Check(file, TIFFSetField(tif, TIFFTAG_COLORMATRIX1, 9, color_matrix.data()), "set ColorMatrix1");
  Check(file, TIFFSetField(tif, TIFFTAG_CALIBRATIONILLUMINANT1, kIlluminantD65), "set CalibrationIlluminant1");
  const Eigen::Vector3d neutral_value = metadata.as_shot_neutral.value_or(Eigen::Vector3d::Ones());
  float neutral[3];
  for (int c = 0; c < 3; ++c) neutral[c] = static_cast<float>(neutral_value[c]);
  Check(file, TIFFSetField(tif, TIFFTAG_ASSHOTNEUTRAL, 3, neutral), "set AsShotNeutral");
  if (metadata.forward_matrix_d50) {
    RegisterForwardMatrix1(tif, file);
    std::array<float, 9> forward = RowMajor(*metadata.forward_matrix_d50);
    Check(file, TIFFSetField(tif, kTagForwardMatrix1, 9, forward.data()), "set ForwardMatrix1");
  }
}

void SetImageDirectory(TIFF* tif, MemoryFile& file, const RawImage& raw,
                       const DngMetadata& metadata, uint64_t exif_offset) {
  const auto width = static_cast<uint32_t>(raw.width());
  const auto height = static_cast<uint32_t>(raw.height());
  Check(file, TIFFSetField(tif, TIFFTAG_SUBFILETYPE, 0), "set NewSubfileType");
  Check(file, TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, width), "set ImageWidth");
  Check(file, TIFFSetField(tif, TIFFTAG_IMAGELENGTH, height), "set ImageLength");
  Check(file, TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 16), "set BitsPerSample");
  Check(file, TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1), "set SamplesPerPixel");
  Check(file, TIFFSetField(tif, TIFFTAG_COMPRESSION, COMPRESSION_NONE), "set Compression");
  Check(file, TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_CFA), "set PhotometricInterpretation");
  Check(file, TIFFSetField(tif, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG), "set PlanarConfiguration");
  Check(file, TIFFSetField(tif, TIFFTAG_ORIENTATION, ORIENTATION_TOPLEFT), "set Orientation");
  // One strip: LibRaw reads uncompressed DNG data as one run from the first strip offset.
  Check(file, TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, height), "set RowsPerStrip");
  Check(file, TIFFSetField(tif, TIFFTAG_MAKE, metadata.make.c_str()), "set Make");
  Check(file, TIFFSetField(tif, TIFFTAG_MODEL, metadata.model.c_str()), "set Model");
  if (!metadata.software.empty()) {
    Check(file, TIFFSetField(tif, TIFFTAG_SOFTWARE, metadata.software.c_str()), "set Software");
  }
  if (!metadata.capture_time.empty()) {
    Check(file, TIFFSetField(tif, TIFFTAG_DATETIME, metadata.capture_time.c_str()), "set DateTime");
  }

  uint16_t cfa_dim[2] = {2, 2};
  Check(file, TIFFSetField(tif, TIFFTAG_CFAREPEATPATTERNDIM, cfa_dim), "set CFARepeatPatternDim");
  uint8_t cfa[4];
  for (int i = 0; i < 4; ++i) cfa[i] = static_cast<uint8_t>(CfaColorAt(raw.cfa, i & 1, i >> 1));
  Check(file, TIFFSetField(tif, TIFFTAG_CFAPATTERN, 4, cfa), "set CFAPattern");

  uint8_t dng_version[4] = {1, 4, 0, 0};
  uint8_t dng_backward_version[4] = {1, 1, 0, 0};
  Check(file, TIFFSetField(tif, TIFFTAG_DNGVERSION, dng_version), "set DNGVersion");
  Check(file, TIFFSetField(tif, TIFFTAG_DNGBACKWARDVERSION, dng_backward_version),
        "set DNGBackwardVersion");
  const std::string unique_model = metadata.make + " " + metadata.model;
  Check(file, TIFFSetField(tif, TIFFTAG_UNIQUECAMERAMODEL, unique_model.c_str()), "set UniqueCameraModel");
  if (!metadata.serial.empty()) {
    Check(file, TIFFSetField(tif, TIFFTAG_CAMERASERIALNUMBER, metadata.serial.c_str()),
          "set CameraSerialNumber");
  }

  // Black level per 2x2 tile position, in the same row-major order as RawImage.
  uint16_t black_dim[2] = {2, 2};
  Check(file, TIFFSetField(tif, TIFFTAG_BLACKLEVELREPEATDIM, black_dim), "set BlackLevelRepeatDim");
  float black[4];
  for (int i = 0; i < 4; ++i) black[i] = raw.black_level[i];
  Check(file, TIFFSetField(tif, TIFFTAG_BLACKLEVEL, 4, black), "set BlackLevel");
  uint32_t white = raw.white_level;
  Check(file, TIFFSetField(tif, TIFFTAG_WHITELEVEL, 1, &white), "set WhiteLevel");

  SetColorTags(tif, file, metadata);
  Check(file, TIFFSetField(tif, TIFFTAG_EXIFIFD, exif_offset), "set ExifIFD");
}

}  // namespace

std::vector<uint8_t> EncodeDng(const RawImage& raw, const DngMetadata& metadata) {
  Validate(raw, metadata);

  MemoryFile file;
  std::unique_ptr<TIFFOpenOptions, decltype(&TIFFOpenOptionsFree)> options(TIFFOpenOptionsAlloc(),
                                                                           &TIFFOpenOptionsFree);
  TIFFOpenOptionsSetErrorHandlerExtR(options.get(), &CollectTiffError, &file);
  TIFFOpenOptionsSetWarningHandlerExtR(options.get(), &IgnoreTiffWarning, nullptr);
  // "wl": classic little-endian TIFF, as DNG readers expect 32-bit offsets.
  std::unique_ptr<TIFF, TiffCloser> tif(TIFFClientOpenExt(
      "memory.dng", "wl", &file, &MemoryRead, &MemoryWrite, &MemorySeek, &MemoryClose, &MemorySize,
      &MemoryMap, &MemoryUnmap, options.get()));
  Check(file, tif != nullptr, "open an in-memory TIFF");

  const uint64_t exif_offset = WriteExifDirectory(tif.get(), file, metadata);
  SetImageDirectory(tif.get(), file, raw, metadata, exif_offset);
  // Writing the directory now puts it before the pixel data (camera layout);
  // the final TIFFWriteDirectory rewrites it in place with the strip offset.
  Check(file, TIFFCheckpointDirectory(tif.get()), "write the image directory");

  std::vector<uint16_t> row(static_cast<size_t>(raw.width()));
  for (int y = 0; y < raw.height(); ++y) {
    // libtiff may byte-swap the buffer it is given, so hand it a copy.
    std::copy_n(raw.mosaic.row(y), raw.width(), row.data());
    Check(file, TIFFWriteScanline(tif.get(), row.data(), static_cast<uint32_t>(y), 0) == 1,
          "write a pixel row");
  }
  Check(file, TIFFWriteDirectory(tif.get()), "finish the image directory");
  tif.reset();
  if (!file.error.empty()) throw std::runtime_error("EncodeDng: libtiff reported: " + file.error);
  return std::move(file.bytes);
}

void WriteDng(const std::filesystem::path& path, const RawImage& raw, const DngMetadata& metadata) {
  std::vector<uint8_t> bytes;
  try {
    bytes = EncodeDng(raw, metadata);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path.string() + ": " + e.what());
  }
  WriteFileAtomic(path, bytes, OverwritePolicy::kRefuse);
}

}  // namespace scanbench
