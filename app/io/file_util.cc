#include "app/io/file_util.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>
#include <stdexcept>

#include <openssl/evp.h>

namespace scanbench {
namespace fs = std::filesystem;

namespace {

std::runtime_error PathError(const fs::path& path, const std::string& problem) {
  return std::runtime_error(path.string() + ": " + problem);
}

void FsyncPath(const fs::path& path, int flags) {
  const int fd = ::open(path.c_str(), flags);
  if (fd < 0) return;  // best effort: some file systems refuse to open folders
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

fs::path TemporarySiblingPath(const fs::path& path) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  for (int attempt = 0; attempt < 100; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof(suffix), ".tmp-%08llx",
                  static_cast<unsigned long long>(rng() & 0xffffffffULL));
    fs::path candidate = path;
    candidate += suffix;
    if (!fs::exists(candidate)) return candidate;
  }
  throw PathError(path, "could not find a free temporary name beside it");
}

void CommitTemporaryFile(const fs::path& temporary, const fs::path& path, OverwritePolicy policy) {
  FsyncPath(temporary, O_RDONLY);
  if (policy == OverwritePolicy::kRefuse) {
    // link() fails if the target exists, so an existing file is never replaced
    // even when two writers race.
    if (::link(temporary.c_str(), path.c_str()) != 0) {
      const int err = errno;
      std::error_code ignored;
      fs::remove(temporary, ignored);
      if (err == EEXIST) throw PathError(path, "already exists and is never overwritten");
      throw PathError(path, std::string("cannot be created: ") + std::strerror(err));
    }
    std::error_code ignored;
    fs::remove(temporary, ignored);
  } else {
    std::error_code ec;
    fs::rename(temporary, path, ec);
    if (ec) {
      fs::remove(temporary, ec);
      throw PathError(path, "cannot be replaced: " + ec.message());
    }
  }
  FsyncPath(path.has_parent_path() ? path.parent_path() : fs::path("."), O_RDONLY | O_DIRECTORY);
}

void WriteFileAtomic(const fs::path& path, std::span<const uint8_t> bytes, OverwritePolicy policy) {
  if (policy == OverwritePolicy::kRefuse && fs::exists(path)) {
    throw PathError(path, "already exists and is never overwritten");
  }
  const fs::path temporary = TemporarySiblingPath(path);
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw PathError(temporary, "cannot be opened for writing");
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      out.close();
      std::error_code ignored;
      fs::remove(temporary, ignored);
      throw PathError(path, "write failed (disk full or removed?)");
    }
  }
  CommitTemporaryFile(temporary, path, policy);
}

void WriteFileAtomic(const fs::path& path, std::string_view text, OverwritePolicy policy) {
  WriteFileAtomic(path, std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()),
                  policy);
}

std::vector<uint8_t> ReadFileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw PathError(path, fs::exists(path) ? "cannot be opened for reading" : "does not exist");
  }
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw PathError(path, "cannot determine its size");
  in.seekg(0, std::ios::beg);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), size);
  if (!in) throw PathError(path, "read failed");
  return bytes;
}

std::string Sha256Hex(std::span<const uint8_t> bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1) {
    throw std::runtime_error("SHA-256 computation failed in OpenSSL");
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(length * 2);
  for (unsigned int i = 0; i < length; ++i) {
    hex.push_back(kHex[digest[i] >> 4]);
    hex.push_back(kHex[digest[i] & 15]);
  }
  return hex;
}

std::string Sha256HexOfFile(const fs::path& path) { return Sha256Hex(ReadFileBytes(path)); }

}  // namespace scanbench
