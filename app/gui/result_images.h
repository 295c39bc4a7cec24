// Turns the files a solve or capture wrote into images to look at. Display
// only: the maps are read as written, nothing is recomputed except the
// relight preview, a shading of the solved normals and albedo
// (app/gui/relight_shading.h).
#pragma once

#include <QImage>
#include <QString>
#include <QStringList>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "app/gui/relight_shading.h"
#include "app/io/status_codes.h"
#include "core/image.h"

namespace scanbench {

// The maps a result folder offers, in the order the Results page lists them.
enum class ResultLayer {
  kAlbedo,
  kNormal,
  kStatus,
  kResidual,         // confidence.exr: RMS luminance residual / albedo
  kConditionNumber,  // confidence.exr: the light matrix's condition number
  kLightsUsed,       // confidence.exr: samples in the solve
  kAngularError,     // angular_error_deg.exr (ground truth only)
  kRelight,
  kSpecularF0,       // specular.exr: specular_f0 (a solve with a specular lobe)
  kSpecularRoughness,  // specular.exr: roughness_alpha
  kHeight,           // the newest export of the result: <material>_height.exr, mm
  kOcclusion,        // the newest export of the result: <material>_ao.*, 1 = open
};
QString ResultLayerName(ResultLayer layer);

// The layers present in `result_dir`, in the order the page lists them
// (angular error only with ground truth, specular with specular.exr, height
// and occlusion once the result was exported into <session>/exports/).
QList<ResultLayer> AvailableLayers(const std::filesystem::path& result_dir);

// The newest export of `result_dir` (<session>/exports/<run-id>-<preset>[-N]/
// with a material.json naming it) and the files it lists by kind ("height",
// "ao"), as absolute paths; empty when the result was not exported there.
struct ResultExport {
  std::filesystem::path dir;
  std::filesystem::path height_file, occlusion_file;  // empty if the export has none
};
std::optional<ResultExport> LatestExportOf(const std::filesystem::path& result_dir);

// The pixel pitch on the sample, mm: the session rig's footprint of the
// centre pixel on the table (as the export takes it); nullopt when the
// result's session cannot be read. `why` (optional) receives the reason.
std::optional<double> ResultPixelPitchMm(const std::filesystem::path& result_dir, std::string* why = nullptr);

// How a heatmap's colours map to values, for its legend.
struct HeatmapScale {
  QString quantity;      // "RMS residual / albedo"
  QString unit;          // "deg"; "" = a ratio or a count
  float lo = 0, hi = 1;  // the colour range: lo dark blue .. hi yellow (values beyond are clamped)
  bool has_values = false;
  float min = 0, max = 0;  // the map's smallest and largest finite value (has_values)
};

struct LayerImage {
  QImage image;
  std::optional<HeatmapScale> scale;  // heatmaps only
  std::optional<StatusCounts> status;  // the status map only: pixels per code
  // The values behind a heatmap (channel `channel`), for the pixel readout.
  std::shared_ptr<const ImageF> values;
  int channel = 0;
};

// Loads one layer (not kRelight). Throws std::runtime_error naming the file.
LayerImage LoadResultLayerImage(const std::filesystem::path& result_dir, ResultLayer layer);
QImage LoadResultLayer(const std::filesystem::path& result_dir, ResultLayer layer);

// status.png's colours (app/io/status_codes.h), one per code.
QRgb StatusColour(int code);

// t in [0, 1] -> dark blue -> magenta -> orange -> yellow (ordered in lightness).
QRgb HeatmapColour(double t);
// value in [lo, hi] -> HeatmapColour; NaN grey. One channel of `values`.
QImage Heatmap(const ImageF& values, int channel, float lo, float hi);
// The finite values' range of one channel, only where `mask` (optional, one
// channel, same size) is non-zero; has_values false if none.
void FillValueRange(const ImageF& values, int channel, HeatmapScale* scale, const ImageU8* mask = nullptr);

// The solved normals and albedo, for relighting.
struct RelightMaps {
  ImageF normal;  // 3 channels, unit (x, y, z) in the tangent frame
  ImageF albedo;  // 3 channels, linear
  float albedo_scale = 1;  // maps the 99th-percentile albedo to about 0.8
};
RelightMaps LoadRelightMaps(const std::filesystem::path& result_dir);
// ShadeRelight for a distant light l (unit) seen from straight above,
// albedo scaled by albedo_scale, sRGB-encoded. Throws if `shading` fails Check().
// `stop` (optional) is read once per row: when it is set the render gives up
// and returns a null image.
QImage Relight(const RelightMaps& maps, double lx, double ly, double lz, const RelightShading& shading = {},
               const std::atomic<bool>* stop = nullptr);

// What the pixel readout under the cursor reads: the result's maps, each
// empty when the result has no such file. Loaded off the UI thread.
struct PixelProbeMaps {
  int width = 0, height = 0;
  ImageF normal;     // normal.exr, 3 channels
  ImageF albedo;     // albedo.exr, 3 channels, linear
  ImageU8 status;    // status.png codes
  ImageF error_deg;  // angular_error_deg.exr (ground truth only)
  ImageF residual;   // confidence.exr's residual
};
// Throws std::runtime_error naming a file that exists but cannot be read.
PixelProbeMaps LoadPixelProbeMaps(const std::filesystem::path& result_dir);
// One line for pixel (x, y): "x 12, y 40 · residual 0.0031 · normal (0.012, -0.034, 0.999), 2.0° from flat ·
// albedo 0.41 0.40 0.38 · solved · error 0.42°"; `shown` (optional) adds the
// shown heatmap's value first. "" outside the maps.
QString DescribePixel(const PixelProbeMaps& maps, int x, int y, const LayerImage* shown = nullptr);

// A small preview of a RAW frame, developed as the live view develops
// (DevelopRawPreview: white-balanced, box-filtered, clipped samples red), at
// most `max_width` wide. Throws naming the file.
QImage RawThumbnail(const std::filesystem::path& raw_file, int max_width);


}  // namespace scanbench
