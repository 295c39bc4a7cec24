#include "app/io/result_maps.h"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <future>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "calibration/color_science.h"
#include "core/format.h"
#include "core/parallel_for.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// lround((clamp((n + 1) / 2, 0, 1)) * 65535) in double, as
// floor(x + 0.5) so that the loop vectorises (lround is a libm call per
// sample): the same codes. x = fl(value * 65535) is at least 0; floor(x +
// 0.5) could differ from lround(x) only where x + 0.5 is not a double and
// rounds up onto an integer, which needs x = 0.5 - 2^-54 exactly; x is
// value * 65535 with value = fl(float + 1) / 2, a multiple of 2^-25 wherever
// it is below 0.5 (tested against lround over floats near -1, 0 and 1 and
// random ones).
void EncodeNormalsPng16(const ImageF& normal_in_tangent, ImageU16* out) {
  out->Reshape(normal_in_tangent.width(), normal_in_tangent.height(), 3);
  ImageU16& encoded = *out;
  const float* in = normal_in_tangent.data();
  uint16_t* codes = encoded.data();
  for (size_t i = 0; i < encoded.size(); ++i) {
    const double value = std::clamp((double(in[i]) + 1.0) * 0.5, 0.0, 1.0);
    codes[i] = static_cast<uint16_t>(static_cast<int32_t>(value * 65535.0 + 0.5));
  }
}

// SrgbQuantizer::Of(8)'s codes by a table: the code at each "node" (the
// floats that share their top 16 bits, 128 a binary octave) and the lowest
// float of every code. Within a node in (0, 1) the code rises by at most one
// (a node spans at most 1/128 of its value, the curve's 8-bit code at most
// 0.87 of a step there), so a value's code is its node's, or one more where
// it reaches the next code's lowest float: two loads and a comparison
// instead of the quantizer's interpolated guess and two search loops. Made
// from the quantizer itself, so the same codes (checked when it is built,
// and by the tests over every code's edges).
class SrgbPreviewTable {
 public:
  SrgbPreviewTable() {
    const SrgbQuantizer& quantizer = SrgbQuantizer::Of(8);
    const auto code = [&](uint32_t bits) { return static_cast<int>(quantizer(std::bit_cast<float>(bits))); };
    for (uint32_t node = 0; node < kNodes; ++node) {
      node_code_[node] = static_cast<uint8_t>(code(node << 16));
      if (code(((node + 1) << 16) - 1) > node_code_[node] + 1) {
        throw std::logic_error("SrgbPreviewTable: more than one code change within a node");
      }
    }
    lowest_.fill(std::numeric_limits<float>::infinity());  // lowest_[256]: never reached
    for (int k = 1; k <= 255; ++k) {
      uint32_t below = 0, reaches = kOneBits;  // code(below) < k <= code(reaches)
      while (reaches - below > 1) {
        const uint32_t middle = below + (reaches - below) / 2;
        (code(middle) >= k ? reaches : below) = middle;
      }
      lowest_[k] = std::bit_cast<float>(reaches);
    }
    lowest_[0] = 0;
  }

  uint8_t operator()(float linear) const {
    if (!(linear > 0)) return 0;  // also NaN
    if (linear >= 1) return 255;
    const int code = node_code_[std::bit_cast<uint32_t>(linear) >> 16];
    return static_cast<uint8_t>(code + (linear >= lowest_[code + 1]));
  }

 private:
  static constexpr uint32_t kOneBits = 0x3F800000;  // 1.0f
  static constexpr uint32_t kNodes = kOneBits >> 16;
  std::array<uint8_t, kNodes> node_code_{};
  std::array<float, 257> lowest_{};
};

const SrgbPreviewTable& PreviewTable() {
  static const SrgbPreviewTable table;
  return table;
}

void EncodeSrgbPreview(const ImageF& linear_rgb, ImageU8* out) {
  out->Reshape(linear_rgb.width(), linear_rgb.height(), linear_rgb.channels());
  ImageU8& encoded = *out;
  const SrgbPreviewTable& table = PreviewTable();
  const float* in = linear_rgb.data();
  uint8_t* codes = encoded.data();
  for (size_t i = 0; i < encoded.size(); ++i) codes[i] = table(in[i]);
}

}  // namespace

