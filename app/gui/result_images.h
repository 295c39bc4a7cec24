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
#include <optional>
#include <vector>

#include "app/gui/relight_shading.h"
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
};
QString ResultLayerName(ResultLayer layer);

// The layers present in `result_dir` (angular error only with ground truth).
QList<ResultLayer> AvailableLayers(const std::filesystem::path& result_dir);

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
};

// Loads one layer (not kRelight). Throws std::runtime_error naming the file.
LayerImage LoadResultLayerImage(const std::filesystem::path& result_dir, ResultLayer layer);
QImage LoadResultLayer(const std::filesystem::path& result_dir, ResultLayer layer);

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

// A small preview of a RAW frame, developed as the live view develops
// (DevelopRawPreview: white-balanced, box-filtered, clipped samples red), at
// most `max_width` wide. Throws naming the file.
QImage RawThumbnail(const std::filesystem::path& raw_file, int max_width);


}  // namespace scanbench
