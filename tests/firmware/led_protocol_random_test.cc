// The fuzz target's invariants on a fixed set of pseudo-random inputs, so
// that every ctest run checks them deterministically (the libFuzzer target
// explores further when clang is available).
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "tests/firmware/led_protocol_invariants.h"

namespace scanbench::led_protocol_test {
namespace {

// Pieces that make the parser's branches likely; raw bytes cover the rest.
const std::vector<std::string> kTokens = {
    "ON ", "OFF", "STATUS", "VERSION", "WATCHDOG ", "on", "0", "9", "10", "100", "3600001", "99999999999",
    " ", "\t", "\r", "\n", "\r\n", "-", "x", std::string(40, 'A'), std::string(1, '\0'), "\xFF",
};

std::string RandomInput(std::mt19937& random) {
  std::string input;
  const int pieces = std::uniform_int_distribution<int>(0, 40)(random);
  for (int i = 0; i < pieces; ++i) {
    if (std::uniform_int_distribution<int>(0, 3)(random) == 0) {
      input += static_cast<char>(std::uniform_int_distribution<int>(0, 255)(random));
    } else {
      input += kTokens[std::uniform_int_distribution<size_t>(0, kTokens.size() - 1)(random)];
    }
  }
  return input;
}

TEST(LedProtocolInvariants, HoldForKnownEdgeCases) {
  for (const std::string& input :
       {std::string(), std::string("\n"), std::string(5000, 'Z'), std::string("ON 3"), std::string("ON 3\r\nOFF\n\r"),
        std::string(300, '\0'), std::string("WATCHDOG 100\nON 1\n") + std::string(500, ' ')}) {
    const auto* data = reinterpret_cast<const uint8_t*>(input.data());
    EXPECT_EQ(CheckProtocolInvariants(data, input.size()), "") << input.substr(0, 40);
  }
}

TEST(LedProtocolInvariants, HoldForThousandsOfRandomStreams) {
  std::mt19937 random(20240521);
  for (int i = 0; i < 20000; ++i) {
    const std::string input = RandomInput(random);
    const auto* data = reinterpret_cast<const uint8_t*>(input.data());
    const std::string problem = CheckProtocolInvariants(data, input.size());
    ASSERT_EQ(problem, "") << "input #" << i << " (" << input.size() << " bytes)";
  }
}

}  // namespace
}  // namespace scanbench::led_protocol_test
