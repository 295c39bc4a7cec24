// Writes a Bayer mosaic as an uncompressed CFA DNG, so that simulated frames
// are read back through LibRaw exactly like a camera's RAW files.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

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
  // ColorMatrix1 with CalibrationIlluminant1 = 21 (D65): camera native R, G, B
  // (rows) from CIE XYZ (columns, Y of the white = 1), as a camera's DNG
  // carries it. Finite, not all zero. Absent = a camera with sRGB primaries
  // (XYZ -> linear sRGB), the writer's behaviour before camera models existed.
  std::optional<Eigen::Matrix3d> camera_from_xyz_d65;
  // AsShotNeutral: the camera-native R, G, B a neutral surface gave in this
  // shot (usually green = 1). Finite and > 0. Absent = (1, 1, 1).
  std::optional<Eigen::Vector3d> as_shot_neutral;
  // ForwardMatrix1 (for illuminant 1, D65): XYZ under D50 (rows) from
  // white-balanced camera R, G, B (columns). Finite. Absent = not written.
  std::optional<Eigen::Matrix3d> forward_matrix_d50;
};

// LibRaw refuses smaller images and stores sizes in 16 bits.
inline constexpr int kMinDngSide = 22;
inline constexpr int kMaxDngSide = 64000;

// Encodes `raw` as a DNG 1.4 file in memory: one uncompressed 16-bit CFA
// strip, the 2x2 black levels (BlackLevelRepeatDim 2x2), WhiteLevel and the
// metadata (ExposureTime, FNumber, ISO and DateTimeOriginal in the EXIF IFD),
// ColorMatrix1 / CalibrationIlluminant1 (D65), AsShotNeutral and, if given,
// ForwardMatrix1; matrices are stored as SRATIONALs (about 1e-7 relative).
// The image directory precedes the pixel data, as in camera files, so a
// truncated file keeps its header and the truncation is detectable.
// Throws std::invalid_argument naming the field, its value and the rule for
// an empty or multi-channel mosaic, a side outside [22, 64000], a white level
// not above every black level, a pixel above the white level, or bad metadata
// (including a non-finite or all-zero colour matrix, a neutral <= 0).
std::vector<uint8_t> EncodeDng(const RawImage& raw, const DngMetadata& metadata = {});

// EncodeDng + atomic write. RAW frames are never overwritten: an existing
// `path` is an error (std::runtime_error naming it) and no temporary is left.
void WriteDng(const std::filesystem::path& path, const RawImage& raw,
              const DngMetadata& metadata = {});

}  // namespace scanbench