ImageU16 EncodeNormalsPng16(const ImageF& normal_in_tangent) {
  ImageU16 encoded;
  EncodeNormalsPng16(normal_in_tangent, &encoded);
  return encoded;
}

uint8_t SrgbPreviewCode(float linear) {
  // lround(SrgbEncode(v) * 255) without a pow per sample (48 M of them at 16 MP).
  return PreviewTable()(linear);
}

ImageU8 EncodeSrgbPreview(const ImageF& linear_rgb) {
  ImageU8 encoded;
  EncodeSrgbPreview(linear_rgb, &encoded);
  return encoded;
}

ImageMetadata AlbedoMetadata(const AlbedoColor& albedo_color, const std::string& color_space) {
  ImageMetadata metadata;
  metadata.color_space = color_space;
  metadata.description = albedo_color.IsLinearRec709()
                             ? "diffuse albedo, linear Rec.709 primaries, D65 white (" + albedo_color.scale + ")"
                             : "diffuse albedo, white-balanced camera RGB: not colour calibrated (" +
                                   albedo_color.scale + ")";
  if (color_space == "sRGB") metadata.description += ", sRGB transfer curve";
  metadata.attributes["scanbench:albedo_color_space"] = albedo_color.color_space;
  metadata.attributes["scanbench:albedo_scale"] = albedo_color.scale;
  metadata.attributes["scanbench:albedo_color_source"] = AlbedoColorSourceName(albedo_color.source);
  if (albedo_color.IsLinearRec709()) {
    const Chromaticities c = Rec709Chromaticities();
    metadata.chromaticities =
        ImageChromaticities{c.red_x, c.red_y, c.green_x, c.green_y, c.blue_x, c.blue_y, c.white_x, c.white_y};
  }
  return metadata;
}

namespace {

// Measured at 16 MP (docs/session-format.md, "Result map encoding").
// piz: with the normals on their grid the smallest of the quick ones (zip
// is 8 % larger and twice as slow to write).
constexpr ExrCompression kResultMapHalfCompression = ExrCompression::kPiz;
// normal.png and albedo_srgb.png: paeth with zlib's run-length strategy
// (docs/export.md, "File encodings": the export's own normal map
// 62.5 MB in 1.45 s against 66.2 MB in 2.66 s with libpng's adaptive filter;
// the 8-bit sRGB preview 13.3 MB in 0.69 s against 16.4 MB in 0.87 s).
constexpr PngEncoding kNormalPngEncoding{1, PngFilter::kPaeth, PngStrategy::kRle};
constexpr PngEncoding kPreviewPngEncoding{1, PngFilter::kPaeth, PngStrategy::kRle};

// normal.exr's components on an absolute 2^-12 grid below 0.25 (half's own
// step from there to 0.5): a tilted normal's small components otherwise
// carry noise in their low mantissa bits, which compresses worst. The
// direction moves by at most sqrt(3) 2^-12 rad = 0.024 deg, as with half alone.
ExrEncoding NormalMapExrEncoding(const ExrEncoding& exr) {
  ExrEncoding normal = exr;
  if (exr.sample_type == ExrSampleType::kHalf) normal.half_absolute_step = std::ldexp(1.0, -12);
  return normal;
}

// confidence.exr's residual channel in half: 8 significant bits (a relative
// step of 2^-7, rounding by at most 0.4 %) instead of half's 11. Its low
// bits are noise that cost the lossless compressor a quarter of the file
// (measured at 16 MP: 26.1 -> 19.6 MB; docs/session-format.md, "Result map
// encoding"); a residual is read as a size, never to three digits.
constexpr int kResidualSignificantBits = 8;
// angular_error_deg.exr in half: on an absolute grid of 2^-9 deg (rounding by
// at most 0.001 deg, a 200th of the solver's mean error) below 2 deg, where
// half's own step is finer; half's own step (2^-9 deg and up) above.
// Measured at 16 MP: 18.3 -> 12.2 MB.
constexpr double kErrorMapHalfStepDeg = 1.0 / 512;

// `value` rounded to `bits` (1 to 24) significant bits (to nearest, ties to
// even); zero and non-finite values as they are. A normal float's low 24 -
// bits significand bits are rounded away in its bit pattern (a carry into the
// exponent is the next power of two, an overflow infinity, as the libm form
// gives); zero, subnormal and non-finite values take the libm form
// (frexp, nearbyint, ldexp: two scalbnf calls per value were 3 % of the
// result writing's CPU).
float RoundToSignificantBits(float value, int bits) {
  uint32_t pattern = std::bit_cast<uint32_t>(value);
  const uint32_t biased_exponent = (pattern >> 23) & 0xFF;
  if (biased_exponent == 0 || biased_exponent == 0xFF) {
    if (value == 0 || !std::isfinite(value)) return value;
    int exponent = 0;
    const float mantissa = std::frexp(value, &exponent);  // [0.5, 1)
    return std::ldexp(std::nearbyint(std::ldexp(mantissa, bits)), exponent - bits);
  }
  const int dropped = 24 - bits;
  if (dropped <= 0) return value;
  const uint32_t lsb = (pattern >> dropped) & 1;
  pattern = (pattern + (1u << (dropped - 1)) - 1 + lsb) & ~((1u << dropped) - 1);
  return std::bit_cast<float>(pattern);
}

void CheckSpecularShape(const PhotometricSolution& solution) {
  const ImageU8& status = solution.status;
  if (!solution.specular.SameSize(status) || solution.specular.channels() != 2) {
    throw std::invalid_argument("PhotometricSolution.specular is " + ShapeText(solution.specular) + ", must be " +
                                SizeText(status.width(), status.height()) + "x2 (specular_f0, roughness_alpha)");
  }
  if (!solution.specular_status.SameSize(status) || solution.specular_status.channels() != 1) {
    throw std::invalid_argument("PhotometricSolution.specular_status is " + ShapeText(solution.specular_status) +
                                ", must be " + SizeText(status.width(), status.height()) + "x1");
  }
}

bool IsSpecularUnsupported(const PhotometricSolution& solution, size_t i) {
  return solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved) &&
         solution.specular_status.data()[i] == static_cast<uint8_t>(SpecularStatus::kUnsupported);
}

