#include "pipeline/albedo_color.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <map>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "calibration/color_calibration.h"
#include "calibration/color_checker.h"
#include "calibration/color_science.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace {

nlohmann::json MatrixJson(const Eigen::Matrix3d& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2)});
  return rows;
}

}  // namespace

const char* AlbedoColorSourceName(AlbedoColorOptions::Source source) {
  switch (source) {
    case AlbedoColorOptions::Source::kAuto: return "auto";
    case AlbedoColorOptions::Source::kChart: return "chart";
    case AlbedoColorOptions::Source::kCameraMatrix: return "camera-matrix";
    case AlbedoColorOptions::Source::kNone: return "none";
  }
  return "?";
}

AlbedoColorOptions::Source AlbedoColorSourceFromName(const std::string& name) {
  for (const auto source : {AlbedoColorOptions::Source::kAuto, AlbedoColorOptions::Source::kChart,
                            AlbedoColorOptions::Source::kCameraMatrix, AlbedoColorOptions::Source::kNone}) {
    if (name == AlbedoColorSourceName(source)) return source;
  }
  throw std::invalid_argument("albedo colour \"" + name + "\" must be auto, chart, camera-matrix or none");
}

void ApplyAlbedoColor(const AlbedoColor& color, const ImageU8& solved, ImageF* albedo) {
  if (albedo->channels() != 3 || solved.width() != albedo->width() || solved.height() != albedo->height()) {
    throw std::invalid_argument("ApplyAlbedoColor: albedo " + ShapeText(*albedo) + " and mask " + ShapeText(solved) +
                                " must be 3 and 1 channels of one size");
  }
  if (color.source == AlbedoColorOptions::Source::kNone) return;
  const Eigen::Matrix3f m = color.rec709_from_camera.cast<float>();
  float* values = albedo->data();
  for (size_t i = 0; i < solved.num_pixels(); ++i) {
    if (solved.data()[i] == 0) continue;
    Eigen::Map<Eigen::Vector3f> rgb(values + 3 * i);
    rgb = m * Eigen::Vector3f(rgb);
  }
}

std::string AlbedoColor::ReportJson() const {
  nlohmann::json report;
  report["color_space"] = color_space;
  report["source"] = AlbedoColorSourceName(source);
  report["description"] = description;
  report["rec709_from_camera"] = MatrixJson(rec709_from_camera);
  report["scale"] = scale;
  report["scale_source"] = scale_source;
  if (chart_mean_delta_e) report["chart_mean_delta_e"] = *chart_mean_delta_e;
  if (chart_max_delta_e) report["chart_max_delta_e"] = *chart_max_delta_e;
  return report.dump();
}

namespace {

double Median(std::vector<float>& values) {
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  return values[mid];
}

// The ColorChecker patch whose reference the truth holds (float precision), if any.
const ColorCheckerPatch* MatchingPatch(const Eigen::Vector3d& truth) {
  for (const ColorCheckerPatch& patch : ColorCheckerClassic()) {
    if ((patch.linear_rec709 - truth).cwiseAbs().maxCoeff() < 1e-5) return &patch;
  }
  return nullptr;
}

}  // namespace

AlbedoColorErrors CompareAlbedoColor(const ImageF& albedo_linear_rec709, const ImageF& truth_linear_rec709,
                                     const ImageU8& mask, double min_region_fraction) {
  AlbedoColorComparison comparison(min_region_fraction);
  comparison.AddRows(albedo_linear_rec709, mask, truth_linear_rec709);
  return comparison.Finish();
}

namespace {

constexpr int kRegionBucketBits = 20;  // 4 MB of counts

static_assert(sizeof(ComparedAlbedoPixel) == 24);

// The truth's bits: equal values -- a chart's patches -- are the regions.
std::array<uint32_t, 3> TruthBits(const ComparedAlbedoPixel& pixel) {
  return std::bit_cast<std::array<uint32_t, 3>>(pixel.truth_linear_rec709);
}

uint32_t RegionBucket(const std::array<uint32_t, 3>& bits) {
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (const uint32_t b : bits) {
    h ^= b;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 31;
  }
  return static_cast<uint32_t>(h >> (64 - kRegionBucketBits));
}

}  // namespace

