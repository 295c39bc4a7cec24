#include "app/gui/result_images.h"

#include <QColor>
#include <QFile>
#include <QJsonDocument>
#include <QJsonObject>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "app/controllers/capture_controller.h"
#include "app/gui/live_view.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/io/result_maps.h"
#include "app/session/session.h"
#include "calibration/camera_model.h"
#include "calibration/color_science.h"
#include "calibration/raw_develop.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

uint8_t ToSrgb8(double linear) { return static_cast<uint8_t>(std::lround(SrgbEncode(linear) * 255)); }

QImage LoadQtImage(const fs::path& path) {
  QImage image(QString::fromStdString(path.string()));
  if (image.isNull()) {
    throw std::runtime_error(path.string() + ": cannot be read as an image; solve the session again");
  }
  return image.convertToFormat(QImage::Format_RGB32);
}

// status.png's codes in the colours of app/io/status_codes.h, with the pixels per code.
LayerImage StatusLayer(const fs::path& path) {
  const ImageU8 status = ReadImageU8(path);
  QImage image(status.width(), status.height(), QImage::Format_RGB32);
  for (int y = 0; y < status.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    const uint8_t* codes = status.row(y);
    for (int x = 0; x < status.width(); ++x) line[x] = StatusColour(codes[x * status.channels()]);
  }
  LayerImage layer;
  layer.image = image;
  layer.status = CountStatusCodes(status);
  return layer;
}

LayerImage HeatmapLayer(QImage image, std::optional<HeatmapScale> scale) {
  LayerImage layer;
  layer.image = std::move(image);
  layer.scale = std::move(scale);
  return layer;
}

float Percentile(std::vector<float> values, double p) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, size_t(p * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

}  // namespace

QString ResultLayerName(ResultLayer layer) {
  switch (layer) {
    case ResultLayer::kAlbedo: return QStringLiteral("Albedo");
    case ResultLayer::kNormal: return QStringLiteral("Normal");
    case ResultLayer::kStatus: return QStringLiteral("Status");
    case ResultLayer::kResidual: return QStringLiteral("Confidence (residual)");
    case ResultLayer::kConditionNumber: return QStringLiteral("Confidence (condition number)");
    case ResultLayer::kLightsUsed: return QStringLiteral("Confidence (lights used)");
    case ResultLayer::kAngularError: return QStringLiteral("Angular error (deg)");
    case ResultLayer::kRelight: return QStringLiteral("Relight");
    case ResultLayer::kSpecularF0: return QStringLiteral("Specular F0");
    case ResultLayer::kSpecularRoughness: return QStringLiteral("Specular roughness (GGX alpha)");
    case ResultLayer::kHeight: return QStringLiteral("Height (mm, from the export)");
    case ResultLayer::kOcclusion: return QStringLiteral("Ambient occlusion (from the export)");
  }
  return {};
}

namespace {

// "<session>/results/<run-id>" however it was typed (a trailing slash).
fs::path NormalResultDir(const fs::path& dir) {
  fs::path normal = dir.lexically_normal();
  if (!normal.has_filename()) normal = normal.parent_path();
  return normal;
}

}  // namespace

std::optional<ResultExport> LatestExportOf(const fs::path& result_dir) {
  const fs::path result = NormalResultDir(result_dir);
  const fs::path exports = result.parent_path().parent_path() / "exports";
  const std::string prefix = result.filename().string() + "-";
  std::error_code error;
  std::optional<ResultExport> newest;
  fs::file_time_type newest_time;
  for (const fs::directory_entry& entry : fs::directory_iterator(exports, error)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory(error) || name.rfind(prefix, 0) != 0) continue;
    const fs::path manifest = entry.path() / "material.json";
    const fs::file_time_type time = fs::last_write_time(manifest, error);
    if (error) continue;
    if (newest && time < newest_time) continue;
    QFile file(QString::fromStdString(manifest.string()));
    if (!file.open(QIODevice::ReadOnly)) continue;
    const QJsonObject json = QJsonDocument::fromJson(file.readAll()).object();
    const QJsonObject files = json["files"].toObject();
    ResultExport found;
    found.dir = entry.path();
    auto file_of = [&](const char* kind) {
      const QString path = files[kind].toObject()["path"].toString();
      return path.isEmpty() ? fs::path() : entry.path() / path.toStdString();
    };
    found.height_file = file_of("height");
    found.occlusion_file = file_of("ao");
    newest = found;
    newest_time = time;
  }
  return newest;
}