// specular.exr's pixels: both channels 0 wherever the lobe is not estimated,
// and a non-finite value (never expected from the solver) as 0, so that no
// NaN reaches the file and roughness_alpha > 0 alone marks an estimate.
void SpecularForFile(const PhotometricSolution& solution, ImageF* file) {
  file->Reshape(solution.specular.width(), solution.specular.height(), 2);
  ImageF& out = *file;
  for (size_t i = 0; i < out.num_pixels(); ++i) {
    const bool estimated = solution.specular_status.data()[i] == static_cast<uint8_t>(SpecularStatus::kEstimated) &&
                           solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    const float f0 = solution.specular.data()[2 * i], alpha = solution.specular.data()[2 * i + 1];
    const bool usable = estimated && std::isfinite(f0) && std::isfinite(alpha) && alpha > 0;
    out.data()[2 * i] = usable ? std::clamp(f0, 0.0f, 1.0f) : 0.0f;
    out.data()[2 * i + 1] = usable ? std::min(alpha, 1.0f) : 0.0f;
  }
}

}  // namespace

namespace {

void StatusPngCodes(const PhotometricSolution& solution, ImageU8* out) {
  const ImageU8& status = solution.status;
  out->Reshape(status.width(), status.height(), status.channels());
  ImageU8& codes = *out;
  std::copy(status.data(), status.data() + status.size(), codes.data());
  if (solution.specular.empty()) return;
  CheckSpecularShape(solution);
  for (size_t i = 0; i < codes.num_pixels(); ++i) {
    if (IsSpecularUnsupported(solution, i)) codes.data()[i] = kStatusSolvedSpecularUnsupported;
  }
}

}  // namespace

ImageU8 StatusPngCodes(const PhotometricSolution& solution) {
  ImageU8 codes;
  StatusPngCodes(solution, &codes);
  return codes;
}

