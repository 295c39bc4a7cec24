// Size and encoding CPU time of an export's full-size maps in each lossless
// encoding: the measurement behind the export's file encodings
// (docs/export.md, "File encodings"; ExportPngEncoding and ExportExrEncoding
// in app/io/export_files.cc).
//
//   scanbench export s16/results/<run>                     # png16: the PNG maps
//   scanbench export s16/results/<run> --preset exr        # every map as float EXR
//   build/benchmarks/export_encoding_benchmark s16/exports/<run>-png16 [s16/exports/<run>-exr]
//
// Every PNG and EXR of at least 1 megapixel in the folders given (their
// material subfolder included) is read, written in each candidate encoding
// into a scratch folder beside it (WritePng / WriteExr, fsync included, one
// file at a time), read back and removed: bytes, CPU seconds of the write
// (user + system of the whole process, so OpenEXR's own threads count) and
// wall seconds, then the read's CPU seconds. PNGs: zlib level 1 with libpng's
// row filters and zlib's strategies (PngEncoding); EXRs: 32-bit float in
// every lossless OpenEXR compression. The CPU figures are steadier than wall
// time on a shared machine, but a loaded machine still inflates them (caches,
// frequency); the sizes are exact. Figures, not pass/fail.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "benchmarks/process_cpu.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

struct Timing {
  double cpu_s = 0, wall_s = 0;
};

template <typename Work>
Timing Timed(const Work& work) {
  const double cpu = ProcessCpuSeconds();
  const auto start = std::chrono::steady_clock::now();
  work();
  return {ProcessCpuSeconds() - cpu, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
}

void PrintRow(const std::string& label, uintmax_t bytes, const Timing& write, const Timing& read) {
  std::printf("  %-24s %9.2f MB %8.2f s %8.2f s %8.2f s\n", label.c_str(), bytes / 1e6, write.cpu_s, write.wall_s,
              read.cpu_s);
  std::fflush(stdout);
}

void PrintHeader(const fs::path& file, int width, int height, int channels, const std::string& kind) {
  std::printf("\n%s (%dx%d, %d channel%s, %s)\n  %-24s %12s %10s %10s %10s\n", file.filename().c_str(), width, height,
              channels, channels == 1 ? "" : "s", kind.c_str(), "encoding", "bytes", "write cpu", "write wall",
              "read cpu");
}

std::vector<PngEncoding> PngCandidates() {
  std::vector<PngEncoding> candidates;
  auto add = [&](PngFilter filter, PngStrategy strategy) {
    PngEncoding encoding{1, filter};
    encoding.strategy = strategy;
    candidates.push_back(encoding);
  };
  for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kSub, PngFilter::kUp, PngFilter::kPaeth}) {
    add(filter, PngStrategy::kDefault);
  }
  for (PngFilter filter : {PngFilter::kAdaptive, PngFilter::kNone, PngFilter::kSub, PngFilter::kUp,
                           PngFilter::kPaeth}) {
    add(filter, PngStrategy::kRle);
  }
  add(PngFilter::kUp, PngStrategy::kHuffmanOnly);
  return candidates;
}

template <typename T>
void RunPng(const fs::path& file, const fs::path& scratch, const Image<T>& image) {
  PrintHeader(file, image.width(), image.height(), image.channels(), sizeof(T) == 2 ? "16-bit PNG" : "8-bit PNG");
  for (const PngEncoding& encoding : PngCandidates()) {
    const fs::path path = scratch / file.filename();
    const Timing write = Timed([&] { WritePng(path, image, OverwritePolicy::kRefuse, {}, encoding); });
    const uintmax_t bytes = fs::file_size(path);
    const Timing read = Timed([&] { (void)ReadImageU16(path); });
    fs::remove(path);
    PrintRow(std::string("1, ") + PngFilterName(encoding.filter) + ", " + PngStrategyName(encoding.strategy), bytes,
             write, read);
  }
}

void RunExr(const fs::path& file, const fs::path& scratch) {
  std::vector<std::string> channels;
  const ImageF image = ReadImageFloat(file, &channels);
  PrintHeader(file, image.width(), image.height(), image.channels(), "float EXR");
  for (ExrCompression compression : {ExrCompression::kNone, ExrCompression::kRle, ExrCompression::kZips,
                                     ExrCompression::kZip, ExrCompression::kPiz}) {
    const fs::path path = scratch / file.filename();
    const ExrEncoding encoding{ExrSampleType::kFloat32, compression};
    const Timing write = Timed([&] { WriteExr(path, image, OverwritePolicy::kRefuse, channels, {}, encoding); });
    const uintmax_t bytes = fs::file_size(path);
    const Timing read = Timed([&] { (void)ReadImageFloat(path); });
    fs::remove(path);
    PrintRow(std::string("float32 ") + ExrCompressionName(compression), bytes, write, read);
  }
}

int Run(const std::vector<fs::path>& folders) {
  int maps = 0;
  for (const fs::path& folder : folders) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::recursive_directory_iterator(folder)) {
      const std::string extension = entry.path().extension().string();
      if (entry.is_regular_file() && (extension == ".png" || extension == ".exr")) files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    const fs::path scratch = folder.parent_path() / (".export_encoding_benchmark." + folder.filename().string());
    fs::create_directories(scratch);
    std::printf("%s\n", folder.c_str());
    for (const fs::path& file : files) {
      const ImageFileInfo info = ReadImageFileInfo(file);
      if (static_cast<double>(info.width) * info.height < 1e6) continue;
      ++maps;
      if (file.extension() == ".exr") {
        RunExr(file, scratch);
      } else if (info.bits_per_sample == 8) {
        RunPng(file, scratch, ReadImageU8(file));
      } else {
        RunPng(file, scratch, ReadImageU16(file));
      }
    }
    fs::remove_all(scratch);
  }
  if (maps == 0) {
    std::fprintf(stderr, "no PNG or EXR of at least 1 MP in the folders given\n");
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace scanbench

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s <export folder> [<export folder> ...]\n", argv[0]);
    return 2;
  }
  try {
    std::vector<std::filesystem::path> folders(argv + 1, argv + argc);
    return scanbench::Run(folders);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
}