AlbedoColorComparison::AlbedoColorComparison(double min_region_fraction, const std::filesystem::path& spill_folder)
    : min_region_fraction_(min_region_fraction),
      pixels_(spill_folder),
      bucket_counts_(size_t{1} << kRegionBucketBits, 0) {}

void AlbedoColorComparison::CountPossibleRegions(const ImageF& truth_rows, const ImageU8& mask_rows) {
  if (truth_rows.channels() != 3 || mask_rows.channels() != 1 || !truth_rows.SameSize(mask_rows) || width_ >= 0) {
    throw std::invalid_argument("AlbedoColorComparison::CountPossibleRegions: truth " + ShapeText(truth_rows) +
                                " and mask " + ShapeText(mask_rows) +
                                " must be 3 and 1 channels of one size, before any AddRows");
  }
  if (possible_counts_.empty()) possible_counts_.assign(size_t{1} << kRegionBucketBits, 0);
  ComparedAlbedoPixel pixel{};
  for (int y = 0; y < truth_rows.height(); ++y) {
    const uint8_t* mask = mask_rows.row(y);
    const float* truth = truth_rows.row(y);
    for (int x = 0; x < truth_rows.width(); ++x) {
      if (mask[x] == 0) continue;
      std::copy_n(truth + 3 * static_cast<size_t>(x), 3, pixel.truth_linear_rec709);
      ++possible_counts_[RegionBucket(TruthBits(pixel))];
    }
  }
}

void AlbedoColorComparison::AddRows(const ImageF& albedo_rows, const ImageU8& mask_rows, const ImageF& truth_rows,
                                    int num_threads) {
  if (albedo_rows.channels() != 3 || truth_rows.channels() != 3 || mask_rows.channels() != 1 ||
      !albedo_rows.SameSize(truth_rows) || !albedo_rows.SameSize(mask_rows) ||
      (width_ >= 0 && albedo_rows.width() != width_)) {
    throw std::invalid_argument("CompareAlbedoColor: albedo " + ShapeText(albedo_rows) + ", truth " +
                                ShapeText(truth_rows) + " and mask " + ShapeText(mask_rows) +
                                " must be 3, 3 and 1 channels of one size (every band as wide as the first)");
  }
  width_ = albedo_rows.width();
  if (!possible_counts_.empty()) {
    // The smallest region Finish accepts has 16 pixels (min_pixels).
    possible_.resize(possible_counts_.size());
    for (size_t b = 0; b < possible_counts_.size(); ++b) possible_[b] = possible_counts_[b] >= 16;
    possible_counts_ = {};
  }
  // Per row, into its own stretch of the band's buffer: the evaluated
  // pixels' truth, albedo and CIEDE2000 (the costly part, so in parallel);
  // then, in pixel order, the counts, the statistics and the spill.
  const int width = albedo_rows.width(), rows = truth_rows.height();
  band_pixels_.resize(static_cast<size_t>(width) * rows);
  band_delta_e_.resize(static_cast<size_t>(width) * rows);
  band_buckets_.resize(static_cast<size_t>(width) * rows);
  band_row_counts_.assign(rows, 0);
  band_spilled_counts_.assign(rows, 0);
  ParallelRows(rows, num_threads, {}, 0, 1, [&](int r) {
    // A row's evaluated albedos, truths and CIEDE2000s, packed: the pool's
    // threads keep theirs from row to row.
    thread_local std::vector<float> colours;
    colours.resize(6 * static_cast<size_t>(width));
    const uint8_t* mask = mask_rows.row(r);
    const size_t first = static_cast<size_t>(r) * width;
    float* albedo = colours.data();
    float* truth = albedo + 3 * static_cast<size_t>(width);
    uint32_t count = 0;
    for (int x = 0; x < width; ++x) {
      if (mask[x] == 0) continue;
      std::copy_n(albedo_rows.row(r) + 3 * static_cast<size_t>(x), 3, albedo + 3 * count);
      std::copy_n(truth_rows.row(r) + 3 * static_cast<size_t>(x), 3, truth + 3 * count);
      ++count;
    }
    // The many-pairs form in vector lanes: one per sample pixel (16 M at
    // full size); within 1e-10 of the published formula, 1e-5 where a colour
    // is neutral.
    Ciede2000FromLinearRec709(albedo, truth, count, band_delta_e_.data() + first);
    ComparedAlbedoPixel* out = band_pixels_.data() + first;
    uint32_t* buckets = band_buckets_.data() + first;
    // The records to spill first in the row's stretch (all of them unless
    // CountPossibleRegions said which buckets can hold a region).
    uint32_t spilled = 0;
    for (uint32_t i = 0; i < count; ++i) {
      ComparedAlbedoPixel pixel;
      std::copy_n(truth + 3 * i, 3, pixel.truth_linear_rec709);
      std::copy_n(albedo + 3 * i, 3, pixel.albedo_linear_rec709);
      buckets[i] = RegionBucket(TruthBits(pixel));
      out[spilled] = pixel;
      spilled += possible_.empty() || possible_[buckets[i]] != 0 ? 1 : 0;
    }
    band_row_counts_[r] = count;
    band_spilled_counts_[r] = spilled;
  });
  for (int r = 0; r < rows; ++r) {
    const size_t first = static_cast<size_t>(r) * width;
    const ComparedAlbedoPixel* row = band_pixels_.data() + first;
    // The counts (4 MB) are hit at random: fetched a few pixels ahead.
    const uint32_t* buckets = band_buckets_.data() + first;
    const uint32_t count = band_row_counts_[r];
    constexpr uint32_t kAhead = 16;
    for (uint32_t i = 0; i < count; ++i) {
      if (i + kAhead < count) __builtin_prefetch(&bucket_counts_[buckets[i + kAhead]], 1);
      ++bucket_counts_[buckets[i]];
    }
    delta_e_.Add(std::span<const double>(band_delta_e_.data() + first, band_row_counts_[r]));
    pixels_.Append(row, band_spilled_counts_[r] * sizeof(ComparedAlbedoPixel));
  }
  // Nothing left buffered: ForEachPixel only reads, so Finish and a replay
  // of the pixels (the albedo's errors) may run at once.
  pixels_.Flush();
}