void SpecularMapTally::Add(const PhotometricSolution& band) {
  if (band.specular.empty()) {
    if (any_specular_) throw std::invalid_argument("SpecularMapTally: a band without specular maps after one with");
    without_specular_ = true;
    return;
  }
  if (without_specular_) throw std::invalid_argument("SpecularMapTally: a band with specular maps after one without");
  CheckSpecularShape(band);
  any_specular_ = true;
  for (size_t i = 0; i < band.specular_status.num_pixels(); ++i) {
    const int code = std::min<int>(band.specular_status.data()[i], kNumSpecularStatuses - 1);
    ++stats_.pixels_by_status[code];
    if (code == static_cast<int>(SpecularStatus::kEstimated)) {
      const double f0 = band.specular.data()[2 * i], alpha = band.specular.data()[2 * i + 1];
      if (std::isfinite(f0)) f0_sum_ += f0;
      if (std::isfinite(alpha)) alpha_sum_ += alpha;
    }
  }
}

std::optional<SpecularMapStatistics> SpecularMapTally::Finish() const {
  if (!any_specular_) return std::nullopt;
  SpecularMapStatistics stats = stats_;
  if (stats.estimated() > 0) {
    stats.mean_specular_f0 = f0_sum_ / stats.estimated();
    stats.mean_roughness_alpha = alpha_sum_ / stats.estimated();
  }
  return stats;
}

std::optional<SpecularMapStatistics> SpecularMapStatisticsOf(const PhotometricSolution& solution) {
  SpecularMapTally tally;
  tally.Add(solution);
  return tally.Finish();
}

std::string SpecularMapStatistics::ReportJson() const {
  nlohmann::json by_status;
  for (int s = 0; s < kNumSpecularStatuses; ++s) {
    by_status[SpecularStatusName(static_cast<SpecularStatus>(s))] = pixels_by_status[s];
  }
  const nlohmann::json json = {{"file", "specular.exr"},
                               {"channels", {"specular_f0", "roughness_alpha"}},
                               {"pixels_by_status", by_status},
                               {"mean_specular_f0", mean_specular_f0},
                               {"mean_roughness_alpha", mean_roughness_alpha},
                               {"means_over", "estimated pixels"},
                               {"status_png_code_unsupported", kStatusSolvedSpecularUnsupported}};
  return json.dump();
}

std::string SpecularMapStatistics::BriefReport() const {
  return "specular map: " + std::to_string(estimated()) + " estimated, " +
         std::to_string(pixels_by_status[static_cast<int>(SpecularStatus::kUnsupported)]) + " unsupported, " +
         std::to_string(pixels_by_status[static_cast<int>(SpecularStatus::kNotSolved)]) +
         " not solved; mean F0 " + Fixed(mean_specular_f0, 3) + ", mean GGX alpha " +
         Fixed(mean_roughness_alpha, 3) + " (specular.exr; status.png 7 = unsupported)";
}

ExrEncoding ResultMapExrEncoding(bool float32_maps) {
  if (float32_maps) return {ExrSampleType::kFloat32, ExrCompression::kZip};
  return {ExrSampleType::kHalf, kResultMapHalfCompression};
}

std::map<std::string, uintmax_t> FileSizesIn(const std::filesystem::path& folder) {
  std::map<std::string, uintmax_t> sizes;
  for (const std::filesystem::directory_entry& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.is_regular_file()) sizes[entry.path().filename().string()] = entry.file_size();
  }
  return sizes;
}

namespace {

// angular_error_deg.exr: in half on the grid of kErrorMapHalfStepDeg (0.06 deg steps at 90 deg).
ExrEncoding ErrorMapExrEncoding(const ExrEncoding& exr) {
  ExrEncoding error_map = exr;
  if (exr.sample_type == ExrSampleType::kHalf) error_map.half_absolute_step = kErrorMapHalfStepDeg;
  return error_map;
}

void SolvedMask(const PhotometricSolution& solution, ImageU8* out) {
  out->Reshape(solution.status.width(), solution.status.height(), 1);
  ImageU8& solved = *out;
  for (size_t i = 0; i < solved.size(); ++i) {
    solved.data()[i] = solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved) ? 255 : 0;
  }
}

