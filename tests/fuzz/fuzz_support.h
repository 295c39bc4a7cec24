// What every libFuzzer harness of tests/fuzz shares: the rule for which
// exceptions are fine, a per-process temporary folder for loaders that take
// a path, and the split of one input into several files.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <typeinfo>
#include <vector>

namespace scanbench::fuzz {

// The project documents its input errors as std::runtime_error (SessionError,
// DeviceError and the io readers' errors derive from it) and
// std::invalid_argument (FieldValueError, inputs that do not fit together),
// each with a message naming the file or field. Those are the loader doing
// its job. Anything else escaping -- nlohmann::json's own exceptions,
// std::out_of_range from a substr, std::bad_alloc, an empty message -- is a
// finding: abort, so that libFuzzer records the input.
template <typename Load>
void ExpectOnlyDocumentedErrors(Load&& load) {
  // SCANBENCH_FUZZ_PRINT_ERRORS=1 prints them (why a seed is refused).
  static const bool print_errors = std::getenv("SCANBENCH_FUZZ_PRINT_ERRORS") != nullptr;
  const auto empty_message = [](const std::exception& e) {
    if (e.what() == nullptr || e.what()[0] == '\0') {
      std::fprintf(stderr, "fuzz: %s with an empty message\n", typeid(e).name());
      std::abort();
    }
    if (print_errors) std::fprintf(stderr, "fuzz: documented error: %s\n", e.what());
  };
  try {
    load();
  } catch (const std::runtime_error& e) {
    empty_message(e);
  } catch (const std::invalid_argument& e) {
    empty_message(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: undocumented exception %s: %s\n", typeid(e).name(), e.what());
    std::abort();
  } catch (...) {
    std::fprintf(stderr, "fuzz: a non-std exception escaped\n");
    std::abort();
  }
}

// An invariant of the harness (e.g. what the writer wrote loads again): here
// even a documented error is a finding.
template <typename Step>
void RequireNoError(Step&& step, const char* what) {
  try {
    step();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: %s failed: %s: %s\n", what, typeid(e).name(), e.what());
    std::abort();
  }
}

// One folder per process (libFuzzer's -jobs / -fork run several), made on
// first use under $TMPDIR and removed when the process exits normally.
inline const std::filesystem::path& ProcessTempFolder() {
  // Never destroyed: the exit handler below runs after static destructors.
  static const std::filesystem::path* const folder = [] {
    auto* path = new std::filesystem::path(std::filesystem::temp_directory_path() /
                                           ("scanbench-fuzz-" + std::to_string(::getpid())));
    std::filesystem::remove_all(*path);
    std::filesystem::create_directories(*path);
    return path;
  }();
  static const bool cleaned_at_exit = [] {
    return std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(ProcessTempFolder(), ignored);
    }) == 0;
  }();
  (void)cleaned_at_exit;
  return *folder;
}

// An empty folder for one input: `name` under the process folder, emptied.
inline std::filesystem::path FreshFolder(const std::string& name) {
  const std::filesystem::path folder = ProcessTempFolder() / name;
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  return folder;
}

inline void WriteBytes(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

// Several files in one input: the sections between separator lines
// "#SBFUZZ#\n" (in the dictionaries), in the order the harness names them.
inline constexpr std::string_view kSectionSeparator = "#SBFUZZ#\n";

inline std::vector<std::string_view> SplitSections(const uint8_t* data, size_t size) {
  std::vector<std::string_view> sections;
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  for (;;) {
    const size_t at = rest.find(kSectionSeparator);
    sections.push_back(rest.substr(0, at));
    if (at == std::string_view::npos) break;
    rest.remove_prefix(at + kSectionSeparator.size());
  }
  return sections;
}

}  // namespace scanbench::fuzz
