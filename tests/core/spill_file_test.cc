// The spill file: records out of memory in an unlinked temporary file.
#include "core/spill_file.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

using testing::TemporaryFolder;

// The spill file has no name: the folder stays empty.
TEST(SpillFileTest, SpillFileLeavesNothingInItsFolder) {
  TemporaryFolder folder;
  {
    SpillFile spill(folder.path());
    const std::vector<uint32_t> records = {1, 2, 3, 4, 5, 6};
    for (int i = 0; i < 100'000; ++i) spill.Append(records.data(), records.size() * sizeof(uint32_t));
    EXPECT_TRUE(std::filesystem::is_empty(folder.path()));
    size_t seen = 0;
    uint64_t sum = 0;
    spill.ForEachRecord(3 * sizeof(uint32_t), [&](const uint8_t* bytes, size_t count) {
      for (size_t i = 0; i < count; ++i) {
        uint32_t record[3];
        std::memcpy(record, bytes + i * sizeof(record), sizeof(record));
        sum += record[0] + record[1] + record[2];
      }
      seen += count;
    });
    EXPECT_EQ(seen, 200'000u);
    EXPECT_EQ(sum, 100'000u * 21);
    EXPECT_THROW(spill.ForEachRecord(7, [](const uint8_t*, size_t) {}), std::invalid_argument);
  }
  EXPECT_TRUE(std::filesystem::is_empty(folder.path()));
}

// Appends smaller and larger than the write buffer (1 MiB), interleaved,
// come back in order: a large one is written from the caller's memory once
// the buffered bytes before it are written.
TEST(SpillFileTest, SpillFileKeepsTheOrderOfSmallAndLargeAppends) {
  std::mt19937 random(11);
  std::vector<uint8_t> expected;
  SpillFile spill;
  for (const size_t size : {size_t{5}, size_t{3} << 20, size_t{1}, size_t{1} << 20, (size_t{1} << 20) - 1,
                            size_t{2} << 20, size_t{7}}) {
    std::vector<uint8_t> bytes(size);
    for (uint8_t& byte : bytes) byte = static_cast<uint8_t>(random());
    spill.Append(bytes.data(), bytes.size());
    expected.insert(expected.end(), bytes.begin(), bytes.end());
  }
  ASSERT_EQ(spill.size(), expected.size());
  std::vector<uint8_t> actual(expected.size());
  spill.ReadAt(0, actual.data(), actual.size());
  EXPECT_TRUE(actual == expected);
  std::vector<uint8_t> middle(100);
  spill.ReadAt(5 + (size_t{3} << 20) - 50, middle.data(), middle.size());
  EXPECT_TRUE(std::equal(middle.begin(), middle.end(), expected.begin() + 5 + (size_t{3} << 20) - 50));
}

}  // namespace
}  // namespace scanbench