void ConfidenceForFile(const PhotometricSolution& solution, bool half, ImageF* out) {
  out->Reshape(solution.status.width(), solution.status.height(), 3);
  ImageF& confidence = *out;
  for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
    const float residual = solution.residual.data()[i];
    confidence.data()[3 * i + 0] = solution.lights_used.data()[i];
    confidence.data()[3 * i + 1] = solution.condition_number.data()[i];
    confidence.data()[3 * i + 2] = half ? RoundToSignificantBits(residual, kResidualSignificantBits) : residual;
  }
}

void CheckThreads(int threads) {
  if (threads < 0) throw std::invalid_argument("WriteSolutionMaps: threads = " + std::to_string(threads) + " must be >= 0");
}

}  // namespace

// A band's rows as one file stores them, kept from band to band (the buffer
// of the type the file takes).
struct BandRows {
  ImageU16 u16;
  ImageU8 u8;
  ImageF f;
};

// One result file: its report.json kind, its name, its row writer and how a
// band of the solution becomes its rows (in `rows` where they need making).
struct SolutionMapStream::Map {
  const char* kind;
  const char* name;
  ImageRowWriter writer;
  std::function<void(const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows)> add;
  BandRows rows{};
};

SolutionMapStream::SolutionMapStream(const std::filesystem::path& folder, int width, int height, bool with_specular,
                                     bool with_error_map, bool with_learned_error, const AlbedoColor& albedo_color,
                                     const ExrEncoding& exr)
    : width_(width), height_(height), with_specular_(with_specular), with_learned_error_(with_learned_error) {
  const auto policy = OverwritePolicy::kRefuse;
  const auto path = [&](const char* name) { return folder / name; };
  const bool half = exr.sample_type == ExrSampleType::kHalf;
  // Slowest first (measured at 16 MP), so that no long file starts last
  // within a band while the other threads idle.
  maps_.push_back({"normal_png16_opengl", "normal.png",
                   ImageRowWriter::Png(path("normal.png"), width, height, 3, 16, policy, {}, kNormalPngEncoding),
                   [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows) {
                     EncodeNormalsPng16(band.normal_in_table, &rows.u16);
                     writer.WriteRows(rows.u16);
                   }});
  maps_.push_back({"normal_exr", "normal.exr",
                   ImageRowWriter::Exr(path("normal.exr"), width, height, 3, policy, {}, {}, NormalMapExrEncoding(exr)),
                   [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows&) {
                     writer.WriteRows(band.normal_in_table);
                   }});
  maps_.push_back({"albedo_exr", "albedo.exr",
                   ImageRowWriter::Exr(path("albedo.exr"), width, height, 3, policy, {},
                                       AlbedoMetadata(albedo_color, "Linear"), exr),
                   [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows&) { writer.WriteRows(band.albedo); }});
  maps_.push_back({"confidence", "confidence.exr",
                   ImageRowWriter::Exr(path("confidence.exr"), width, height, 3, policy,
                                       ConfidenceChannelNames(), {}, exr),
                   [half](const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows) {
                     ConfidenceForFile(band, half, &rows.f);
                     writer.WriteRows(rows.f);
                   }});
  if (with_error_map) {
    error_map_ = std::make_unique<ImageRowWriter>(ImageRowWriter::Exr(path("angular_error_deg.exr"), width, height, 1,
                                                                      policy, {"Y"}, {}, ErrorMapExrEncoding(exr)));
  }
  maps_.push_back({"albedo_srgb_preview", "albedo_srgb.png",
                   ImageRowWriter::Png(path("albedo_srgb.png"), width, height, 3, 8, policy,
                                       AlbedoMetadata(albedo_color, "sRGB"), kPreviewPngEncoding),
                   [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows) {
                     EncodeSrgbPreview(band.albedo, &rows.u8);
                     writer.WriteRows(rows.u8);
                   }});
  if (with_specular) {
    ImageMetadata metadata;
    metadata.description =
        "specular lobe: specular_f0 (white reflectance at normal incidence, [0, 1]) and "
        "roughness_alpha (GGX alpha, (0, 1]); both 0 where not estimated";
    maps_.push_back({"specular_exr", "specular.exr",
                     ImageRowWriter::Exr(path("specular.exr"), width, height, 2, policy,
                                         {"specular_f0", "roughness_alpha"}, metadata, exr),
                     [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows) {
                       SpecularForFile(band, &rows.f);
                       writer.WriteRows(rows.f);
                     }});
  }
  if (with_learned_error) {
    ImageMetadata metadata;
    metadata.description =
        "the learned normal network's own expected angular error (deg, from its von Mises-Fisher "
        "concentration) where the pixel's normal is the network's (solve path learned); 0 elsewhere";
    maps_.push_back({"learned_error_deg", "learned_error_deg.exr",
                     ImageRowWriter::Exr(path("learned_error_deg.exr"), width, height, 1, policy, {"Y"}, metadata,
                                         ErrorMapExrEncoding(exr)),
                     [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows&) {
                       writer.WriteRows(band.learned_error_deg);
                     }});
  }
  maps_.push_back({"status", "status.png", ImageRowWriter::Png(path("status.png"), width, height, 1, 8, policy),
                   [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows) {
                     StatusPngCodes(band, &rows.u8);
                     writer.WriteRows(rows.u8);
                   }});
  maps_.push_back({"solved_mask", "solved_mask.png",
                   ImageRowWriter::Png(path("solved_mask.png"), width, height, 1, 8, policy),
                   [](const PhotometricSolution& band, ImageRowWriter& writer, BandRows& rows) {
                     SolvedMask(band, &rows.u8);
                     writer.WriteRows(rows.u8);
                   }});
}

