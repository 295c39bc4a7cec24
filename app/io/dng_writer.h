// Writes a Bayer mosaic as an uncompressed CFA DNG, so that simulated frames
// are read back through LibRaw exactly like a camera's RAW files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "calibration/raw_image.h"

namespace scanbench {

struct DngMetadata {
  std::string make = "scanbench";
  std::string model = "Simulated D5100";
  std::string serial;    // CameraSerialNumber; empty = not written
  std::string software;  // Software; empty = not written
  double exposure_time_s = 0;  // 0 = not written
  double iso = 0;              // 0 = not written; at most 65535 (EXIF SHORT)
  double f_number = 0;         // 0 = not written
  std::string capture_time;    // "YYYY:MM:DD HH:MM:SS" local time; empty = not written
};

// LibRaw refuses smaller images and stores sizes in 16 bits.
inline constexpr int kMinDngSide = 22;
inline constexpr int kMaxDngSide = 64000;

// Encodes `raw` as a DNG 1.4 file in memory: one uncompressed 16-bit CFA
// strip, the 2x2 black levels (BlackLevelRepeatDim 2x2), WhiteLevel and the
// metadata (ExposureTime, FNumber, ISO and DateTimeOriginal in the EXIF IFD).
// The image directory precedes the pixel data, as in camera files, so a
// truncated file keeps its header and the truncation is detectable.
// Throws std::invalid_argument naming the field, its value and the rule for
// an empty or multi-channel mosaic, a side outside [22, 64000], a white level
// not above every black level, a pixel above the white level, or bad metadata.
std::vector<uint8_t> EncodeDng(const RawImage& raw, const DngMetadata& metadata = {});

// EncodeDng + atomic write. RAW frames are never overwritten: an existing
// `path` is an error (std::runtime_error naming it) and no temporary is left.
void WriteDng(const std::filesystem::path& path, const RawImage& raw,
              const DngMetadata& metadata = {});

}  // namespace scanbench