void AlbedoColorComparison::ForEachPixel(const std::function<void(std::span<const ComparedAlbedoPixel>)>& visit) {
  std::vector<ComparedAlbedoPixel> pixels;
  pixels_.ForEachRecord(sizeof(ComparedAlbedoPixel), [&](const uint8_t* records, size_t count) {
    pixels.resize(count);  // the spill's chunk, aligned
    std::memcpy(pixels.data(), records, count * sizeof(ComparedAlbedoPixel));
    visit(pixels);
  });
}

AlbedoColorErrors AlbedoColorComparison::Finish() {
  AlbedoColorErrors errors;
  const size_t evaluated = delta_e_.count();
  errors.delta_e = delta_e_.Finish();
  const size_t min_pixels = std::max<size_t>(16, static_cast<size_t>(min_region_fraction_ * evaluated));
  // A region's pixels all fall in its bucket: only the buckets with at least
  // min_pixels can hold one, and only their pixels' values are counted.
  std::vector<uint8_t> heavy(bucket_counts_.size(), 0);
  bool any_heavy = false;
  for (size_t b = 0; b < bucket_counts_.size(); ++b) {
    heavy[b] = bucket_counts_[b] >= min_pixels;
    any_heavy |= heavy[b] != 0;
  }
  bucket_counts_ = {};
  if (!any_heavy) return errors;
  std::map<std::array<uint32_t, 3>, size_t> counts;  // sorted by truth bits, as the regions were found before
  ForEachPixel([&](std::span<const ComparedAlbedoPixel> pixels) {
    for (const ComparedAlbedoPixel& pixel : pixels) {
      const std::array<uint32_t, 3> bits = TruthBits(pixel);
      if (heavy[RegionBucket(bits)]) ++counts[bits];
    }
  });
  struct Region {
    std::array<uint32_t, 3> truth_bits;
    size_t pixels = 0;
    Eigen::Vector3d median_albedo = Eigen::Vector3d::Zero();
  };
  std::vector<Region> found;
  std::map<std::array<uint32_t, 3>, size_t> region_of;  // truth bits -> index in found
  for (const auto& [bits, count] : counts) {
    if (count < min_pixels) continue;
    region_of[bits] = found.size();
    found.push_back({bits, count});
  }
  // A textile's truth varies from pixel to pixel: one big region is just its
  // background, not a chart.
  if (found.size() < 2) return errors;
  // Each region's median albedo, a channel at a time (4 bytes a region pixel held).
  for (int c = 0; c < 3; ++c) {
    std::vector<std::vector<float>> channel(found.size());
    for (size_t r = 0; r < found.size(); ++r) channel[r].reserve(found[r].pixels);
    ForEachPixel([&](std::span<const ComparedAlbedoPixel> pixels) {
      for (const ComparedAlbedoPixel& pixel : pixels) {
        const std::array<uint32_t, 3> bits = TruthBits(pixel);
        if (!heavy[RegionBucket(bits)]) continue;
        const auto at = region_of.find(bits);
        if (at != region_of.end()) channel[at->second].push_back(pixel.albedo_linear_rec709[c]);
      }
    });
    for (size_t r = 0; r < found.size(); ++r) found[r].median_albedo[c] = Median(channel[r]);
  }
  std::vector<const Region*> regions;
  for (const Region& region : found) regions.push_back(&region);
  std::sort(regions.begin(), regions.end(), [](auto* a, auto* b) { return a->pixels > b->pixels; });
  double sum = 0;
  for (size_t r = 0; r < regions.size(); ++r) {
    AlbedoRegionError region;
    float t[3];
    std::memcpy(t, regions[r]->truth_bits.data(), sizeof(t));
    region.truth_linear_rec709 = Eigen::Vector3d(t[0], t[1], t[2]);
    region.solved_linear_rec709 = regions[r]->median_albedo;
    region.delta_e = Ciede2000(LabFromLinearRec709(region.solved_linear_rec709),
                               LabFromLinearRec709(region.truth_linear_rec709));
    region.pixels = regions[r]->pixels;
    const ColorCheckerPatch* patch = MatchingPatch(region.truth_linear_rec709);
    region.chart_patch = patch != nullptr;
    region.name = patch ? patch->name : "region " + std::to_string(r + 1);
    if (patch) {
      ++errors.chart_patches;
      errors.chart_mean_delta_e += region.delta_e;
      errors.chart_max_delta_e = std::max(errors.chart_max_delta_e, region.delta_e);
    }
    sum += region.delta_e;
    errors.region_max_delta_e = std::max(errors.region_max_delta_e, region.delta_e);
    errors.regions.push_back(region);
  }
  errors.region_mean_delta_e = sum / errors.regions.size();
  if (errors.chart_patches > 0) errors.chart_mean_delta_e /= errors.chart_patches;
  return errors;
}

