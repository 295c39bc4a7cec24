// A result folder's maps: writes a photometric solution as the files a
// material pipeline picks up, and reads back what its report states.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "app/io/image_io.h"

#include "pipeline/albedo_color.h"
#include "solver/photometric_solver.h"

namespace scanbench {

// The albedo's colour as a result's report.json states it (its "color" object);
// results older than issue #12 (no "color") are white-balanced camera RGB of a
// relative scale. Read by the export and by the GUI's results page.
struct ResultAlbedoColor {
  std::string color_space = "camera_rgb";  // "linear_rec709" or "camera_rgb"
  std::string scale = "relative";          // "absolute" or "relative"
  std::string description = "not colour calibrated (the result's report names no colour space)";
  std::string scale_source;
};
// From report.json's text; throws std::runtime_error when it is no JSON object.
ResultAlbedoColor AlbedoColorOfReport(const std::string& report_json);


// Normals in the tangent frame (x right, y up, z out of the sample) as
// 16-bit RGB: value = (n + 1) / 2 * 65535, i.e. the OpenGL (+Y up) convention.
ImageU16 EncodeNormalsPng16(const ImageF& normal_in_tangent);
// Linear RGB to 8-bit sRGB for a preview: SrgbPreviewCode per sample.
ImageU8 EncodeSrgbPreview(const ImageF& linear_rgb);
// lround(SrgbEncode(linear) * 255), exactly: SrgbQuantizer (calibration/color_science.h).
uint8_t SrgbPreviewCode(float linear);

// status.png's code for a solved pixel whose specular lobe the samples do not
// support (SpecularStatus::kUnsupported): the codes 0 .. 6 are PixelStatus,
// 7 is this. Only written when the solution has a specular map; solved_mask.png
// counts these pixels as solved (their normal and albedo are).
inline constexpr uint8_t kStatusSolvedSpecularUnsupported = 7;

// status.png: PixelStatus per pixel, solved pixels with an unsupported
// specular lobe as kStatusSolvedSpecularUnsupported when `specular` is non-empty.
ImageU8 StatusPngCodes(const PhotometricSolution& solution);

// The specular map of a solution in numbers (report.json's "specular",
// summary.txt's specular line).
struct SpecularMapStatistics {
  std::array<size_t, kNumSpecularStatuses> pixels_by_status{};  // per SpecularStatus
  double mean_specular_f0 = 0;      // over kEstimated pixels, white reflectance at normal incidence; 0 if none
  double mean_roughness_alpha = 0;  // over kEstimated pixels, GGX alpha; 0 if none
  size_t estimated() const { return pixels_by_status[static_cast<int>(SpecularStatus::kEstimated)]; }
  std::string ReportJson() const;   // {"pixels_by_status": {...}, "mean_specular_f0": .., ...}
  // "specular map: 1200 estimated, 300 unsupported, 50 not solved; mean F0 0.041, mean GGX alpha 0.210".
  std::string BriefReport() const;
};
// nullopt when the solution has no specular map (`specular` empty); throws
// std::invalid_argument when specular / specular_status do not fit the
// solution's size (2 and 1 channels).
std::optional<SpecularMapStatistics> SpecularMapStatisticsOf(const PhotometricSolution& solution);
// The same band by band (the solve streams its bands): Add each band in
// order of rows, then Finish; the same sums in the same order, so the same figures.
class SpecularMapTally {
 public:
  void Add(const PhotometricSolution& band);  // throws as SpecularMapStatisticsOf
  std::optional<SpecularMapStatistics> Finish() const;