std::optional<double> ResultPixelPitchMm(const fs::path& result_dir, std::string* why) {
  try {
    SessionLoadOptions options;
    options.verify_checksums = false;  // the rig only
    const Session session = LoadSession(NormalResultDir(result_dir).parent_path().parent_path(), options);
    const double mm = TablePixelFootprintMm(session.rig.camera);
    if (std::isfinite(mm) && mm > 0) return mm;
    if (why) *why = "the session's rig gives a pixel footprint of " + std::to_string(mm) + " mm";
  } catch (const std::exception& error) {
    if (why) *why = error.what();
  }
  return std::nullopt;
}

QList<ResultLayer> AvailableLayers(const fs::path& dir) {
  QList<ResultLayer> layers;
  if (fs::exists(dir / "albedo_srgb.png")) layers << ResultLayer::kAlbedo;
  if (fs::exists(dir / "normal.png")) layers << ResultLayer::kNormal;
  if (fs::exists(dir / "status.png")) layers << ResultLayer::kStatus;
  if (fs::exists(dir / "confidence.exr")) {
    layers << ResultLayer::kResidual << ResultLayer::kConditionNumber << ResultLayer::kLightsUsed;
  }
  if (fs::exists(dir / "angular_error_deg.exr")) layers << ResultLayer::kAngularError;
  if (fs::exists(dir / "specular.exr")) layers << ResultLayer::kSpecularF0 << ResultLayer::kSpecularRoughness;
  if (const std::optional<ResultExport> exported = LatestExportOf(dir)) {
    if (!exported->height_file.empty() && fs::exists(exported->height_file)) layers << ResultLayer::kHeight;
    if (!exported->occlusion_file.empty() && fs::exists(exported->occlusion_file)) layers << ResultLayer::kOcclusion;
  }
  if (fs::exists(dir / "normal.exr") && fs::exists(dir / "albedo.exr")) layers << ResultLayer::kRelight;
  return layers;
}

