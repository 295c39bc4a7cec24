// libFuzzer target for the LED board's protocol (built with clang by
// tests/firmware/CMakeLists.txt). Run longer than ctest does with e.g.
//   build/tests/firmware/led_protocol_fuzz -dict=tests/firmware/led_protocol.dict -max_total_time=600
#include <cstdio>
#include <cstdlib>

#include "tests/firmware/led_protocol_invariants.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string problem = scanbench::led_protocol_test::CheckProtocolInvariants(data, size);
  if (!problem.empty()) {
    std::fprintf(stderr, "LED protocol invariant broken: %s\n", problem.c_str());
    std::abort();
  }
  return 0;
}
