#include "app/controllers/map_writer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
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

ImageU16 EncodeNormalsPng16(const ImageF& normal_in_tangent) {
  ImageU16 encoded(normal_in_tangent.width(), normal_in_tangent.height(), 3);
  for (size_t i = 0; i < encoded.size(); ++i) {
    const double value = std::clamp((double(normal_in_tangent.data()[i]) + 1.0) * 0.5, 0.0, 1.0);
    encoded.data()[i] = static_cast<uint16_t>(std::lround(value * 65535.0));
  }
  return encoded;
}

uint8_t SrgbPreviewCode(float linear) {
  // lround(SrgbEncode(v) * 255) without a pow per sample (48 M of them at 16 MP).
  return static_cast<uint8_t>(SrgbQuantizer::Of(8)(linear));
}

ImageU8 EncodeSrgbPreview(const ImageF& linear_rgb) {
  ImageU8 encoded(linear_rgb.width(), linear_rgb.height(), linear_rgb.channels());
  for (size_t i = 0; i < encoded.size(); ++i) encoded.data()[i] = SrgbPreviewCode(linear_rgb.data()[i]);
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
// normal.png: paeth alone is within 0.1 % of libpng's adaptive choice in
// size and spends less CPU (the adaptive choice tries all five filters per row).
constexpr PngEncoding kNormalPngEncoding{1, PngFilter::kPaeth};

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

// `value` rounded to `bits` significant bits (to nearest, ties to even);
// zero and non-finite values as they are.
float RoundToSignificantBits(float value, int bits) {
  if (value == 0 || !std::isfinite(value)) return value;
  int exponent = 0;
  const float mantissa = std::frexp(value, &exponent);  // [0.5, 1)
  return std::ldexp(std::nearbyint(std::ldexp(mantissa, bits)), exponent - bits);
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
ImageF SpecularForFile(const PhotometricSolution& solution) {
  ImageF out(solution.specular.width(), solution.specular.height(), 2);
  for (size_t i = 0; i < out.num_pixels(); ++i) {
    const bool estimated = solution.specular_status.data()[i] == static_cast<uint8_t>(SpecularStatus::kEstimated) &&
                           solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    const float f0 = solution.specular.data()[2 * i], alpha = solution.specular.data()[2 * i + 1];
    const bool usable = estimated && std::isfinite(f0) && std::isfinite(alpha) && alpha > 0;
    out.data()[2 * i] = usable ? std::clamp(f0, 0.0f, 1.0f) : 0.0f;
    out.data()[2 * i + 1] = usable ? std::min(alpha, 1.0f) : 0.0f;
  }
  return out;
}

}  // namespace

ImageU8 StatusPngCodes(const PhotometricSolution& solution) {
  ImageU8 codes = solution.status;
  if (solution.specular.empty()) return codes;
  CheckSpecularShape(solution);
  for (size_t i = 0; i < codes.num_pixels(); ++i) {
    if (IsSpecularUnsupported(solution, i)) codes.data()[i] = kStatusSolvedSpecularUnsupported;
  }
  return codes;
}

std::optional<SpecularMapStatistics> SpecularMapStatisticsOf(const PhotometricSolution& solution) {
  if (solution.specular.empty()) return std::nullopt;
  CheckSpecularShape(solution);
  SpecularMapStatistics stats;
  double f0_sum = 0, alpha_sum = 0;
  for (size_t i = 0; i < solution.specular_status.num_pixels(); ++i) {
    const int code = std::min<int>(solution.specular_status.data()[i], kNumSpecularStatuses - 1);
    ++stats.pixels_by_status[code];
    if (code == static_cast<int>(SpecularStatus::kEstimated)) {
      const double f0 = solution.specular.data()[2 * i], alpha = solution.specular.data()[2 * i + 1];
      if (std::isfinite(f0)) f0_sum += f0;
      if (std::isfinite(alpha)) alpha_sum += alpha;
    }
  }
  if (stats.estimated() > 0) {
    stats.mean_specular_f0 = f0_sum / stats.estimated();
    stats.mean_roughness_alpha = alpha_sum / stats.estimated();
  }
  return stats;
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

// One result file: its report.json kind, its name, how it is written.
struct MapFile {
  const char* kind;
  const char* name;
  std::function<void(const std::filesystem::path&)> write;
};

void CheckErrorMap(const PhotometricSolution& solution, const ImageF& angular_error_deg) {
  if (!angular_error_deg.empty() && (!angular_error_deg.SameSize(solution.status) || angular_error_deg.channels() != 1)) {
    throw std::invalid_argument("WriteSolutionMaps: angular_error_deg is " + ShapeText(angular_error_deg) +
                                ", must be " + SizeText(solution.status.width(), solution.status.height()) + "x1");
  }
}

// angular_error_deg.exr: in half on the grid of kErrorMapHalfStepDeg (0.06 deg steps at 90 deg).
MapFile ErrorMapFile(const ImageF& angular_error_deg, const ExrEncoding& exr) {
  ExrEncoding error_map = exr;
  if (exr.sample_type == ExrSampleType::kHalf) error_map.half_absolute_step = kErrorMapHalfStepDeg;
  return {"angular_error_deg", "angular_error_deg.exr", [&angular_error_deg, error_map](const auto& path) {
            WriteExr(path, angular_error_deg, OverwritePolicy::kRefuse, {"Y"}, {}, error_map);
          }};
}

// The files of a solution but the error map, slowest first (measured at 16 MP),
// so that no long file starts last while the other threads idle. `solved` and
// `status_codes` are held by the caller while the files are written.
std::vector<MapFile> SolutionMapFiles(const PhotometricSolution& solution, const AlbedoColor& albedo_color,
                                      const ExrEncoding& exr, const ImageU8& solved, const ImageU8& status_codes) {
  const auto policy = OverwritePolicy::kRefuse;
  std::vector<MapFile> files = {
      {"normal_png16_opengl", "normal.png",
       [&, policy](const auto& path) {
         WritePng(path, EncodeNormalsPng16(solution.normal_in_table), policy, {}, kNormalPngEncoding);
       }},
      {"normal_exr", "normal.exr",
       [&, policy, exr](const auto& path) {
         WriteExr(path, solution.normal_in_table, policy, {}, {}, NormalMapExrEncoding(exr));
       }},
      {"albedo_exr", "albedo.exr",
       [&, policy, exr](const auto& path) {
         WriteExr(path, solution.albedo, policy, {}, AlbedoMetadata(albedo_color, "Linear"), exr);
       }},
      {"confidence", "confidence.exr",
       [&, policy, exr](const auto& path) {
         ImageF confidence(solution.status.width(), solution.status.height(), 3);
         const bool half = exr.sample_type == ExrSampleType::kHalf;
         for (size_t i = 0; i < solution.status.num_pixels(); ++i) {
           const float residual = solution.residual.data()[i];
           confidence.data()[3 * i + 0] = solution.lights_used.data()[i];
           confidence.data()[3 * i + 1] = solution.condition_number.data()[i];
           confidence.data()[3 * i + 2] = half ? RoundToSignificantBits(residual, kResidualSignificantBits) : residual;
         }
         WriteExr(path, confidence, policy, {"lights_used", "condition_number", "residual"}, {}, exr);
       }},
      {"albedo_srgb_preview", "albedo_srgb.png",
       [&, policy](const auto& path) {
         WritePng(path, EncodeSrgbPreview(solution.albedo), policy, AlbedoMetadata(albedo_color, "sRGB"));
       }},
  };
  if (!solution.specular.empty()) {
    files.push_back({"specular_exr", "specular.exr", [&, policy, exr](const auto& path) {
                       ImageMetadata metadata;
                       metadata.description =
                           "specular lobe: specular_f0 (white reflectance at normal incidence, [0, 1]) and "
                           "roughness_alpha (GGX alpha, (0, 1]); both 0 where not estimated";
                       WriteExr(path, SpecularForFile(solution), policy, {"specular_f0", "roughness_alpha"}, metadata, exr);
                     }});
  }
  files.push_back({"status", "status.png", [&, policy](const auto& path) { WritePng(path, status_codes, policy); }});
  files.push_back({"solved_mask", "solved_mask.png", [&, policy](const auto& path) { WritePng(path, solved, policy); }});
  return files;
}

ImageU8 SolvedMask(const PhotometricSolution& solution) {
  ImageU8 solved(solution.status.width(), solution.status.height(), 1);
  for (size_t i = 0; i < solved.size(); ++i) {
    solved.data()[i] = solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved) ? 255 : 0;
  }
  return solved;
}

void CheckThreads(int threads) {
  if (threads < 0) throw std::invalid_argument("WriteSolutionMaps: threads = " + std::to_string(threads) + " must be >= 0");
}

std::map<std::string, std::string> Kinds(const std::vector<MapFile>& files) {
  std::map<std::string, std::string> written;
  for (const MapFile& file : files) written[file.kind] = file.name;
  return written;
}

}  // namespace