LayerImage LoadResultLayerImage(const fs::path& dir, ResultLayer layer) {
  switch (layer) {
    case ResultLayer::kAlbedo: return HeatmapLayer(LoadQtImage(dir / "albedo_srgb.png"), std::nullopt);
    case ResultLayer::kNormal: return HeatmapLayer(LoadQtImage(dir / "normal.png"), std::nullopt);
    case ResultLayer::kStatus: return StatusLayer(dir / "status.png");
    case ResultLayer::kResidual:
    case ResultLayer::kConditionNumber:
    case ResultLayer::kLightsUsed: {
      const char* channel_name = layer == ResultLayer::kResidual          ? "residual"
                                 : layer == ResultLayer::kConditionNumber ? "condition_number"
                                                                          : "lights_used";
      std::vector<std::string> names;
      const ImageF confidence = ReadImageFloat(dir / "confidence.exr", &names);
      const auto found = std::find(names.begin(), names.end(), channel_name);
      if (found == names.end()) {
        throw std::runtime_error((dir / "confidence.exr").string() + ": has no channel '" + channel_name + "'");
      }
      const int channel = int(found - names.begin());
      HeatmapScale scale;
      FillValueRange(confidence, channel, &scale);
      if (layer == ResultLayer::kLightsUsed) {
        // Whole counts from none to every light: the scale reads as the count.
        scale.quantity = QStringLiteral("lights used");
        scale.lo = 0;
        scale.hi = std::max(3.0f, scale.max);
      } else {
        std::vector<float> values;
        values.reserve(confidence.num_pixels());
        for (int y = 0; y < confidence.height(); ++y)
          for (int x = 0; x < confidence.width(); ++x)
            // Unsolved pixels hold 0 in both maps: not part of the spread.
            if (std::isfinite(confidence(x, y, channel)) && confidence(x, y, channel) > 0)
              values.push_back(confidence(x, y, channel));
        // Scaled to the 99th percentile: the size depends on the sample.
        const float p99 = Percentile(values, 0.99);
        if (layer == ResultLayer::kResidual) {
          scale.quantity = QStringLiteral("RMS residual / albedo");
          scale.lo = 0;
          scale.hi = std::max(p99, 1e-6f);
        } else {
          scale.quantity = QStringLiteral("condition number");
          scale.lo = 1;  // the best a light matrix can be
          scale.hi = std::max(p99, 1.01f);
        }
      }
      LayerImage shown = HeatmapLayer(Heatmap(confidence, channel, scale.lo, scale.hi), scale);
      shown.values = std::make_shared<const ImageF>(confidence);
      shown.channel = channel;
      return shown;
    }
    case ResultLayer::kAngularError: {
      const ImageF error = ReadImageFloat(dir / "angular_error_deg.exr");
      HeatmapScale scale;
      scale.quantity = QStringLiteral("angular error");
      scale.unit = QStringLiteral("deg");
      // 0..5 degrees: the range in which the solver's errors are told apart.
      scale.lo = 0;
      scale.hi = 5;
      // The file holds 0 off the sample: the range is stated over the
      // session's sample mask (<session>/ground_truth/) when it fits.
      const fs::path mask_file = dir.parent_path().parent_path() / "ground_truth" / "sample_mask.png";
      std::optional<ImageU8> mask;
      if (fs::exists(mask_file)) {
        try {
          mask = ReadImageU8(mask_file);
        } catch (const std::exception&) {
          mask.reset();  // the range is then over the whole map, as without a mask
        }
      }
      if (mask && mask->width() == error.width() && mask->height() == error.height()) {
        scale.quantity = QStringLiteral("angular error on the sample");
        FillValueRange(error, 0, &scale, &*mask);
      } else {
        FillValueRange(error, 0, &scale);
      }
      LayerImage shown = HeatmapLayer(Heatmap(error, 0, scale.lo, scale.hi), scale);
      shown.values = std::make_shared<const ImageF>(error);
      return shown;
    }
    case ResultLayer::kSpecularF0:
    case ResultLayer::kSpecularRoughness: {
      // Both channels hold 0 where the lobe is not estimated: shown grey (NaN), not as a value.
      const bool f0 = layer == ResultLayer::kSpecularF0;
      std::vector<std::string> names;
      ImageF specular = ReadImageFloat(dir / "specular.exr", &names);
      const char* channel_name = f0 ? "specular_f0" : "roughness_alpha";
      const auto found = std::find(names.begin(), names.end(), channel_name);
      const auto alpha = std::find(names.begin(), names.end(), "roughness_alpha");
      if (found == names.end() || alpha == names.end()) {
        throw std::runtime_error((dir / "specular.exr").string() + ": has no channel '" + channel_name +
                                 "' and 'roughness_alpha'");
      }
      const int channel = int(found - names.begin()), alpha_channel = int(alpha - names.begin());
      for (int y = 0; y < specular.height(); ++y)
        for (int x = 0; x < specular.width(); ++x)
          if (!(specular(x, y, alpha_channel) > 0)) specular(x, y, channel) = std::nanf("");
      HeatmapScale scale;
      scale.quantity = f0 ? QStringLiteral("specular F0 (grey: no lobe)") : QStringLiteral("GGX alpha (grey: no lobe)");
      FillValueRange(specular, channel, &scale);
      scale.lo = 0;
      scale.hi = f0 ? std::max(0.01f, scale.has_values ? scale.max : 0.1f) : 1.0f;
      LayerImage shown = HeatmapLayer(Heatmap(specular, channel, scale.lo, scale.hi), scale);
      shown.values = std::make_shared<const ImageF>(std::move(specular));
      shown.channel = channel;
      return shown;
    }
    case ResultLayer::kHeight:
    case ResultLayer::kOcclusion: {
      const std::optional<ResultExport> exported = LatestExportOf(dir);
      const fs::path file = !exported ? fs::path()
                            : layer == ResultLayer::kHeight ? exported->height_file
                                                            : exported->occlusion_file;
      if (file.empty()) {
        throw std::runtime_error((dir.parent_path().parent_path() / "exports").string() +
                                 ": no export of this result lists a " +
                                 (layer == ResultLayer::kHeight ? "height" : "occlusion") + " map; export it first");
      }
      ImageF values = ReadImageFloat(file);
      HeatmapScale scale;
      FillValueRange(values, 0, &scale);
      if (layer == ResultLayer::kHeight) {
        scale.quantity = QStringLiteral("height");
        scale.unit = QStringLiteral("mm");
        scale.lo = scale.has_values ? scale.min : 0;
        scale.hi = scale.has_values && scale.max > scale.min ? scale.max : scale.lo + 1;
      } else {
        scale.quantity = QStringLiteral("ambient occlusion (1 = open)");
        scale.lo = 0;
        scale.hi = 1;
      }
      LayerImage shown = HeatmapLayer(Heatmap(values, 0, scale.lo, scale.hi), scale);
      shown.values = std::make_shared<const ImageF>(std::move(values));
      return shown;
    }
    case ResultLayer::kRelight: break;
  }
  throw std::logic_error("LoadResultLayer: relight is computed, not loaded");
}

