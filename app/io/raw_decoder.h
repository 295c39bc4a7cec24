// Reads camera RAW files (Nikon NEF, the rig's DNG, anything LibRaw reads)
// into a RawImage: the visible Bayer mosaic exactly as stored, its CFA
// layout and its black and white levels. No processing of any kind.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>

#include <Eigen/Core>

#include "calibration/raw_image.h"

namespace scanbench {

struct DecodedRaw {
  RawImage image;
  std::string make;
  std::string model;
  std::string serial;        // empty if the file records none
  std::string software;
  std::string capture_time;  // "YYYY:MM:DD HH:MM:SS" in local time; empty if unknown
  double exposure_time_s = 0;  // 0 if unknown
  double iso = 0;
  double f_number = 0;
  std::string lens;          // empty if the file records none
  // How the camera was held (LibRaw's sizes.flip): 0 as stored, 3 = 180 deg,
  // 5 = 90 deg counter-clockwise, 6 = 90 deg clockwise. The mosaic itself is
  // never rotated.
  int orientation = 0;

  // Colour data (LibRaw's, rows and vector entries in the order camera R, G, B;
  // the second green, LibRaw's fourth row, is dropped as it equals the first).
  // camera_from_xyz: camera native R, G, B (rows) from CIE XYZ (columns, Y of
  // the white = 1), under the illuminant `camera_from_xyz_illuminant` (EXIF
  // LightSource code: 21 = D65, 17 = A, 0 = unknown). For a DNG it is
  // AnalogBalance * CameraCalibration * ColorMatrix of the calibration
  // illuminant that is D65 (else another daylight one, else the only one);
  // note LibRaw 0.20's own cam_xyz is only its built-in table and stays empty
  // for DNGs. For other formats it is LibRaw's built-in table for the model
  // (Adobe's D65 matrices), nullopt when LibRaw has none.
  std::optional<Eigen::Matrix3d> camera_from_xyz;
  int camera_from_xyz_illuminant = 0;
  // DNG ForwardMatrix for the same illuminant: XYZ under D50 (rows) from
  // white-balanced camera R, G, B; nullopt when the file has none.
  std::optional<Eigen::Matrix3d> forward_matrix_d50;
  // The camera-native R, G, B a neutral read in this shot, green = 1: the
  // inverse of LibRaw's cam_mul (as-shot white balance multipliers), i.e. the
  // DNG AsShotNeutral; (1, 1, 1) when the file records none.
  Eigen::Vector3d as_shot_neutral = Eigen::Vector3d::Ones();
  // LibRaw's pre_mul, green = 1: daylight (D65) white balance multipliers
  // derived from the colour matrix; (1, 1, 1) when unknown.
  Eigen::Vector3d daylight_multipliers = Eigen::Vector3d::Ones();
};

// Decodes a RAW file held in memory. `name_for_errors` (usually the path)
// starts every error message. Throws std::runtime_error when:
//  - LibRaw does not recognise the bytes (garbage, JPEG, empty file);
//  - the file is truncated (checked against the TIFF directories, LibRaw's
//    data offset and size, and the size an uncompressed strip must have,
//    because LibRaw silently pads a short final row);
//  - there is no pixel data;
//  - the image is not a 2x2 Bayer mosaic (LinearRaw/3-channel DNG,
//    X-Trans, 4-colour or other CFAs, floating-point data);
//  - the black levels do not repeat every 2x2 tile, or white <= black.
// The mosaic is LibRaw's visible area (its margins removed); the black
// level is black + per-channel cblack + the cblack pattern, per 2x2 tile
// position of that visible area; the white level is LibRaw's color.maximum
// (the DNG WhiteLevel, or the camera's saturation for other formats).
DecodedRaw DecodeRawWithInfo(std::span<const uint8_t> bytes, const std::string& name_for_errors);
RawImage DecodeRaw(std::span<const uint8_t> bytes, const std::string& name_for_errors);

// Reads and decodes `path`; errors start with the path.
DecodedRaw DecodeRawFileWithInfo(const std::filesystem::path& path);
RawImage DecodeRawFile(const std::filesystem::path& path);

// Throws std::runtime_error such as
// "frames/led_03.dng: image is 1000x800 but the session records 1232x816".
void CheckRawSize(const RawImage& image, int width, int height, const std::string& name);

}  // namespace scanbench
