// The solver's error against run time: every method on simulated scenes
// (analytic spheres: Lambertian at several noise levels and with specular
// sheen; the simulated rig's textile with near-field LEDs and cast shadows,
// noise-free and through the RAW path incl. the Bayer-domain mode, and its
// cloth twill and satin through the RAW path; a 16 MP 10-light near-field
// scene) and on the DiLiGenT ball and bear when present, with all 96 lights
// and with 10 chosen like the rig's LED rings.
// Writes report.md (the table docs/solver.md quotes), report.csv and
// error_vs_time.svg (one panel per scene, Pareto front drawn).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"

namespace scanbench {

struct SolverReportOptions {
  std::filesystem::path output_dir;      // created if missing; the three files are replaced
  std::filesystem::path diligent_dir;    // holds ballPNG, bearPNG; empty or missing = skipped
  std::filesystem::path diligent_crop8_dir;  // holds buddhaPNG, gobletPNG, pot1PNG (8-bit crops); empty or missing = skipped
  bool include_16mp = true;              // the 4928 x 3264, 10-light scene (about 2 GB, minutes)
  int num_threads = 0;                   // solver threads; 0 = all cores, [0, 256]
  int analytic_size = 512;               // side of the analytic sphere scenes, pixels, [64, 4096]

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

struct SolverReportRow {
  std::string scene;
  std::string method;
  double mean_error_deg = 0;
  double median_error_deg = 0;
  double albedo_error = -1;   // mean absolute, linear units; < 0 = no ground truth
  double megapixels_per_second = 0;  // pixels asked for (the region) per second
  double seconds = 0;
  int threads = 0;
  double robust_fraction = 0;  // of the solved pixels, re-solved robustly
};

struct SolverReportSummary {
  std::vector<SolverReportRow> rows;
  std::vector<std::string> skipped;  // what was left out and why
  std::string MarkdownTable() const;
};

class SolverReportController : public BaseController {
 public:
  explicit SolverReportController(SolverReportOptions options);
  void Run() override;
  const SolverReportSummary& summary() const { return summary_; }

 private:
  SolverReportOptions options_;
  SolverReportSummary summary_;
};

// The scenes Run solves, in report order, without building any (for tests
// and --help); what is left out and why goes into *skipped when given.
std::vector<std::string> SolverReportSceneNames(const SolverReportOptions& options,
                                                std::vector<std::string>* skipped = nullptr);

// The plot on its own (for tests): one panel per scene, seconds per
// megapixel (log) against mean angular error, Pareto front as a line.
std::string ErrorVsTimeSvg(const std::vector<SolverReportRow>& rows);

}  // namespace scanbench