 private:
  SpecularMapStatistics stats_;
  double f0_sum_ = 0, alpha_sum_ = 0;
  bool any_specular_ = false, without_specular_ = false;
};

// The result maps' EXR encoding. By default half float (11-bit mantissa: a
// unit normal's direction moves by at most 0.024 deg, albedo and confidence
// values by at most 2^-11 relative) with the lossless compression that
// measured smallest among the quick ones at 16 MP (docs/session-format.md,
// "Result map encoding"); WriteSolutionMaps also puts normal.exr's components
// below 0.25 on an absolute 2^-12 grid (within the same 0.024 deg),
// confidence.exr's residual on 8 significant bits (within 0.4 %) and
// angular_error_deg.exr below 2 deg on a 2^-9 deg grid (within 0.001 deg).
// `float32_maps` gives 32-bit float with zip, the files before issue #14,
// normals exactly as in memory.
ExrEncoding ResultMapExrEncoding(bool float32_maps = false);

// Writes normal.exr, normal.png, albedo.exr, albedo_srgb.png, status.png,
// solved_mask.png and confidence.exr into `folder` (never overwriting), and
// specular.exr (channels specular_f0, roughness_alpha; both 0 where the lobe
// is not estimated) when the solution has a specular map, and
// angular_error_deg.exr (channel Y) when `angular_error_deg` is non-empty,
// and learned_error_deg.exr (channel Y: the network's own expected error,
// deg, where its normal was kept, else 0) when the solution has that map.
// The EXRs are stored as `exr` says; the PNGs are always 16-bit (normal) and 8-bit.
// albedo.exr and albedo_srgb.png name their colour space (`albedo_color`):
// linear Rec.709 carries the OpenEXR chromaticities of Rec.709 / D65.
// The files are independent and written concurrently on up to `threads`
// threads of the one pool (0 = all cores, 1 = one after another), each
// atomically (SolutionMapStream with the whole solution as one band); their
// bytes do not depend on `threads`. Returns output kind -> file name.
std::map<std::string, std::string> WriteSolutionMaps(const std::filesystem::path& folder,
                                                     const PhotometricSolution& solution,
                                                     const AlbedoColor& albedo_color = {},
                                                     const ExrEncoding& exr = ResultMapExrEncoding(),
                                                     const ImageF& angular_error_deg = {}, int threads = 0);

// The same files written band by band while the solve runs (issue #14): every
// map's ImageRowWriter is opened at once and each solved band's rows are
// encoded and appended, so no full-size map or encoding buffer is held. The
// files are WriteSolutionMaps' byte for byte (but for the EXRs' capDate, the
// second each was written). They appear, each atomically, on Commit(); a
// stream destroyed uncommitted leaves none of them (nor temporary files).
class SolutionMapStream {
 public:
  // Opens the files for a width x height solution in `folder`: specular.exr
  // when `with_specular`, angular_error_deg.exr when `with_error_map`,
  // learned_error_deg.exr when `with_learned_error` (the bands then carry
  // PhotometricSolution::learned_error_deg).
  SolutionMapStream(const std::filesystem::path& folder, int width, int height, bool with_specular,
                    bool with_error_map, bool with_learned_error = false, const AlbedoColor& albedo_color = {},
                    const ExrEncoding& exr = ResultMapExrEncoding());
  SolutionMapStream(const SolutionMapStream&) = delete;
  SolutionMapStream& operator=(const SolutionMapStream&) = delete;
  ~SolutionMapStream();

  // The next band (rows following the last band's; every map the width, the
  // specular maps when opened with them). The files' rows are encoded
  // concurrently on up to `threads` threads of the one pool (0 = all), and
  // `alongside` (the band's ground-truth evaluation; it may use the pool
  // itself) runs as one more item among them; the 1-channel rows it returns
  // go to angular_error_deg.exr (it must be given exactly when the stream has
  // that file). Rethrows a failure of `alongside` or a write.
  void AddBand(const PhotometricSolution& band, const std::function<ImageF()>& alongside = {}, int threads = 0);
  // Every row added: the files appear (closed, fsynced and renamed
  // concurrently on the pool). Returns output kind -> file name.
  std::map<std::string, std::string> Commit();

  int rows_added() const { return rows_added_; }
  // Wall time from each AddBand's start until its `alongside` returned, summed.
  double alongside_seconds() const { return alongside_seconds_; }

 private:
  struct Map;
  void CheckBand(const PhotometricSolution& band) const;
  int width_ = 0, height_ = 0;
  bool with_specular_ = false;
  bool with_learned_error_ = false;
  std::vector<Map> maps_;
  std::unique_ptr<ImageRowWriter> error_map_;
  int rows_added_ = 0;
  double alongside_seconds_ = 0;
  bool committed_ = false;
};

// Bytes of each regular file directly in `folder` (name -> bytes), for the
// reports' account of what a result costs on disk.
std::map<std::string, uintmax_t> FileSizesIn(const std::filesystem::path& folder);

// The metadata of an albedo file in `albedo_color`'s space; `color_space` as
// ImageMetadata::color_space ("Linear" or "sRGB").
ImageMetadata AlbedoMetadata(const AlbedoColor& albedo_color, const std::string& color_space);

// --- A result folder's maps read back (the export) --------------------------
// Each reader checks what it reads -- the channel count, the session's size
// width x height, every value finite (bad input must never turn into NaN
// downstream) -- and throws std::runtime_error naming the file otherwise.

// confidence.exr's channels, in the order the solve writes them.
const std::vector<std::string>& ConfidenceChannelNames();
// A map of the result folder. `channel_names`, if given, are read by name in
// that order: OpenEXR stores channels sorted by name, so their position in
// the file is not the writer's.
ImageF ReadResultMap(const std::filesystem::path& path, int channels, int width, int height,
                     const std::vector<std::string>& channel_names = {});
// A map of a simulated session's ground truth (float EXRs), its channels in
// the file's order, through ImageRowReader: its OpenEXR core-library reader
// copies a float file's rows straight into the image (about 4x less CPU than
// ReadImageFloat's default reader on an uncompressed 16 MP map), the same values.
ImageF ReadGroundTruthMap(const std::filesystem::path& path, int channels, int width, int height);
// specular.exr's roughness_alpha (issue #13): both channels by name, every
// value of both finite and in [0, 1].
ImageF ReadSpecularAlpha(const std::filesystem::path& path, int width, int height);
// An 8-bit mask (solved_mask.png, a ground truth's sample mask): 1 where the
// stored value is above half, 0 elsewhere.
ImageU8 ReadBinaryMask(const std::filesystem::path& path, int width, int height);

}  // namespace scanbench