QImage LoadResultLayer(const fs::path& dir, ResultLayer layer) { return LoadResultLayerImage(dir, layer).image; }

QRgb StatusColour(int code) {
  const StatusCodeInfo& info = StatusCodeOf(code);
  return qRgb(info.r, info.g, info.b);
}

QRgb HeatmapColour(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return qRgb(int(255 * std::min(1.0, 1.6 * t)), int(255 * std::max(0.0, 1.4 * t - 0.4)),
              int(255 * std::clamp(0.35 + 1.2 * t - 2.0 * t * t, 0.0, 1.0)));
}

QImage Heatmap(const ImageF& values, int channel, float lo, float hi) {
  QImage image(values.width(), values.height(), QImage::Format_RGB32);
  for (int y = 0; y < values.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    for (int x = 0; x < values.width(); ++x) {
      const float v = values(x, y, channel);
      line[x] = std::isfinite(v) ? HeatmapColour((v - lo) / double(hi - lo)) : qRgb(128, 128, 128);
    }
  }
  return image;
}

void FillValueRange(const ImageF& values, int channel, HeatmapScale* scale, const ImageU8* mask) {
  scale->has_values = false;
  for (int y = 0; y < values.height(); ++y) {
    for (int x = 0; x < values.width(); ++x) {
      const float v = values(x, y, channel);
      if (!std::isfinite(v) || (mask && (*mask)(x, y, 0) == 0)) continue;
      scale->min = scale->has_values ? std::min(scale->min, v) : v;
      scale->max = scale->has_values ? std::max(scale->max, v) : v;
      scale->has_values = true;
    }
  }
}

RelightMaps LoadRelightMaps(const fs::path& dir) {
  RelightMaps maps;
  maps.normal = ReadImageFloat(dir / "normal.exr");
  maps.albedo = ReadImageFloat(dir / "albedo.exr");
  if (maps.normal.channels() < 3 || maps.albedo.channels() < 3 || !maps.normal.SameSize(maps.albedo)) {
    throw std::runtime_error((dir / "normal.exr").string() + " and albedo.exr: not two RGB maps of one size");
  }
  std::vector<float> values;
  for (size_t i = 1; i < maps.albedo.size(); i += 3 * 7) values.push_back(maps.albedo.data()[i]);
  maps.albedo_scale = 0.8f / std::max(Percentile(values, 0.99), 1e-6f);
  return maps;
}

QImage Relight(const RelightMaps& maps, double lx, double ly, double lz, const RelightShading& shading,
               const std::atomic<bool>* stop) {
  shading.Check();
  const ImageF& n = maps.normal;
  const Eigen::Vector3d light(lx, ly, lz);
  const Eigen::Vector3d view(0, 0, 1);  // the camera looks straight down on the table
  QImage image(n.width(), n.height(), QImage::Format_RGB32);
  for (int y = 0; y < n.height(); ++y) {
    if (stop != nullptr && stop->load(std::memory_order_relaxed)) return QImage();
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    for (int x = 0; x < n.width(); ++x) {
      const Eigen::Vector3d normal(n(x, y, 0), n(x, y, 1), n(x, y, 2));
      const Eigen::Vector3d albedo =
          Eigen::Vector3d(maps.albedo(x, y, 0), maps.albedo(x, y, 1), maps.albedo(x, y, 2)) * maps.albedo_scale;
      const Eigen::Vector3d rgb = ShadeRelight(albedo, normal, light, view, shading);
      line[x] = qRgb(ToSrgb8(rgb.x()), ToSrgb8(rgb.y()), ToSrgb8(rgb.z()));
    }
  }
  return image;
}

