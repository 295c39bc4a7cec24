// A solution against its ground truth (a simulated rig's), band by band as the
// solve streams its bands (issue #14): the normals' angular error, the albedo's
// absolute error and CIEDE2000, on the solved pixels of the sample. Where the
// truth comes from is the caller's (the solve job reads a session's files,
// solve_controller.h): the evaluation reads it a band of rows at a time
// through GroundTruthRows, so neither a full-size solution nor truth is held.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>

#include "core/image.h"
#include "pipeline/albedo_color.h"
#include "solver/angular_error.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// The figures of an evaluation, on the solved pixels of the sample.
struct GroundTruthComparison {
  ErrorStatistics normal_error_deg;
  ErrorStatistics albedo_error;
  AlbedoColorErrors albedo_color_error;
  size_t unsolved_on_sample = 0;
  ImageF angular_error_deg;  // per pixel, 0 off the evaluated pixels
};

// Rows of the truth read at a time by CompareWithGroundTruth and by the
// evaluation's first reading of the truth's colours: 16 MB of float RGB at 16
// MP, a multiple of OpenEXR's largest scanline chunk (32 rows, piz), so that
// no chunk of a truth file is decoded twice.
inline constexpr int kEvaluationBandRows = 256;

// Where an evaluation reads the truth, a band of rows at a time.
class GroundTruthRows {
 public:
  virtual ~GroundTruthRows() = default;
  // Rows [y_begin, y_end) of the true unit normals (table frame) into *rows,
  // width x (y_end - y_begin) x 3; *rows may be reused from the last call.
  virtual void ReadNormalRows(int y_begin, int y_end, ImageF* rows) = 0;
  // The same rows of the true albedo (the solution's colour space).
  virtual void ReadAlbedoRows(int y_begin, int y_end, ImageF* rows) = 0;
};

// The evaluation band by band: the truth's rows are read for each band; the
// angles, the albedo's errors and the CIEDE2000 values are held as floats
// (FloatErrorStatistics: 20 bytes a sample pixel, 228 MB at 16 MP); the
// truth's colours are read once first, so that only the pixels that may be a
// uniform region's go to a spill file (AlbedoColorComparison's
// CountPossibleRegions: almost none of a textile). Finish gives what the
// whole-frame figures (AngularErrorDegrees, AbsoluteError, CompareAlbedoColor)
// give, except that the medians and p95s are those of the values rounded to
// float. Holds the sample mask (1 byte a pixel).
class GroundTruthEvaluation {
 public:
  // For a solution of the sample mask's size (`on_sample`: 1 channel, nonzero
  // = on the sample); spill files in `spill_folder` (empty = the temporary
  // folder). Reads the truth's albedo over the whole frame once.
  GroundTruthEvaluation(ImageU8 on_sample, std::unique_ptr<GroundTruthRows> truth,
                        const std::filesystem::path& spill_folder = {});
  GroundTruthEvaluation(GroundTruthEvaluation&&) noexcept;
  GroundTruthEvaluation& operator=(GroundTruthEvaluation&&) noexcept;
  ~GroundTruthEvaluation();
  // The next band of the solution (its normal_in_table, albedo and status,
  // rows following the last band's); returns its rows of the angular error
  // map (degrees, 1 channel, 0 off the evaluated pixels). num_threads 0 = all.
  ImageF AddBand(const PhotometricSolution& band, int num_threads = 0);
  // Every row added; angular_error_deg is left empty (the rows went to AddBand's caller).
  // Its statistics' reads run side by side on up to `num_threads` threads (0 = all);
  // the figures do not depend on it.
  GroundTruthComparison Finish(int num_threads = 0);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The same over a whole solution, band_rows (>= 1) at a time, with the whole
// error map. num_threads 0 = all.
GroundTruthComparison CompareWithGroundTruth(ImageU8 on_sample, std::unique_ptr<GroundTruthRows> truth,
                                             const PhotometricSolution& solution, int num_threads = 0,
                                             int band_rows = kEvaluationBandRows);

}  // namespace scanbench
