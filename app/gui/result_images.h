// Turns the files a solve or capture wrote into images to look at. Display
// only: the maps are read as written, nothing is recomputed except the
// relight preview, a Lambertian shading of the solved normals and albedo.
#pragma once

#include <QImage>
#include <QString>
#include <QStringList>

#include <cstdint>
#include <filesystem>
#include <vector>

#include "solver/image.h"

namespace scanbench {

// The maps a result folder offers, in the order the Results page lists them.
enum class ResultLayer { kAlbedo, kNormal, kStatus, kResidual, kAngularError, kRelight };
QString ResultLayerName(ResultLayer layer);

// The layers present in `result_dir` (angular error only with ground truth).
QList<ResultLayer> AvailableLayers(const std::filesystem::path& result_dir);

// Loads one layer (not kRelight). Throws std::runtime_error naming the file.
QImage LoadResultLayer(const std::filesystem::path& result_dir, ResultLayer layer);

// value in [lo, hi] -> dark blue .. yellow; NaN grey. Single-channel input.
QImage Heatmap(const ImageF& values, int channel, float lo, float hi);

// The solved normals and albedo, for relighting.
struct RelightMaps {
  ImageF normal;  // 3 channels, unit (x, y, z) in the tangent frame
  ImageF albedo;  // 3 channels, linear
  float albedo_scale = 1;  // maps the 99th-percentile albedo to about 0.8
};
RelightMaps LoadRelightMaps(const std::filesystem::path& result_dir);
// albedo · max(0, n·l) for a distant light l (unit), sRGB-encoded.
QImage Relight(const RelightMaps& maps, double lx, double ly, double lz);

// A small preview of a RAW frame: 2x2 Bayer tiles to one RGB pixel, black
// subtracted, gamma for display, at most `max_width` wide. Throws naming the file.
QImage RawThumbnail(const std::filesystem::path& raw_file, int max_width);

// A decoded camera preview (JPEG, PPM) with its luminance histogram drawn
// under it and clipped pixels painted red: the live view.
QImage DecodePreview(const std::vector<uint8_t>& bytes);

}  // namespace scanbench