std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution,
                                                     const AlbedoColor& albedo_color, const ExrEncoding& exr,
                                                     const ImageF& angular_error_deg, int threads) {
  CheckThreads(threads);
  CheckErrorMap(solution, angular_error_deg);
  const ImageU8 solved = SolvedMask(solution);
  const ImageU8 status_codes = StatusPngCodes(solution);  // checks the specular maps' shape
  // Compression dominates at 16 MP (seconds per file) and the files are
  // independent, so they are written concurrently on the one thread pool:
  // as many at once as there are threads, so that only that many files'
  // encoding buffers (a full-size copy each) are held at a time.
  std::vector<MapFile> files = SolutionMapFiles(solution, albedo_color, exr, solved, status_codes);
  if (!angular_error_deg.empty()) files.insert(files.begin() + 4, ErrorMapFile(angular_error_deg, exr));
  ParallelFor(static_cast<int>(files.size()), ResolveThreadCount(threads), 1, [&](int first, int last, int) {
    for (int i = first; i < last; ++i) files[i].write(folder / files[i].name);
  });  // rethrows a failure
  return Kinds(files);
}

MapsWrittenAlongside WriteSolutionMapsAlongside(const std::filesystem::path& folder,
                                                const PhotometricSolution& solution,
                                                const AlbedoColor& albedo_color, const ExrEncoding& exr,
                                                const std::function<ImageF()>& alongside, int threads) {
  CheckThreads(threads);
  if (!alongside) throw std::invalid_argument("WriteSolutionMapsAlongside: alongside must not be empty");
  const ImageU8 solved = SolvedMask(solution);
  const ImageU8 status_codes = StatusPngCodes(solution);
  const std::vector<MapFile> files = SolutionMapFiles(solution, albedo_color, exr, solved, status_codes);
  MapsWrittenAlongside result;
  ImageF angular_error_deg;
  // Item 0 is `alongside` and then the error map it made; the others the
  // files. Whichever thread is free takes the next item, so the files fill
  // the threads `alongside` leaves idle and the other way round.
  const auto start = std::chrono::steady_clock::now();
  ParallelFor(static_cast<int>(files.size()) + 1, ResolveThreadCount(threads), 1, [&](int first, int last, int) {
    for (int i = first; i < last; ++i) {
      if (i > 0) {
        files[i - 1].write(folder / files[i - 1].name);
        continue;
      }
      angular_error_deg = alongside();
      result.alongside_seconds = SecondsSince(start);
      CheckErrorMap(solution, angular_error_deg);
      if (!angular_error_deg.empty()) {
        const MapFile error_map = ErrorMapFile(angular_error_deg, exr);
        error_map.write(folder / error_map.name);
        result.outputs[error_map.kind] = error_map.name;
      }
    }
  });  // rethrows a failure
  const std::map<std::string, std::string> kinds = Kinds(files);
  result.outputs.insert(kinds.begin(), kinds.end());
  return result;
}

}  // namespace scanbench
