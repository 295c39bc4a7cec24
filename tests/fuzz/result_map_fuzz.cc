// libFuzzer harness: a result folder's map as the export reads it back
// (app/io/result_maps.h): an EXR (normal / albedo / confidence / specular)
// or a PNG (solved_mask.png), named by its first bytes. The session's size
// is taken from the file's own header, so the readers get past the size
// check to the channel and value checks.
#include <cstdint>

#include "app/io/image_io.h"
#include "app/io/result_maps.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const bool png = bytes.substr(0, 4) == "\x89PNG";
  const std::filesystem::path path = fuzz::ProcessTempFolder() / (png ? "solved_mask.png" : "confidence.exr");
  fuzz::WriteBytes(path, bytes);
  fuzz::ExpectOnlyDocumentedErrors([&] {
    const ImageFileInfo info = ReadImageFileInfo(path);
    if (png) {
      ReadBinaryMask(path, info.width, info.height);
      return;
    }
    fuzz::ExpectOnlyDocumentedErrors([&] { ReadResultMap(path, 3, info.width, info.height); });
    fuzz::ExpectOnlyDocumentedErrors(
        [&] { ReadResultMap(path, 3, info.width, info.height, ConfidenceChannelNames()); });
    fuzz::ExpectOnlyDocumentedErrors([&] { ReadSpecularAlpha(path, info.width, info.height); });
    ReadGroundTruthMap(path, info.channels, info.width, info.height);
  });
  return 0;
}
