// The solve's ground-truth evaluation (GroundTruthEvaluation, issue #14, on
// the session's files: SessionGroundTruthEvaluation) on its own: a result's
// normal and albedo maps against the session's ground truth, band by band as
// `scanbench solve` hands them over, with the wall and CPU time of the bands
// and of Finish and every figure printed to the last digit (so two builds'
// figures can be diffed: they must be equal).
//
//   scanbench simulate s16 --width 4928 --height 3264 && scanbench solve s16
//   build/benchmarks/ground_truth_evaluation_benchmark s16 s16/results/<run> [threads] [band rows]
//
// The result's maps are half float, so its figures are not the solve's own
// (those come from the full-precision bands); every pixel counts as solved.
// Figures, not pass/fail; wall time depends on the machine's load, CPU time
// (user + system of the process) much less.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "app/controllers/solve_controller.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "benchmarks/process_cpu.h"
#include "pipeline/banded_solve.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;

double Since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void PrintStatistics(const char* name, const ErrorStatistics& s) {
  std::printf("%-24s pixels %zu mean %.17g median %.17g p95 %.17g max %.17g\n", name, s.num_pixels, s.mean, s.median,
              s.percentile_95, s.max);
}

int Run(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s <session> <result folder> [threads, 0 = all] [band rows, 128]\n", argv[0]);
    return 2;
  }
  const fs::path session_dir = argv[1], result_dir = argv[2];
  const int threads = argc > 3 ? std::stoi(argv[3]) : 0;
  const int band_rows = argc > 4 ? std::stoi(argv[4]) : 128;
  const Session session = LoadSession(session_dir);
  if (!session.ground_truth) {
    std::fprintf(stderr, "%s has no ground truth\n", session_dir.c_str());
    return 2;
  }
  PhotometricSolution solution;
  solution.normal_in_table = ReadImageFloat(result_dir / "normal.exr");
  solution.albedo = ReadImageFloat(result_dir / "albedo.exr");
  const int width = solution.albedo.width(), height = solution.albedo.height();
  solution.status = ImageU8(width, height, 1, static_cast<uint8_t>(PixelStatus::kSolved));

  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ProcessCpuSeconds();
  GroundTruthEvaluation evaluation =
      SessionGroundTruthEvaluation(session_dir, *session.ground_truth, width, height, result_dir);
  for (int y = 0; y < height; y += band_rows) {
    evaluation.AddBand(SolutionRows(solution, y, std::min(band_rows, height - y)), threads);
  }
  const double bands_wall = Since(start), bands_cpu = ProcessCpuSeconds() - cpu_start;
  const auto finish_start = std::chrono::steady_clock::now();
  const double finish_cpu_start = ProcessCpuSeconds();
  const GroundTruthComparison comparison = evaluation.Finish(threads);
  const double finish_wall = Since(finish_start), finish_cpu = ProcessCpuSeconds() - finish_cpu_start;

  std::printf("%dx%d, %d threads, bands of %d rows\n", width, height, threads, band_rows);
  std::printf("bands:  wall %.3f s, CPU %.3f s\nfinish: wall %.3f s, CPU %.3f s\ntotal:  wall %.3f s, CPU %.3f s\n",
              bands_wall, bands_cpu, finish_wall, finish_cpu, bands_wall + finish_wall, bands_cpu + finish_cpu);
  PrintStatistics("normal_error_deg", comparison.normal_error_deg);
  PrintStatistics("albedo_error", comparison.albedo_error);
  PrintStatistics("albedo_delta_e", comparison.albedo_color_error.delta_e);
  std::printf("unsolved_on_sample %zu\nalbedo colour: %s\n", comparison.unsolved_on_sample,
              comparison.albedo_color_error.ReportJson().c_str());
  return 0;
}

}  // namespace
}  // namespace scanbench

int main(int argc, char** argv) {
  try {
    return scanbench::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
