// Size and write time of a result folder's EXR maps in each lossless OpenEXR
// encoding, on the maps of a real solve: the measurement behind the result
// maps' default (docs/session-format.md, "Result map encoding").
//
//   scanbench simulate s16 --width 4928 --height 3264 && scanbench solve s16 --float32-maps
//   build/benchmarks/exr_encoding_benchmark s16/results/<run>
//
// Each map is written (sequentially, one file at a time, fsync included, as
// WriteExr does) into a scratch folder beside the result, timed, measured,
// read back (ReadImageFloat, timed: export and the GUI read these maps) and
// removed. Figures, not pass/fail; the write time depends on the machine's
// load. Also prints the largest change of a normal's direction that half
// storage makes on this normal map. Then normal.png in zlib levels and row
// filters.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "app/io/file_util.h"
#include "app/io/image_io.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

struct Candidate {
  std::string label;
  ExrEncoding encoding;
  double normal_step = 0;  // ExrEncoding::half_absolute_step for normal.exr only
};

double MaxAngleChangeDegrees(const ImageF& before, const ImageF& after) {
  double max_deg = 0;
  for (size_t p = 0; p < before.num_pixels(); ++p) {
    const float* a = before.data() + 3 * p;
    const float* b = after.data() + 3 * p;
    const double na = std::sqrt(double(a[0]) * a[0] + double(a[1]) * a[1] + double(a[2]) * a[2]);
    const double nb = std::sqrt(double(b[0]) * b[0] + double(b[1]) * b[1] + double(b[2]) * b[2]);
    if (na < 0.5 || nb < 0.5) continue;  // unsolved pixels are stored as 0
    const double dot = (double(a[0]) * b[0] + double(a[1]) * b[1] + double(a[2]) * b[2]) / (na * nb);
    // atan2 of |a x b| and a . b stays accurate for tiny angles where acos does not.
    const double cx = double(a[1]) * b[2] - double(a[2]) * b[1], cy = double(a[2]) * b[0] - double(a[0]) * b[2],
                 cz = double(a[0]) * b[1] - double(a[1]) * b[0];
    const double angle = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz) / (na * nb), dot);
    max_deg = std::max(max_deg, angle * 180 / std::numbers::pi);
  }
  return max_deg;
}

// normal.png (16-bit RGB, the largest file of a result) in zlib levels and
// libpng row filters: bytes, write and read time.
void RunPngEncodings(const fs::path& result, const fs::path& scratch) {
  if (!fs::exists(result / "normal.png")) return;
  const ImageU16 normals = ReadImageU16(result / "normal.png");
  std::vector<PngEncoding> encodings;
  for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kNone, PngFilter::kSub, PngFilter::kUp,
                           PngFilter::kAverage, PngFilter::kPaeth}) {
    encodings.push_back({1, filter});
  }
  for (int level : {2, 3, 6}) {
    for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kUp, PngFilter::kPaeth}) encodings.push_back({level, filter});
  }
  std::printf("\nnormal.png (%dx%d, 16-bit RGB)\n%-22s %10s %8s %7s\n", normals.width(), normals.height(),
              "zlib level, filter", "bytes", "write", "read");
  for (const PngEncoding& encoding : encodings) {
    const fs::path path = scratch / "normal.png";
    const auto start = std::chrono::steady_clock::now();
    WritePng(path, normals, OverwritePolicy::kRefuse, {}, encoding);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const uintmax_t bytes = fs::file_size(path);
    const auto read_start = std::chrono::steady_clock::now();
    const ImageU16 read_back = ReadImageU16(path);
    const double read_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
    fs::remove(path);
    std::printf("%d, %-19s %7.1f MB %6.2f s %5.2f s\n", encoding.zlib_level, PngFilterName(encoding.filter),
                bytes / 1e6, seconds, read_s);
    std::fflush(stdout);
  }
}

