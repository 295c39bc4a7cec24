// libFuzzer harness: a RAW / DNG file as a card reader or a camera hands it
// in, through the project's decoder (app/io/raw_decoder.h): the in-memory
// decode the capture path uses, and the file decode of import and solve.
#include <cstdint>

#include "app/io/raw_decoder.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  const std::span<const uint8_t> bytes(data, size);
  fuzz::ExpectOnlyDocumentedErrors([&] {
    const DecodedRaw decoded = DecodeRawWithInfo(bytes, "frames/led_00.dng");
    CheckRawSize(decoded.image, decoded.image.width(), decoded.image.height(), "frames/led_00.dng");
  });
  // The file path (import, solve) reads the bytes back and checks the size
  // against the file's; a second decoder run on the same bytes.
  const std::filesystem::path path = fuzz::ProcessTempFolder() / "frame.dng";
  fuzz::WriteBytes(path, std::string_view(reinterpret_cast<const char*>(data), size));
  fuzz::ExpectOnlyDocumentedErrors([&] { DecodeRawFileWithInfo(path); });
  return 0;
}