SolutionMapStream::~SolutionMapStream() = default;

void SolutionMapStream::CheckBand(const PhotometricSolution& band) const {
  const ImageU8& status = band.status;
  const int rows = status.height();
  const bool fits = status.width() == width_ && rows >= 1 && rows <= height_ - rows_added_ && status.channels() == 1 &&
                    band.normal_in_table.SameSize(status) && band.normal_in_table.channels() == 3 &&
                    band.albedo.SameSize(status) && band.albedo.channels() == 3 && band.residual.SameSize(status) &&
                    band.lights_used.SameSize(status) && band.condition_number.SameSize(status) &&
                    band.specular.empty() != with_specular_ &&
                    (with_learned_error_ ? band.learned_error_deg.SameSize(status) && band.learned_error_deg.channels() == 1
                                         : band.learned_error_deg.empty());
  if (!fits) {
    throw std::invalid_argument("SolutionMapStream: a band of " + ShapeText(status) + " (normal " +
                                ShapeText(band.normal_in_table) + ", albedo " + ShapeText(band.albedo) +
                                (band.specular.empty() ? ", no specular" : ", specular") + ", learned error " +
                                ShapeText(band.learned_error_deg) + ") for maps of " + SizeText(width_, height_) +
                                (with_specular_ ? " with" : " without") + " specular.exr," +
                                (with_learned_error_ ? " with" : " without") + " learned_error_deg.exr, " +
                                std::to_string(rows_added_) + " rows added");
  }
  if (with_specular_) CheckSpecularShape(band);
}

void SolutionMapStream::AddBand(const PhotometricSolution& band, const std::function<ImageF()>& alongside,
                                int threads) {
  CheckThreads(threads);
  if (committed_) throw std::logic_error("SolutionMapStream::AddBand: already committed");
  CheckBand(band);
  if (error_map_ && !alongside) {
    throw std::invalid_argument("SolutionMapStream::AddBand: the stream has an error map; give its rows (alongside)");
  }
  const int rows = band.status.height();
  // Item 0 is `alongside` and then the error map's rows it made; the others
  // the files. Whichever thread is free takes the next item, so the files
  // fill the threads `alongside` leaves idle and the other way round.
  const int first = alongside ? 0 : 1;
  const auto start = std::chrono::steady_clock::now();
  ParallelFor(static_cast<int>(maps_.size()) + 1 - first, ResolveThreadCount(threads), 1,
              [&](int begin, int end, int) {
                for (int i = begin + first; i < end + first; ++i) {
                  if (i > 0) {
                    maps_[i - 1].add(band, maps_[i - 1].writer, maps_[i - 1].rows);
                    continue;
                  }
                  const ImageF error_rows = alongside();
                  alongside_seconds_ += SecondsSince(start);
                  if (!error_map_) continue;
                  if (!error_rows.SameSize(band.status) || error_rows.channels() != 1) {
                    throw std::invalid_argument("SolutionMapStream: the error map's rows are " +
                                                ShapeText(error_rows) + ", must be " +
                                                SizeText(band.status.width(), rows) + "x1");
                  }
                  error_map_->WriteRows(error_rows);
                }
              });  // rethrows a failure
  rows_added_ += rows;
}

