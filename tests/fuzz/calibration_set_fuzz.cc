// libFuzzer harness: a calibration set folder (app/session/calibration_set.h)
// through LoadCalibrationSet. The input holds its files in sections
// (fuzz_support.h): calibration.json, then LED 0's direction and intensity
// field EXRs. Checksums are not verified, so that the fuzzer's field files
// reach the EXR reader instead of stopping at the SHA-256 comparison.
#include <cstdint>

#include "app/session/calibration_set.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  static const char* const kFiles[] = {"calibration.json", "lights/led_00_direction.exr",
                                       "lights/led_00_intensity.exr"};
  const std::filesystem::path folder = fuzz::FreshFolder("calibration_set");
  std::filesystem::create_directories(folder / "lights");
  const auto sections = fuzz::SplitSections(data, size);
  for (size_t i = 0; i < sections.size() && i < std::size(kFiles); ++i) {
    if (i == 0 || !sections[i].empty()) fuzz::WriteBytes(folder / kFiles[i], sections[i]);
  }
  fuzz::ExpectOnlyDocumentedErrors([&] {
    CalibrationLoadOptions options;
    options.verify_checksums = false;
    CalibrationSet set = LoadCalibrationSet(folder, options);
    CheckCalibrationSet(set, "calibration.json");
  });
  return 0;
}