int Run(const fs::path& result) {
  const std::vector<std::string> names = {"normal.exr", "albedo.exr", "confidence.exr", "angular_error_deg.exr",
                                          "specular.exr"};
  struct Map {
    std::string name;
    ImageF pixels;
    std::vector<std::string> channels;
    ImageMetadata metadata;
  };
  std::vector<Map> maps;
  for (const std::string& name : names) {
    if (!fs::exists(result / name)) continue;
    Map map{name, {}, {}, {}};
    map.pixels = ReadImageFloat(result / name, &map.channels);
    map.metadata = ReadImageMetadata(result / name);
    maps.push_back(std::move(map));
  }
  if (maps.empty()) {
    std::fprintf(stderr, "%s: no result EXR maps (normal.exr, albedo.exr, ...) in this folder\n", result.c_str());
    return 1;
  }
  std::vector<Candidate> candidates = {{"float32 zip", {ExrSampleType::kFloat32, ExrCompression::kZip}}};
  for (ExrCompression c : {ExrCompression::kNone, ExrCompression::kRle, ExrCompression::kZips, ExrCompression::kZip,
                           ExrCompression::kPiz, ExrCompression::kPxr24}) {
    candidates.push_back({std::string("half ") + ExrCompressionName(c), {ExrSampleType::kHalf, c}});
  }
  // Normals on an absolute 2^-12 grid (WriteSolutionMaps' normal.exr).
  for (ExrCompression c : {ExrCompression::kRle, ExrCompression::kZips, ExrCompression::kZip, ExrCompression::kPiz}) {
    candidates.push_back({std::string("half ") + ExrCompressionName(c) + " n2^-12", {ExrSampleType::kHalf, c},
                          std::ldexp(1.0, -12)});
  }
  const fs::path scratch = result.parent_path() / (".exr_encoding_benchmark." + result.filename().string());
  fs::create_directories(scratch);
  std::printf("%s: %dx%d\n", result.c_str(), maps.front().pixels.width(), maps.front().pixels.height());
  std::printf("%-13s", "encoding");
  for (const Map& map : maps) std::printf(" %26s", map.name.c_str());
  std::printf(" %26s\n%-13s", "total", "");
  for (size_t i = 0; i <= maps.size(); ++i) std::printf(" %26s", "bytes / write / read");
  std::printf("\n");
  for (const Candidate& candidate : candidates) {
    std::printf("%-13s", candidate.label.c_str());
    uintmax_t total_bytes = 0;
    double total_s = 0, total_read_s = 0;
    for (const Map& map : maps) {
      const fs::path path = scratch / map.name;
      const auto start = std::chrono::steady_clock::now();
      ExrEncoding encoding = candidate.encoding;
      if (map.name == "normal.exr") encoding.half_absolute_step = candidate.normal_step;
      WriteExr(path, map.pixels, OverwritePolicy::kRefuse, map.channels, map.metadata, encoding);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const uintmax_t bytes = fs::file_size(path);
      const auto read_start = std::chrono::steady_clock::now();
      const ImageF read_back = ReadImageFloat(path);
      const double read_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count();
      if (map.name == "normal.exr" && candidate.encoding.sample_type == ExrSampleType::kHalf &&
          (candidate.encoding.compression == ExrCompression::kZip)) {
        std::fprintf(stderr, "normal.exr as %s: largest direction change %.5f deg\n", candidate.label.c_str(),
                     MaxAngleChangeDegrees(map.pixels, read_back));
      }
      fs::remove(path);
      total_bytes += bytes;
      total_s += seconds;
      total_read_s += read_s;
      std::printf(" %7.1f MB %6.2f s %5.2f s", bytes / 1e6, seconds, read_s);
    }
    std::printf(" %7.1f MB %6.2f s %5.2f s\n", total_bytes / 1e6, total_s, total_read_s);
    std::fflush(stdout);
  }
  RunPngEncodings(result, scratch);
  fs::remove_all(scratch);
  return 0;
}

}  // namespace
}  // namespace scanbench

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <result folder holding normal.exr, albedo.exr, ...>\n", argv[0]);
    return 2;
  }
  try {
    return scanbench::Run(argv[1]);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
}
