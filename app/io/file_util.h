// Safe file writes and checksums. Nothing is lost: every write goes to a
// temporary name in the same folder and is renamed into place.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace scanbench {

enum class OverwritePolicy {
  kRefuse,   // an existing file is an error (RAW frames, results)
  kReplace,  // atomically replace (manifests)
};

// Writes bytes to `path` via `path.tmp-<random>` + fsync + rename.
// Throws std::runtime_error naming the path and the problem.
void WriteFileAtomic(const std::filesystem::path& path, std::span<const uint8_t> bytes,
                     OverwritePolicy policy);
void WriteFileAtomic(const std::filesystem::path& path, std::string_view text,
                     OverwritePolicy policy);

// A temporary sibling name for `path` that does not exist yet, for writers
// (libtiff, OpenImageIO) that must be handed a file name. Pair with
// CommitTemporaryFile.
std::filesystem::path TemporarySiblingPath(const std::filesystem::path& path);
// Renames `temporary` onto `path` under the policy; removes `temporary` on failure.
void CommitTemporaryFile(const std::filesystem::path& temporary, const std::filesystem::path& path,
                         OverwritePolicy policy);

// Whole file into memory; throws naming the path if it cannot be read.
std::vector<uint8_t> ReadFileBytes(const std::filesystem::path& path);

// Lower-case hex SHA-256.
std::string Sha256Hex(std::span<const uint8_t> bytes);
std::string Sha256HexOfFile(const std::filesystem::path& path);

}  // namespace scanbench
