#include "app/io/observation_set_io.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

constexpr char kMagic[] = "SCANBENCH-OBSERVATIONS 1";

struct ArrayView {
  const char* name;
  const char* dtype;
  std::vector<int64_t> shape;
  const void* data;
  size_t bytes;
};

std::vector<ArrayView> ArraysOf(const ObservationSets& sets) {
  const int64_t n = sets.num_sets(), m = static_cast<int64_t>(sets.value.size());
  return {
      {"offset", "<i8", {n + 1}, sets.offset.data(), sets.offset.size() * sizeof(int64_t)},
      {"normal", "<f4", {n, 3}, sets.normal.data(), sets.normal.size() * sizeof(Eigen::Vector3f)},
      {"albedo", "<f4", {n}, sets.albedo.data(), sets.albedo.size() * sizeof(float)},
      {"light_set_kind", "<i4", {n}, sets.light_set_kind.data(), sets.light_set_kind.size() * sizeof(int32_t)},
      {"material_flags", "<i4", {n}, sets.material_flags.data(), sets.material_flags.size() * sizeof(int32_t)},
      {"light_dir", "<f4", {m, 3}, sets.light_dir.data(), sets.light_dir.size() * sizeof(Eigen::Vector3f)},
      {"value", "<f4", {m}, sets.value.data(), sets.value.size() * sizeof(float)},
  };
}

[[noreturn]] void Fail(const fs::path& path, const std::string& problem) {
  throw std::runtime_error(path.string() + ": " + problem);
}

}  // namespace

void WriteObservationSets(const fs::path& path, const ObservationSets& sets, uint64_t seed) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "Vector3f must be packed");
  nlohmann::json header = {{"num_sets", sets.num_sets()},
                           {"num_samples", static_cast<int64_t>(sets.value.size())},
                           {"seed", seed}};
  size_t offset = 0;
  for (const ArrayView& array : ArraysOf(sets)) {
    header["arrays"].push_back({{"name", array.name}, {"dtype", array.dtype}, {"shape", array.shape}, {"offset", offset}});
    offset += array.bytes;
  }
  std::string bytes = std::string(kMagic) + "\n" + header.dump() + "\n";
  size_t at = bytes.size();
  bytes.resize(at + offset);
  for (const ArrayView& array : ArraysOf(sets)) {
    if (array.bytes > 0) std::memcpy(bytes.data() + at, array.data, array.bytes);
    at += array.bytes;
  }
  WriteFileAtomic(path, std::string_view(bytes), OverwritePolicy::kReplace);
}

ObservationSets ReadObservationSets(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot be opened");
  std::string magic, header_text;
  std::getline(in, magic);
  if (magic != kMagic) Fail(path, "is not a scanbench observation file (first line '" + magic.substr(0, 40) + "')");
  std::getline(in, header_text);
  nlohmann::json header;
  try {
    header = nlohmann::json::parse(header_text);
  } catch (const std::exception& e) {
    Fail(path, std::string("header is not JSON: ") + e.what());
  }
  const std::streamoff body = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff file_size = in.tellg();
  ObservationSets sets;
  const int64_t n = header.value("num_sets", int64_t{-1}), m = header.value("num_samples", int64_t{-1});
  if (n < 0 || m < 0) Fail(path, "header lacks num_sets or num_samples");
  sets.offset.resize(n + 1);
  sets.normal.resize(n);
  sets.albedo.resize(n);
  sets.light_set_kind.resize(n);
  sets.material_flags.resize(n);
  sets.light_dir.resize(m);
  sets.value.resize(m);
  for (const ArrayView& array : ArraysOf(sets)) {
    const auto found = std::find_if(header["arrays"].begin(), header["arrays"].end(),
                                    [&](const nlohmann::json& a) { return a.value("name", "") == array.name; });
    if (found == header["arrays"].end()) Fail(path, std::string("has no array '") + array.name + "'");
    const int64_t at = found->value("offset", int64_t{-1});
    if (at < 0 || body + at + static_cast<std::streamoff>(array.bytes) > file_size) {
      Fail(path, std::string("is truncated: array '") + array.name + "' runs past the end of the file");
    }
    in.seekg(body + at);
    in.read(static_cast<char*>(const_cast<void*>(array.data)), static_cast<std::streamsize>(array.bytes));
    if (!in) Fail(path, std::string("read error in array '") + array.name + "'");
  }
  for (int64_t s = 0; s < n; ++s) {
    if (sets.offset[s + 1] < sets.offset[s]) Fail(path, "offsets out of order at set " + std::to_string(s));
  }
  if (sets.offset.front() != 0 || sets.offset.back() != m) Fail(path, "offsets do not span the samples");
  return sets;
}

}  // namespace scanbench
