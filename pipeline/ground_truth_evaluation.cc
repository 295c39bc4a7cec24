#include "pipeline/ground_truth_evaluation.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/parallel_for.h"
#include "pipeline/banded_solve.h"
#include "pipeline/error_statistics.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// The truth's rows as GroundTruthRows gave them: the solution's width, 3 channels.
const ImageF& CheckedTruthRows(const ImageF& rows, int width, int num_rows, const char* what) {
  if (rows.width() != width || rows.height() != num_rows || rows.channels() != 3) {
    throw std::invalid_argument(std::string("GroundTruthEvaluation: the truth's ") + what + " rows are " +
                                ShapeText(rows) + ", the solution's " + SizeText(width, num_rows) + "x3");
  }
  return rows;
}

}  // namespace

struct GroundTruthEvaluation::State {
  std::unique_ptr<GroundTruthRows> truth;
  ImageF truth_normal_rows, truth_albedo_rows;  // AddBand's, reused from band to band
  ImageU8 solved_on_sample;                     // AddBand's, reused
  ImageU8 on_sample;  // whole size
  int rows_added = 0;
  size_t unsolved_on_sample = 0;
  AlbedoColorComparison color;  // spills the pixels whose truth may be a region's
  FloatErrorStatistics angles;  // the angles, as floats
  FloatErrorStatistics albedo_errors;  // the albedo's absolute errors (pixel, channel), as floats
  std::vector<double> band_values;  // AddBand's, reused from band to band
  explicit State(const fs::path& spill_folder) : color(0.002, spill_folder) {}
};

GroundTruthEvaluation::GroundTruthEvaluation(ImageU8 on_sample, std::unique_ptr<GroundTruthRows> truth,
                                             const fs::path& spill_folder)
    : state_(std::make_unique<State>(spill_folder)) {
  if (on_sample.empty() || on_sample.channels() != 1 || truth == nullptr) {
    throw std::invalid_argument("GroundTruthEvaluation: a sample mask of " + ShapeText(on_sample) +
                                " (must be 1 channel, not empty) and " + (truth ? "a" : "no") + " truth");
  }
  State& s = *state_;
  s.truth = std::move(truth);
  s.on_sample = std::move(on_sample);
  const int width = s.on_sample.width(), height = s.on_sample.height();
  // The values held in memory: room for every sample pixel at once, never a
  // second copy while growing.
  const size_t sample_pixels = std::count_if(s.on_sample.data(), s.on_sample.data() + s.on_sample.size(),
                                             [](uint8_t on) { return on != 0; });
  s.angles.Reserve(sample_pixels);
  s.color.Reserve(sample_pixels);
  s.albedo_errors.Reserve(3 * sample_pixels);
  // The truth's colours over the sample, read once before the bands: the
  // colour comparison then spills only the pixels that may be a uniform
  // region's (a chart's patches), not a textile's every pixel.
  ImageF truth_rows;
  ImageU8 mask_rows;
  for (int y = 0; y < height; y += kEvaluationBandRows) {
    const int rows = std::min(kEvaluationBandRows, height - y);
    s.truth->ReadAlbedoRows(y, y + rows, &truth_rows);
    CheckedTruthRows(truth_rows, width, rows, "albedo");
    mask_rows.Reshape(width, rows, 1);
    std::copy(s.on_sample.row(y), s.on_sample.row(y) + mask_rows.size(), mask_rows.data());
    s.color.CountPossibleRegions(truth_rows, mask_rows);
  }
}

GroundTruthEvaluation::GroundTruthEvaluation(GroundTruthEvaluation&&) noexcept = default;
GroundTruthEvaluation& GroundTruthEvaluation::operator=(GroundTruthEvaluation&&) noexcept = default;
GroundTruthEvaluation::~GroundTruthEvaluation() = default;

