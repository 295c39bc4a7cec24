// libFuzzer harness: session.json as a user edits it or another tool writes
// it, through the validating parser LoadSession uses (app/session/session.h),
// and when it parses, written back and parsed again (a manifest the loader
// accepts must survive its own writer).
#include <cstdint>
#include <optional>

#include "app/session/session.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::optional<Session> parsed;
  fuzz::ExpectOnlyDocumentedErrors([&] { parsed = SessionFromJson(text, "session.json"); });
  if (!parsed) return 0;
  // What the writer makes of it must load again. Not compared byte for byte:
  // cam_from_table's quaternion goes through a rotation matrix, so a rewrite
  // may move its last digit (docs/robustness.md, "Fuzzing").
  fuzz::RequireNoError([&] { SessionFromJson(SessionToJson(*parsed), "session.json (written back)"); },
                       "reading back what the writer wrote");
  return 0;
}
