// The colour space of the solved albedo (issue #12). The solver's albedo is
// white-balanced camera RGB: per raw colour channel, divided by what a perfect
// white would read under the same LED (the light calibration carries that), so
// neutrals are neutral but every other colour is in the sensor's own primaries.
// A 3x3 matrix takes it to linear Rec.709 (D65): the colour calibration's, fitted
// on a ColorChecker, or (weaker) one made from the RAW file's own camera matrix.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <utility>
#include <vector>
#include <string>

#include <Eigen/Core>

#include "core/image.h"
#include "core/spill_file.h"
#include "pipeline/error_statistics.h"
#include "solver/angular_error.h"

namespace scanbench {

struct AlbedoColorOptions {
  enum class Source {
    kAuto,          // the calibration set's colour section, else the RAW file's camera matrix, else none
    kChart,         // the calibration set's colour section (an error without one)
    kCameraMatrix,  // the RAW file's camera matrix (an error when the files carry none)
    kNone,          // white-balanced camera RGB, as solved
  };
  Source source = Source::kAuto;
};

const char* AlbedoColorSourceName(AlbedoColorOptions::Source source);
// Parses "auto", "chart", "camera-matrix", "none"; throws std::invalid_argument naming the text.
AlbedoColorOptions::Source AlbedoColorSourceFromName(const std::string& name);

struct AlbedoColor {
  AlbedoColorOptions::Source source = AlbedoColorOptions::Source::kNone;  // what was used (never kAuto)
  Eigen::Matrix3d rec709_from_camera = Eigen::Matrix3d::Identity();
  std::string color_space = "camera_rgb";  // "linear_rec709" when a matrix was applied
  std::string description;                 // one line for reports: what, from where, how good
  // "absolute" (diffuse reflectance: a 99 % white sheet reads 0.99) or "relative".
  std::string scale = "relative";
  std::string scale_source;                // why, one line
  std::optional<double> chart_mean_delta_e;  // the colour calibration's own fit, when used
  std::optional<double> chart_max_delta_e;

  bool IsLinearRec709() const { return color_space == "linear_rec709"; }
  // report.json's "color".
  std::string ReportJson() const;
};

// albedo (3 channels) <- rec709_from_camera * albedo on the pixels where
// `solved` is non-zero; the rest keep their fill value.
void ApplyAlbedoColor(const AlbedoColor& color, const ImageU8& solved, ImageF* albedo);

// The solved albedo's colour against a ground truth in linear Rec.709: CIEDE2000
// per pixel, and per uniform region of the truth (a colour chart's patches:
// every region of one exact truth value covering at least min_region_fraction
// of the evaluated pixels), where the region's median albedo is compared.
struct AlbedoRegionError {
  std::string name;                  // the ColorChecker patch it matches, else "region N"
  bool chart_patch = false;          // matches a ColorChecker patch
  Eigen::Vector3d truth_linear_rec709 = Eigen::Vector3d::Zero();
  Eigen::Vector3d solved_linear_rec709 = Eigen::Vector3d::Zero();  // median over the region
  double delta_e = 0;                // CIEDE2000 of the two
  size_t pixels = 0;
};

struct AlbedoColorErrors {
  ErrorStatistics delta_e;                 // per pixel
  std::vector<AlbedoRegionError> regions;  // largest first; empty for a textile
  double region_mean_delta_e = 0, region_max_delta_e = 0;
  // Over the regions that are ColorChecker patches (by their truth value).
  int chart_patches = 0;
  double chart_mean_delta_e = 0, chart_max_delta_e = 0;
  std::string ReportJson() const;
};

AlbedoColorErrors CompareAlbedoColor(const ImageF& albedo_linear_rec709, const ImageF& truth_linear_rec709,
                                     const ImageU8& mask, double min_region_fraction = 0.002);

// One evaluated pixel as AlbedoColorComparison keeps it (in its spill file).
struct ComparedAlbedoPixel {
  float truth_linear_rec709[3];
  float albedo_linear_rec709[3];
};

// CompareAlbedoColor band by band (the solve's evaluation, so that neither a
// full-size albedo nor a full-size truth is held): AddRows for the bands in
// order, then Finish gives exactly what CompareAlbedoColor gives on the whole
// images. Per evaluated pixel its truth and its albedo (a ComparedAlbedoPixel,
// 24 bytes) go to one spill file (SpillFile, core/spill_file.h), read back
// by ForEachPixel (with CountPossibleRegions first, only those whose truth may
// be a region's); their CIEDE2000 is held as a float
// (FloatErrorStatistics: the per-pixel median and p95 are those of the
// values rounded to float); in memory besides only counts per hash bucket of
// the truth values. Finish finds the uniform regions
// from those buckets: a region has at least min_pixels pixels, so its bucket
// has too, and at most evaluated / min_pixels buckets do; only their pixels
// are counted exactly.
class AlbedoColorComparison {
 public:
  // The spill files' folder: SpillFile's (empty = the temporary folder).
  explicit AlbedoColorComparison(double min_region_fraction = 0.002,
                                 const std::filesystem::path& spill_folder = {});
  AlbedoColorComparison(const AlbedoColorComparison&) = delete;  // its statistics read its own spill
  AlbedoColorComparison& operator=(const AlbedoColorComparison&) = delete;
  // Rows of the albedo and the truth (3 channels) and of the mask (1
  // channel), one size, following the rows added before. The rows run in parallel.
  void AddRows(const ImageF& albedo_rows, const ImageU8& mask_rows, const ImageF& truth_rows, int num_threads = 0);
  // Room for the CIEDE2000 of this many pixels (an upper bound of those to be evaluated).
  void Reserve(size_t pixels) { delta_e_.Reserve(pixels); }
  // Optional, before the first AddRows: the truth's rows over a superset of
  // the pixels that will be evaluated (mask_rows: the sample mask), a band at
  // a time in any order, so that AddRows spills only the pixels whose truth
  // falls in a hash bucket holding at least 16 of them (the smallest region
  // there can be): no other pixel can be a region's. A textile's truth
  // differs from pixel to pixel and almost nothing is spilled. Without it
  // every evaluated pixel is spilled.
  void CountPossibleRegions(const ImageF& truth_rows, const ImageU8& mask_rows);
  // visit(pixels) over the spilled pixels (every pixel added so far, or after
  // CountPossibleRegions those that may be a region's), in pixel order, in
  // chunks (read back from the spill file). It only reads, so it may run on
  // another thread beside Finish.
  void ForEachPixel(const std::function<void(std::span<const ComparedAlbedoPixel>)>& visit);
  AlbedoColorErrors Finish();  // once

 private:
  double min_region_fraction_;
  int width_ = -1;
  SpillFile pixels_;                     // per evaluated pixel a ComparedAlbedoPixel; pixel order
  FloatErrorStatistics delta_e_;         // the CIEDE2000 values, pixel order
  std::vector<uint32_t> bucket_counts_;  // evaluated pixels per hash bucket of the truth bits
  std::vector<uint32_t> possible_counts_;  // CountPossibleRegions': its pixels per bucket
  std::vector<uint8_t> possible_;          // from those at the first AddRows: 1 = spill its pixels
  // AddRows' rows (each row's evaluated pixels from row * width), kept from band to band.
  std::vector<ComparedAlbedoPixel> band_pixels_;
  std::vector<double> band_delta_e_;
  std::vector<uint32_t> band_buckets_;  // each pixel's hash bucket of its truth bits
  std::vector<uint32_t> band_row_counts_;
  std::vector<uint32_t> band_spilled_counts_;  // each row's pixels spilled (the first ones of its stretch)
};

}  // namespace scanbench
