// The CPU and wall time of writing a solve's result files alone: a result
// folder's maps read back into a solution and streamed again through
// SolutionMapStream (app/io/result_maps.h) in the solve's 128-row
// bands, the error map's rows as the evaluation's item beside the files, as
// `scanbench solve` writes them. The measurement behind docs/solver.md's
// "Writing the results" (issue #14): the process's CPU (user + system, every
// thread, OpenEXR's own included) is steadier than a whole solve's on a
// shared machine.
//
//   build/app/cli/scanbench solve s16 && build/benchmarks/result_writing_benchmark s16/results/<run> 2 3
//
// Arguments: the result folder, the thread count (default 2), the repeats
// (default 3). The files go to a scratch folder beside the result and are
// removed; their sizes are printed. The solution read back is the files'
// (16-bit normals, half albedo and confidence), so normal.png is the
// result's byte for byte and the EXRs nearly so in size; the work is the same.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "app/io/image_io.h"
#include "app/io/result_maps.h"
#include "benchmarks/process_cpu.h"
#include "pipeline/banded_solve.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

// The solution the result's files hold (what the solve handed them, as far
// as the files keep it: the normals from normal.png's 16-bit codes, which
// encode to the same codes again, so normal.png is the result's byte for
// byte; status.png's code 7 is a solved pixel whose lobe is unsupported).
PhotometricSolution SolutionOfResult(const fs::path& result) {
  PhotometricSolution solution;
  const ImageU16 normal_codes = ReadImageU16(result / "normal.png");
  solution.normal_in_table = ImageF(normal_codes.width(), normal_codes.height(), 3);
  for (size_t i = 0; i < normal_codes.size(); ++i) {
    solution.normal_in_table.data()[i] = static_cast<float>(normal_codes.data()[i] / 65535.0 * 2.0 - 1.0);
  }
  solution.albedo = ReadImageFloat(result / "albedo.exr");
  const ImageU8 codes = ReadImageU8(result / "status.png");
  const ImageF confidence = ReadImageFloat(result / "confidence.exr");
  const int width = codes.width(), height = codes.height();
  solution.status = ImageU8(width, height, 1);
  solution.lights_used = ImageU8(width, height, 1);
  solution.condition_number = ImageF(width, height, 1);
  solution.residual = ImageF(width, height, 1);
  solution.solve_path = ImageU8(width, height, 1);
  const bool specular = fs::exists(result / "specular.exr");
  if (specular) {
    solution.specular = ReadImageFloat(result / "specular.exr");
    solution.specular_status = ImageU8(width, height, 1);
  }
  for (size_t i = 0; i < codes.num_pixels(); ++i) {
    const bool unsupported = codes.data()[i] == kStatusSolvedSpecularUnsupported;
    solution.status.data()[i] = unsupported ? static_cast<uint8_t>(PixelStatus::kSolved) : codes.data()[i];
    solution.lights_used.data()[i] = static_cast<uint8_t>(confidence.data()[3 * i]);
    solution.condition_number.data()[i] = confidence.data()[3 * i + 1];
    solution.residual.data()[i] = confidence.data()[3 * i + 2];
    if (specular) {
      const bool solved = solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
      const SpecularStatus status = !solved        ? SpecularStatus::kNotSolved
                                    : unsupported ? SpecularStatus::kUnsupported
                                                  : SpecularStatus::kEstimated;
      solution.specular_status.data()[i] = static_cast<uint8_t>(status);
    }
  }
  return solution;
}

int Run(const fs::path& result, int threads, int repeats) {
  const auto read_start = std::chrono::steady_clock::now();
  const PhotometricSolution solution = SolutionOfResult(result);
  const bool with_error_map = fs::exists(result / "angular_error_deg.exr");
  const ImageF error_map = with_error_map ? ReadImageFloat(result / "angular_error_deg.exr") : ImageF();
  const int width = solution.status.width(), height = solution.status.height();
  std::printf("%s: %dx%d, %s, %d threads; read in %.2f s\n", result.c_str(), width, height,
              solution.specular.empty() ? "no specular map" : "with specular map", threads,
              std::chrono::duration<double>(std::chrono::steady_clock::now() - read_start).count());
  constexpr int kBandRows = 128;  // the solve's (kEvaluationBandRows)
  std::vector<PhotometricSolution> bands;
  std::vector<ImageF> error_bands;
  for (int y = 0; y < height; y += kBandRows) {
    const int rows = std::min(kBandRows, height - y);
    bands.push_back(SolutionRows(solution, y, rows));
    if (with_error_map) {
      ImageF band(width, rows, 1);
      std::copy(error_map.row(y), error_map.row(y) + band.size(), band.data());
      error_bands.push_back(std::move(band));
    }
  }
  const fs::path scratch = result.parent_path() / (".result_writing_benchmark." + result.filename().string());
  for (int repeat = 0; repeat < repeats; ++repeat) {
    fs::remove_all(scratch);
    fs::create_directories(scratch);
    const double cpu_start = ProcessCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    double commit_s = 0;
    {
      SolutionMapStream stream(scratch, width, height, !solution.specular.empty(), with_error_map);
      for (size_t b = 0; b < bands.size(); ++b) {
        stream.AddBand(bands[b],
                       with_error_map ? std::function<ImageF()>([&] { return error_bands[b]; })
                                      : std::function<ImageF()>(),
                       threads);
      }
      const auto commit_start = std::chrono::steady_clock::now();
      stream.Commit();
      commit_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - commit_start).count();
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double cpu = ProcessCpuSeconds() - cpu_start;
    uintmax_t total = 0;
    std::string sizes;
    for (const auto& [name, bytes] : FileSizesIn(scratch)) {
      total += bytes;
      sizes += " " + name + " " + std::to_string(bytes);
    }
    std::printf("run %d: wall %.2f s (Commit %.2f s), CPU %.2f s (%.0f %% of %d threads), %.1f MB:%s\n", repeat + 1,
                wall, commit_s, cpu, 100 * cpu / (wall * threads), threads, total / 1e6, sizes.c_str());
    std::fflush(stdout);
  }
  fs::remove_all(scratch);
  return 0;
}

}  // namespace
}  // namespace scanbench

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s <result folder> [threads, default 2] [repeats, default 3]\n", argv[0]);
    return 2;
  }
  try {
    return scanbench::Run(argv[1], argc > 2 ? std::stoi(argv[2]) : 2, argc > 3 ? std::stoi(argv[3]) : 3);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  }
}
