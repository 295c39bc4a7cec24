// libFuzzer harness: a rig description (rig.json, `scanbench bench init`'s
// output edited by hand) through RigDescriptionFromJson (app/session/rig_json.h),
// and when it parses, written back and parsed again.
#include <cstdint>
#include <optional>

#include "app/session/rig_json.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::optional<RigDescription> parsed;
  fuzz::ExpectOnlyDocumentedErrors([&] { parsed = RigDescriptionFromJson(text, "rig.json"); });
  if (!parsed) return 0;
  // What the writer makes of it must load again. Not compared byte for byte:
  // cam_from_table's quaternion goes through a rotation matrix, so a rewrite
  // may move its last digit (docs/robustness.md, "Fuzzing").
  fuzz::RequireNoError([&] { RigDescriptionFromJson(RigDescriptionToJson(*parsed), "rig.json (written back)"); },
                       "reading back what the writer wrote");
  return 0;
}
