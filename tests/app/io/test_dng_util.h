// Test-only: unusual DNG files written directly with libtiff, and small
// helpers shared by the app/io tests.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/util/temporary_folder.h"

namespace scanbench::testing {

struct TestDngOptions {
  int width = 40;
  int height = 30;
  int samples_per_pixel = 1;
  uint16_t photometric = 32803;  // CFA; 34892 = LinearRaw
  uint16_t cfa_rows = 2;
  uint16_t cfa_cols = 2;
  std::vector<uint8_t> cfa_pattern = {0, 1, 1, 2};  // RGGB; empty = no CFA tags
  uint16_t black_rows = 1;
  uint16_t black_cols = 1;
  std::vector<float> black_levels = {64};
  uint32_t white_level = 4095;
  // Colour tags, row-major, written only when not empty (illuminants: EXIF
  // LightSource codes, written with their matrix).
  std::vector<float> color_matrix1, color_matrix2;
  uint16_t illuminant1 = 0, illuminant2 = 0;
  std::vector<float> camera_calibration2;  // CameraCalibration2, 3x3
  std::vector<float> as_shot_neutral;
};

// A DNG 1.4 with the given layout and pixel values (x + y) % white_level.
std::vector<uint8_t> MakeTestDng(const TestDngOptions& options);

// Little-endian TIFF IFD0 access for patching test files.
uint32_t ReadIfd0Value(const std::vector<uint8_t>& bytes, uint16_t tag);
void PatchIfd0Value(std::vector<uint8_t>& bytes, uint16_t tag, uint32_t value);

using TempDir = TemporaryFolder;

}  // namespace scanbench::testing