std::map<std::string, std::string> SolutionMapStream::Commit() {
  if (committed_) throw std::logic_error("SolutionMapStream::Commit: already committed");
  if (rows_added_ != height_) {
    throw std::logic_error("SolutionMapStream::Commit: " + std::to_string(rows_added_) + " of " +
                           std::to_string(height_) + " rows added");
  }
  // Each file's close (its last chunks, OpenEXR's offset table), fsync and
  // rename on the pool, the fsyncs side by side rather than one after another.
  std::vector<ImageRowWriter*> writers;
  std::map<std::string, std::string> outputs;
  for (Map& map : maps_) {
    writers.push_back(&map.writer);
    outputs[map.kind] = map.name;
  }
  if (error_map_) {
    writers.push_back(error_map_.get());
    outputs["angular_error_deg"] = "angular_error_deg.exr";
  }
  ParallelFor(static_cast<int>(writers.size()), ResolveThreadCount(0), 1, [&](int begin, int end, int) {
    for (int i = begin; i < end; ++i) writers[i]->Commit();
  });  // rethrows a failure
  committed_ = true;
  return outputs;
}

std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution,
                                                     const AlbedoColor& albedo_color, const ExrEncoding& exr,
                                                     const ImageF& angular_error_deg, int threads) {
  CheckThreads(threads);
  if (!angular_error_deg.empty() && (!angular_error_deg.SameSize(solution.status) || angular_error_deg.channels() != 1)) {
    throw std::invalid_argument("WriteSolutionMaps: angular_error_deg is " + ShapeText(angular_error_deg) +
                                ", must be " + SizeText(solution.status.width(), solution.status.height()) + "x1");
  }
  if (!solution.specular.empty()) CheckSpecularShape(solution);
  // The whole solution as one band: the files are independent and written
  // concurrently on the one thread pool (compression dominates at 16 MP).
  SolutionMapStream stream(folder, solution.status.width(), solution.status.height(), !solution.specular.empty(),
                           !angular_error_deg.empty(), !solution.learned_error_deg.empty(), albedo_color, exr);
  stream.AddBand(solution, angular_error_deg.empty() ? std::function<ImageF()>() : [&] { return angular_error_deg; },
                 threads);
  return stream.Commit();
}

ResultAlbedoColor AlbedoColorOfReport(const std::string& report_json) {
  const nlohmann::json report = nlohmann::json::parse(report_json, nullptr, /*allow_exceptions=*/false);
  if (!report.is_object()) throw std::runtime_error("report.json: not a JSON object");
  ResultAlbedoColor color;
  if (!report.contains("color") || !report.at("color").is_object()) return color;
  const nlohmann::json& c = report.at("color");
  color.color_space = c.value("color_space", color.color_space);
  color.scale = c.value("scale", color.scale);
  color.description = c.value("description", color.description);
  color.scale_source = c.value("scale_source", color.scale_source);
  return color;
}

namespace {

std::runtime_error FileError(const fs::path& path, const std::string& problem) {
  return std::runtime_error(path.string() + ": " + problem);
}

// The position of channel `name` among a file's `names`; names the file and
// its channels when missing (`holds` says what the file should hold).
int ChannelOf(const fs::path& path, const std::vector<std::string>& names, const std::string& name,
              const std::string& holds) {
  const auto found = std::find(names.begin(), names.end(), name);
  if (found == names.end()) {
    std::string listed;
    for (const std::string& n : names) listed += (listed.empty() ? "" : ", ") + n;
    throw FileError(path, "has no channel '" + name + "' (channels: " + listed + "); " + holds);
  }
  return static_cast<int>(found - names.begin());
}

// A map as read: the expected channel count and size, every value finite
// (bad input must never turn into NaN downstream).
void CheckMap(const fs::path& path, const ImageF& image, int channels, int width, int height) {
  if (image.channels() != channels) {
    throw FileError(path, "has " + std::to_string(image.channels()) + " channels, " + std::to_string(channels) +
                              " expected");
  }
  if (width > 0 && !image.SameSize(width, height)) {
    throw FileError(path, "is " + ShapeText(image) + ", the session's images are " + std::to_string(width) + "x" +
                              std::to_string(height));
  }
  for (size_t i = 0; i < image.size(); ++i) {
    if (!std::isfinite(image.data()[i])) {
      const size_t pixel = i / channels;
      throw FileError(path, "pixel (" + std::to_string(pixel % image.width()) + ", " +
                                std::to_string(pixel / image.width()) + ") holds a non-finite value");
    }
  }
}

}  // namespace

