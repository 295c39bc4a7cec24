// The learned solver's training observation file (app/io/observation_set_io.h).
#include "app/io/observation_set_io.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

using testing::TemporaryFolder;

ObservationSets TwoSets() {
  ObservationSets sets;
  sets.normal = {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(0.6f, 0, 0.8f)};
  sets.albedo = {0.5f, 0.25f};
  sets.light_set_kind = {0, 3};
  sets.material_flags = {0, 9};
  for (int k = 0; k < 7; ++k) {
    sets.light_dir.push_back(Eigen::Vector3f(0.1f * k, 0, 1).normalized());
    sets.value.push_back(0.1f * k);
  }
  sets.offset = {0, 3, 7};
  return sets;
}

TEST(ObservationSetIoTest, RoundTrip) {
  TemporaryFolder folder;
  const ObservationSets sets = TwoSets();
  WriteObservationSets(folder / "sets.obs", sets, 42);
  const ObservationSets read = ReadObservationSets(folder / "sets.obs");
  EXPECT_EQ(read.offset, sets.offset);
  EXPECT_EQ(read.value, sets.value);
  EXPECT_EQ(read.albedo, sets.albedo);
  EXPECT_EQ(read.light_set_kind, sets.light_set_kind);
  EXPECT_EQ(read.material_flags, sets.material_flags);
  ASSERT_EQ(read.num_sets(), 2);
  EXPECT_EQ(read.normal[1], sets.normal[1]);
  EXPECT_EQ(read.light_dir[6], sets.light_dir[6]);
}

TEST(ObservationSetIoTest, BadFilesNameThemselvesAndTheProblem) {
  TemporaryFolder folder;
  WriteObservationSets(folder / "sets.obs", TwoSets(), 1);
  // Truncated: the last array runs past the end.
  std::string bytes;
  {
    std::ifstream in(folder / "sets.obs", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  {
    std::ofstream out(folder / "cut.obs", std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() - 8));
  }
  try {
    ReadObservationSets(folder / "cut.obs");
    FAIL() << "a truncated file was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cut.obs: is truncated: array 'value'"), std::string::npos) << e.what();
  }
  {
    std::ofstream out(folder / "other.obs");
    out << "P6\n1 1 255\n";
  }
  try {
    ReadObservationSets(folder / "other.obs");
    FAIL() << "a foreign file was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("other.obs: is not a scanbench observation file"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace scanbench