std::string AlbedoColorErrors::ReportJson() const {
  nlohmann::json report;
  report["delta_e_2000_per_pixel"] = {{"mean", delta_e.mean},
                                      {"median", delta_e.median},
                                      {"p95", delta_e.percentile_95},
                                      {"max", delta_e.max},
                                      {"pixels", delta_e.num_pixels}};
  if (!regions.empty()) {
    nlohmann::json list = nlohmann::json::array();
    for (const AlbedoRegionError& r : regions) {
      list.push_back({{"name", r.name},
                      {"chart_patch", r.chart_patch},
                      {"truth_linear_rec709", {r.truth_linear_rec709[0], r.truth_linear_rec709[1], r.truth_linear_rec709[2]}},
                      {"solved_linear_rec709",
                       {r.solved_linear_rec709[0], r.solved_linear_rec709[1], r.solved_linear_rec709[2]}},
                      {"delta_e_2000", r.delta_e},
                      {"pixels", r.pixels}});
    }
    report["regions"] = list;
    report["region_mean_delta_e_2000"] = region_mean_delta_e;
    report["region_max_delta_e_2000"] = region_max_delta_e;
    report["chart_patches"] = chart_patches;
    report["chart_mean_delta_e_2000"] = chart_mean_delta_e;
    report["chart_max_delta_e_2000"] = chart_max_delta_e;
  }
  return report.dump();
}

}  // namespace scanbench
