#include "app/gui/result_images.h"

#include <QColor>
#include <QPainter>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

uint8_t ToSrgb8(double linear) {
  linear = std::clamp(linear, 0.0, 1.0);
  const double encoded = linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(encoded * 255));
}

QImage LoadQtImage(const fs::path& path) {
  QImage image(QString::fromStdString(path.string()));
  if (image.isNull()) {
    throw std::runtime_error(path.string() + ": cannot be read as an image; solve the session again");
  }
  return image.convertToFormat(QImage::Format_RGB32);
}

// The colours of status.png's codes (see README: 0 solved ... 6 invalid input).
QImage StatusImage(const fs::path& path) {
  const ImageU8 status = ReadImageU8(path);
  static const QRgb kColours[] = {qRgb(40, 170, 70),  qRgb(30, 30, 30),   qRgb(230, 160, 30), qRgb(200, 60, 200),
                                  qRgb(60, 90, 200),  qRgb(220, 40, 40), qRgb(255, 255, 255)};
  QImage image(status.width(), status.height(), QImage::Format_RGB32);
  for (int y = 0; y < status.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    for (int x = 0; x < status.width(); ++x) line[x] = kColours[std::min<int>(status(x, y, 0), 6)];
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
  if (fs::exists(dir / "confidence.exr")) layers << ResultLayer::kResidual;
  if (fs::exists(dir / "angular_error_deg.exr")) layers << ResultLayer::kAngularError;
  if (fs::exists(dir / "normal.exr") && fs::exists(dir / "albedo.exr")) layers << ResultLayer::kRelight;
  return layers;
}

QImage LoadResultLayer(const fs::path& dir, ResultLayer layer) {
  switch (layer) {
    case ResultLayer::kAlbedo: return LoadQtImage(dir / "albedo_srgb.png");
    case ResultLayer::kNormal: return LoadQtImage(dir / "normal.png");
    case ResultLayer::kStatus: return StatusImage(dir / "status.png");
    case ResultLayer::kResidual: {
      std::vector<std::string> names;
      const ImageF confidence = ReadImageFloat(dir / "confidence.exr", &names);
      const auto found = std::find(names.begin(), names.end(), "residual");
      if (found == names.end()) {
        throw std::runtime_error((dir / "confidence.exr").string() + ": has no channel 'residual'");
      }
      const int channel = int(found - names.begin());
      std::vector<float> values;
      values.reserve(confidence.num_pixels());
      for (int y = 0; y < confidence.height(); ++y)
        for (int x = 0; x < confidence.width(); ++x)
          if (std::isfinite(confidence(x, y, channel))) values.push_back(confidence(x, y, channel));
      // Scaled to the 99th percentile: the residual's size depends on the sample.
      return Heatmap(confidence, channel, 0, std::max(Percentile(values, 0.99), 1e-6f));
    }
    case ResultLayer::kAngularError:
      // 0..5 degrees: the range in which the solver's errors are told apart.
      return Heatmap(ReadImageFloat(dir / "angular_error_deg.exr"), 0, 0, 5);
    case ResultLayer::kRelight: break;
  }
  throw std::logic_error("LoadResultLayer: relight is computed, not loaded");
}

QImage Heatmap(const ImageF& values, int channel, float lo, float hi) {
  QImage image(values.width(), values.height(), QImage::Format_RGB32);
  for (int y = 0; y < values.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    for (int x = 0; x < values.width(); ++x) {
      const float v = values(x, y, channel);
      if (!std::isfinite(v)) {
        line[x] = qRgb(128, 128, 128);
        continue;
      }
      const double t = std::clamp((v - lo) / double(hi - lo), 0.0, 1.0);
      // Dark blue -> magenta -> orange -> yellow: ordered in lightness.
      line[x] = qRgb(int(255 * std::min(1.0, 1.6 * t)), int(255 * std::max(0.0, 1.4 * t - 0.4)),
                     int(255 * std::clamp(0.35 + 1.2 * t - 2.0 * t * t, 0.0, 1.0)));
    }
  }
  return image;
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

QImage Relight(const RelightMaps& maps, double lx, double ly, double lz) {
  const ImageF& n = maps.normal;
  QImage image(n.width(), n.height(), QImage::Format_RGB32);
  for (int y = 0; y < n.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(y));
    for (int x = 0; x < n.width(); ++x) {
      const double shade = std::max(0.0, n(x, y, 0) * lx + n(x, y, 1) * ly + n(x, y, 2) * lz) * maps.albedo_scale;
      line[x] = qRgb(ToSrgb8(maps.albedo(x, y, 0) * shade), ToSrgb8(maps.albedo(x, y, 1) * shade),
                     ToSrgb8(maps.albedo(x, y, 2) * shade));
    }
  }
  return image;
}

QImage RawThumbnail(const fs::path& raw_file, int max_width) {
  const RawImage raw = DecodeRawFile(raw_file);
  const int tiles_x = raw.width() / 2, tiles_y = raw.height() / 2;
  const int step = std::max(1, (tiles_x + max_width - 1) / max_width);
  const int w = tiles_x / step, h = tiles_y / step;
  QImage image(w, h, QImage::Format_RGB32);
  const double range = std::max(1, raw.white_level - raw.BlackAt(0, 0));
  for (int ty = 0; ty < h; ++ty) {
    auto* line = reinterpret_cast<QRgb*>(image.scanLine(ty));
    for (int tx = 0; tx < w; ++tx) {
      double rgb[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      const int x0 = tx * step * 2, y0 = ty * step * 2;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const int colour = CfaColorAt(raw.cfa, x0 + dx, y0 + dy);
          rgb[colour] += std::max(0, int(raw.mosaic(x0 + dx, y0 + dy)) - int(raw.BlackAt(x0 + dx, y0 + dy)));
          ++count[colour];
        }
      // x4: a frame exposed for no clipping sits in the lower quarter of the range.
      line[tx] = qRgb(ToSrgb8(4 * rgb[0] / count[0] / range), ToSrgb8(4 * rgb[1] / count[1] / range),
                      ToSrgb8(4 * rgb[2] / count[2] / range));
    }
  }
  return image;
}

QImage DecodePreview(const std::vector<uint8_t>& bytes) {
  QImage frame = QImage::fromData(bytes.data(), int(bytes.size())).convertToFormat(QImage::Format_RGB32);
  if (frame.isNull()) return frame;
  constexpr int kHistogramHeight = 80;
  std::vector<int> histogram(256, 0);
  for (int y = 0; y < frame.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(frame.scanLine(y));
    for (int x = 0; x < frame.width(); ++x) {
      const QRgb p = line[x];
      ++histogram[qGray(p)];
      // Any channel at the top of the range: clipped, shown in red.
      if (qRed(p) >= 254 || qGreen(p) >= 254 || qBlue(p) >= 254) line[x] = qRgb(255, 0, 0);
    }
  }
  QImage out(frame.width(), frame.height() + kHistogramHeight, QImage::Format_RGB32);
  out.fill(qRgb(25, 25, 25));
  QPainter painter(&out);
  painter.drawImage(0, 0, frame);
  const int peak = std::max(1, *std::max_element(histogram.begin(), histogram.end() - 1));
  for (int v = 0; v < 256; ++v) {
    const int x = v * out.width() / 256;
    const int bar = std::min(kHistogramHeight, histogram[v] * kHistogramHeight / peak);
    painter.setPen(v >= 254 ? QColor(255, 60, 60) : QColor(200, 200, 200));
    painter.drawLine(x, out.height() - 1, x, out.height() - bar);
  }
  return out;
}

}  // namespace scanbench