ImageF GroundTruthEvaluation::AddBand(const PhotometricSolution& band, int num_threads) {
  State& s = *state_;
  const int width = s.on_sample.width(), rows = band.status.height(), y0 = s.rows_added;
  if (band.status.width() != width || rows < 1 || y0 + rows > s.on_sample.height() ||
      !band.normal_in_table.SameSize(band.status) || band.normal_in_table.channels() != 3 ||
      !band.albedo.SameSize(band.status) || band.albedo.channels() != 3) {
    throw std::invalid_argument("GroundTruthEvaluation::AddBand: a band of " + ShapeText(band.status) + " (normals " +
                                ShapeText(band.normal_in_table) + ", albedo " + ShapeText(band.albedo) + ") after " +
                                std::to_string(y0) + " rows of " + ShapeText(s.on_sample));
  }
  s.rows_added += rows;
  ImageU8& solved_on_sample = s.solved_on_sample;
  solved_on_sample.Reshape(width, rows, 1);
  for (size_t i = 0; i < solved_on_sample.size(); ++i) {
    const bool on_sample = s.on_sample.row(y0)[i] != 0;
    const bool solved = band.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    solved_on_sample.data()[i] = on_sample && solved;
    s.unsolved_on_sample += on_sample && !solved;
  }
  ImageF error_rows(width, rows, 1, 0.0f);
  s.band_values.clear();
  s.truth->ReadNormalRows(y0, y0 + rows, &s.truth_normal_rows);
  AngularErrorsOfRows(band.normal_in_table, CheckedTruthRows(s.truth_normal_rows, width, rows, "normal"), 0,
                      solved_on_sample, num_threads, &s.band_values, &error_rows);
  s.angles.Add(s.band_values);
  s.truth->ReadAlbedoRows(y0, y0 + rows, &s.truth_albedo_rows);
  const ImageF& truth_albedo = CheckedTruthRows(s.truth_albedo_rows, width, rows, "albedo");
  s.color.AddRows(band.albedo, solved_on_sample, truth_albedo, num_threads);
  // The albedo's absolute error of every channel, pooled in pixel order.
  s.band_values.clear();
  AbsoluteErrorsOfRows(band.albedo, truth_albedo, 0, solved_on_sample, num_threads, &s.band_values);
  s.albedo_errors.Add(s.band_values);
  return error_rows;
}

GroundTruthComparison GroundTruthEvaluation::Finish(int num_threads) {
  State& s = *state_;
  if (s.rows_added != s.on_sample.height()) {
    throw std::logic_error("GroundTruthEvaluation::Finish: " + std::to_string(s.rows_added) + " of " +
                           std::to_string(s.on_sample.height()) + " rows added");
  }
  GroundTruthComparison comparison;
  comparison.unsolved_on_sample = s.unsolved_on_sample;
  // Side by side: the albedo's errors (the most values) and the rest.
  ParallelFor(2, std::min(2, ResolveThreadCount(num_threads)), 1, [&](int begin, int end, int) {
    for (int item = begin; item < end; ++item) {
      if (item == 0) {
        comparison.albedo_error = s.albedo_errors.Finish();
      } else {
        comparison.normal_error_deg = s.angles.Finish();
        comparison.albedo_color_error = s.color.Finish();
      }
    }
  });
  return comparison;
}

GroundTruthComparison CompareWithGroundTruth(ImageU8 on_sample, std::unique_ptr<GroundTruthRows> truth,
                                             const PhotometricSolution& solution, int num_threads, int band_rows) {
  if (band_rows < 1) {
    throw std::invalid_argument("CompareWithGroundTruth: band_rows " + std::to_string(band_rows) + " must be >= 1");
  }
  const int width = solution.status.width(), height = solution.status.height();
  if (!on_sample.SameSize(width, height)) {
    throw std::invalid_argument("CompareWithGroundTruth: a sample mask of " + ShapeText(on_sample) +
                                " for a solution of " + SizeText(width, height));
  }
  GroundTruthEvaluation evaluation(std::move(on_sample), std::move(truth));
  ImageF error_map(width, height, 1);
  for (int y = 0; y < height; y += band_rows) {
    const ImageF rows = evaluation.AddBand(SolutionRows(solution, y, std::min(band_rows, height - y)), num_threads);
    std::copy(rows.data(), rows.data() + rows.size(), error_map.row(y));
  }
  GroundTruthComparison comparison = evaluation.Finish(num_threads);
  comparison.angular_error_deg = std::move(error_map);
  return comparison;
}

}  // namespace scanbench