const std::vector<std::string>& ConfidenceChannelNames() {
  static const std::vector<std::string> kNames = {"lights_used", "condition_number", "residual"};
  return kNames;
}

ImageF ReadGroundTruthMap(const fs::path& path, int channels, int width, int height) {
  ImageRowReader reader(path);  // names the file when missing or unreadable
  ImageF image;
  reader.ReadRows(0, reader.height(), &image);
  CheckMap(path, image, channels, width, height);
  return image;
}

ImageF ReadResultMap(const fs::path& path, int channels, int width, int height,
                     const std::vector<std::string>& channel_names) {
  std::vector<std::string> names;
  ImageF image = ReadImageFloat(path, &names);  // names the file when missing or unreadable
  CheckMap(path, image, channels, width, height);
  if (channel_names.empty()) return image;
  std::string holds = path.filename().string() + " holds";
  for (const std::string& name : channel_names) holds += " " + name;
  std::vector<int> source(channel_names.size());
  for (size_t c = 0; c < channel_names.size(); ++c) source[c] = ChannelOf(path, names, channel_names[c], holds);
  bool in_order = true;
  for (int c = 0; c < channels; ++c) in_order = in_order && source[c] == c;
  if (in_order) return image;
  // In place, a pixel at a time: a reordered copy would be another full-size
  // map at the moment the export's memory is highest.
  std::vector<float> pixel(channels);
  for (size_t i = 0; i < image.num_pixels(); ++i) {
    float* values = image.data() + i * channels;
    std::copy_n(values, channels, pixel.data());
    for (int c = 0; c < channels; ++c) values[c] = pixel[source[c]];
  }
  return image;
}

ImageF ReadSpecularAlpha(const fs::path& path, int width, int height) {
  std::vector<std::string> names;
  const ImageF specular = ReadImageFloat(path, &names);  // names the file when unreadable
  auto channel_of = [&](const std::string& name) {
    return ChannelOf(path, names, name, "specular.exr holds specular_f0 and roughness_alpha");
  };
  const int f0_channel = channel_of("specular_f0"), alpha_channel = channel_of("roughness_alpha");
  if (!specular.SameSize(width, height)) {
    throw FileError(path, "is " + ShapeText(specular) + ", the session's images are " + SizeText(width, height));
  }
  ImageF alpha(width, height, 1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (const auto& [channel, name] :
           {std::pair{f0_channel, "specular_f0"}, std::pair{alpha_channel, "roughness_alpha"}}) {
        const float value = specular(x, y, channel);
        if (!std::isfinite(value) || value < 0.0f || value > 1.0f) {
          throw FileError(path, std::string(name) + " at pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                    ") is " + std::to_string(value) + ", must be finite and in [0, 1]");
        }
      }
      alpha(x, y) = specular(x, y, alpha_channel);
    }
  }
  return alpha;
}

ImageU8 ReadBinaryMask(const fs::path& path, int width, int height) {
  const ImageU8 stored = ReadImageU8(path);
  if (!stored.SameSize(width, height)) {
    throw FileError(path, "is " + std::to_string(stored.width()) + "x" + std::to_string(stored.height()) +
                              ", the session's images are " + std::to_string(width) + "x" + std::to_string(height));
  }
  ImageU8 mask(width, height, 1);
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] = stored.data()[i * stored.channels()] > 127;
  return mask;
}

}  // namespace scanbench
