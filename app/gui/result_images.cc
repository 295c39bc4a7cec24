#include "app/gui/result_images.h"

#include <QColor>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "app/controllers/capture_controller.h"
#include "app/gui/live_view.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/io/result_maps.h"
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

// The colours of status.png's codes (see README: 0 solved ... 6 invalid input;
// 7 solved without a specular estimate, kStatusSolvedSpecularUnsupported: pale
// cyan, a solved colour that stands out from the green).
QImage StatusImage(const fs::path& path) {
  const ImageU8 status = ReadImageU8(path);
  static const QRgb kColours[] = {qRgb(40, 170, 70),  qRgb(30, 30, 30),   qRgb(230, 160, 30), qRgb(200, 60, 200),
                                  qRgb(60, 90, 200),  qRgb(220, 40, 40), qRgb(255, 255, 255), qRgb(150, 225, 235)};
  static_assert(std::size(kColours) == kStatusSolvedSpecularUnsupported + 1);
  QImage image(status.width(), status.height(), QImage::Format_RGB32);
  for (int y = 0; y < status.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    for (int x = 0; x < status.width(); ++x) {
      const int code = status(x, y, 0);
      line[x] = kColours[code < int(std::size(kColours)) ? code : int(PixelStatus::kInvalidInput)];
    }
  }
  return image;
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
  }
  return {};
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
  if (fs::exists(dir / "normal.exr") && fs::exists(dir / "albedo.exr")) layers << ResultLayer::kRelight;
  return layers;
}

LayerImage LoadResultLayerImage(const fs::path& dir, ResultLayer layer) {
  switch (layer) {
    case ResultLayer::kAlbedo: return {LoadQtImage(dir / "albedo_srgb.png"), std::nullopt};
    case ResultLayer::kNormal: return {LoadQtImage(dir / "normal.png"), std::nullopt};
    case ResultLayer::kStatus: return {StatusImage(dir / "status.png"), std::nullopt};
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
      return {Heatmap(confidence, channel, scale.lo, scale.hi), scale};
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
      return {Heatmap(error, 0, scale.lo, scale.hi), scale};
    }
    case ResultLayer::kRelight: break;
  }
  throw std::logic_error("LoadResultLayer: relight is computed, not loaded");
}

QImage LoadResultLayer(const fs::path& dir, ResultLayer layer) { return LoadResultLayerImage(dir, layer).image; }

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

QImage RawThumbnail(const fs::path& raw_file, int max_width) {
  // The live view's development (white-balanced, box-filtered, clipping in
  // red); a frame under capture's default minimum signal (the dark frame) is
  // not brightened into noise.
  return DevelopRawPreview(DecodeRawFile(raw_file), RawDevelopOptions{}.clip_fraction, max_width,
                           CaptureOptions{}.min_signal)
      .image;
}

}  // namespace scanbench