PixelProbeMaps LoadPixelProbeMaps(const fs::path& dir) {
  PixelProbeMaps maps;
  auto take_size = [&maps](int width, int height) {
    if (maps.width == 0) maps.width = width, maps.height = height;
  };
  if (fs::exists(dir / "normal.exr")) {
    maps.normal = ReadImageFloat(dir / "normal.exr");
    take_size(maps.normal.width(), maps.normal.height());
  }
  if (fs::exists(dir / "albedo.exr")) {
    maps.albedo = ReadImageFloat(dir / "albedo.exr");
    take_size(maps.albedo.width(), maps.albedo.height());
  }
  if (fs::exists(dir / "status.png")) {
    maps.status = ReadImageU8(dir / "status.png");
    take_size(maps.status.width(), maps.status.height());
  }
  if (fs::exists(dir / "angular_error_deg.exr")) maps.error_deg = ReadImageFloat(dir / "angular_error_deg.exr");
  if (fs::exists(dir / "confidence.exr")) {
    std::vector<std::string> names;
    const ImageF confidence = ReadImageFloat(dir / "confidence.exr", &names);
    const auto found = std::find(names.begin(), names.end(), "residual");
    if (found != names.end()) {
      const int channel = int(found - names.begin());
      maps.residual = ImageF(confidence.width(), confidence.height(), 1);
      for (int y = 0; y < confidence.height(); ++y)
        for (int x = 0; x < confidence.width(); ++x) maps.residual(x, y) = confidence(x, y, channel);
    }
  }
  return maps;
}

namespace {

bool Holds(const ImageF& map, int x, int y) { return !map.empty() && x < map.width() && y < map.height(); }

QString Number(double value, int significant = 3) { return QString::number(value, 'g', significant); }

}  // namespace

QString DescribePixel(const PixelProbeMaps& maps, int x, int y, const LayerImage* shown) {
  if (x < 0 || y < 0 || x >= maps.width || y >= maps.height) return {};
  QStringList parts;
  parts << QStringLiteral("x %1, y %2").arg(x).arg(y);
  if (shown && shown->values && shown->scale && Holds(*shown->values, x, y)) {
    const float v = (*shown->values)(x, y, shown->channel);
    const QString unit = shown->scale->unit.isEmpty() ? QString() : QLatin1Char(' ') + shown->scale->unit;
    parts << (std::isfinite(v) ? QStringLiteral("%1 %2%3").arg(shown->scale->quantity, Number(v, 4), unit)
                               : QStringLiteral("%1: none").arg(shown->scale->quantity));
  }
  if (!maps.status.empty() && x < maps.status.width() && y < maps.status.height()) {
    parts << QString::fromUtf8(StatusCodeOf(maps.status(x, y, 0)).name);
  }
  if (Holds(maps.normal, x, y)) {
    const double nx = maps.normal(x, y, 0), ny = maps.normal(x, y, 1), nz = maps.normal(x, y, 2);
    const double tilt = std::acos(std::clamp(nz / std::max(1e-12, std::hypot(nx, ny, nz)), -1.0, 1.0)) * 180 / std::numbers::pi;
    parts << QStringLiteral("normal (%1, %2, %3), %4° from flat")
                 .arg(nx, 0, 'f', 3)
                 .arg(ny, 0, 'f', 3)
                 .arg(nz, 0, 'f', 3)
                 .arg(tilt, 0, 'f', 1);
  }
  if (Holds(maps.albedo, x, y)) {
    parts << QStringLiteral("albedo %1 %2 %3")
                 .arg(maps.albedo(x, y, 0), 0, 'f', 3)
                 .arg(maps.albedo(x, y, 1), 0, 'f', 3)
                 .arg(maps.albedo(x, y, 2), 0, 'f', 3);
  }
  if (Holds(maps.error_deg, x, y)) parts << QStringLiteral("error %1°").arg(maps.error_deg(x, y), 0, 'f', 2);
  if (Holds(maps.residual, x, y)) parts << QStringLiteral("residual %1").arg(Number(maps.residual(x, y)));
  return parts.join(QStringLiteral(" · "));
}

QImage RawThumbnail(const fs::path& raw_file, int max_width) {
  // The live view's development (white-balanced, box-filtered, clipping in
  // red); a frame under capture's default minimum signal (the dark frame) is
  // not brightened into noise.
  return DevelopRawPreview(DecodeRawFile(raw_file), RawDevelopOptions{}.clip_fraction, max_width,
                           CaptureOptions{}.min_signal)
      .image;
}

}  // namespace scanbench
