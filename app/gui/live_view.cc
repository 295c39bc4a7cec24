#include "app/gui/live_view.h"

#include <QColor>
#include <QPainter>
#include <algorithm>
#include <array>
#include <cmath>

namespace scanbench {

namespace {

constexpr int kHistogramHeight = 80;
constexpr QRgb kClipped = 0xffff0000;  // opaque red

// `frame` over a histogram of `bins` (the last `hot_bins` in red).
QImage WithHistogram(const QImage& frame, const std::vector<int>& bins, int first_hot_bin) {
  QImage out(frame.width(), frame.height() + kHistogramHeight, QImage::Format_RGB32);
  out.fill(qRgb(25, 25, 25));
  QPainter painter(&out);
  painter.drawImage(0, 0, frame);
  // The peak of the unclipped bins: a clipped spike must not flatten the rest.
  const auto unclipped_end = bins.begin() + std::clamp<int>(first_hot_bin, 1, int(bins.size()));
  const int peak = std::max(1, *std::max_element(bins.begin(), unclipped_end));
  const int num_bins = int(bins.size());
  for (int v = 0; v < num_bins; ++v) {
    // Each bin as wide as its share of the picture: no gaps where columns outnumber bins.
    const int x0 = v * out.width() / num_bins;
    const int x1 = std::max(x0 + 1, (v + 1) * out.width() / num_bins);
    const int bar = std::min(kHistogramHeight, int(int64_t(bins[v]) * kHistogramHeight / peak));
    painter.fillRect(x0, out.height() - bar, x1 - x0, bar,
                     v >= first_hot_bin ? QColor(255, 60, 60) : QColor(200, 200, 200));
  }
  return out;
}

uint8_t Encode(double linear) {
  return static_cast<uint8_t>(std::lround(255 * std::pow(std::clamp(linear, 0.0, 1.0), 1 / 2.2)));
}

// Grey-world gains that make the mean of R and B equal that of G.
std::array<double, 3> GreyWorldGains(const std::array<double, 3>& sums) {
  std::array<double, 3> gains{1, 1, 1};
  for (int c : {0, 2}) gains[c] = sums[c] > 0 ? sums[1] / sums[c] : 1;
  return gains;
}

}  // namespace

DevelopedRawPreview DevelopRawPreview(const RawImage& raw, double clip_fraction, int max_width, double min_signal) {
  DevelopedRawPreview out;
  const int tiles_x = raw.width() / 2, tiles_y = raw.height() / 2;
  if (tiles_x < 1 || tiles_y < 1) return out;
  const int step = std::max(1, (tiles_x + std::max(1, max_width) - 1) / std::max(1, max_width));
  const int width = std::max(1, tiles_x / step), height = std::max(1, tiles_y / step);
  // The rule RawDevelopOptions uses: at or above clip_fraction x white level.
  const int clip_level = static_cast<int>(clip_fraction * raw.white_level);
  constexpr int kBins = 256;
  out.bins.assign(kBins, 0);
  out.first_hot_bin = std::min(kBins - 1, int(int64_t(clip_level) * kBins / (raw.white_level + 1)));

  std::vector<float> rgb(size_t(width) * height * 3, 0.0f);
  std::vector<uint8_t> clipped(size_t(width) * height, 0);
  std::array<double, 3> sums{0, 0, 0};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      int brightest = 0;
      for (int py = 2 * y * step; py < 2 * (y + 1) * step; ++py) {
        for (int px = 2 * x * step; px < 2 * (x + 1) * step; ++px) {
          const int value = raw.mosaic(px, py);
          brightest = std::max(brightest, value);
          const int colour = CfaColorAt(raw.cfa, px, py);
          sum[colour] += std::max(0, value - int(raw.BlackAt(px, py)));
          ++count[colour];
        }
      }
      const size_t i = size_t(y) * width + x;
      clipped[i] = brightest >= clip_level;
      ++out.bins[std::min(kBins - 1, int(int64_t(brightest) * kBins / (raw.white_level + 1)))];
      for (int c = 0; c < 3; ++c) {
        rgb[i * 3 + c] = count[c] ? float(sum[c] / count[c]) : 0.0f;
        sums[c] += rgb[i * 3 + c];
      }
    }
  }
  const std::array<double, 3> gains = GreyWorldGains(sums);
  std::vector<float> green;
  green.reserve(size_t(width) * height);
  for (size_t i = 1; i < rgb.size(); i += 3) green.push_back(rgb[i]);
  const size_t rank = green.size() * 99 / 100;
  std::nth_element(green.begin(), green.begin() + rank, green.end());
  const double min_level = min_signal * std::max(1.0, double(raw.white_level) - raw.BlackAt(0, 0));
  const double gain = 0.9 / std::max({1e-3, double(green[rank]), min_level});

  QImage frame(width, height, QImage::Format_RGB32);
  size_t num_clipped = 0;
  for (int y = 0; y < height; ++y) {
    auto* line = reinterpret_cast<QRgb*>(frame.scanLine(y));
    for (int x = 0; x < width; ++x) {
      const size_t i = size_t(y) * width + x;
      if (clipped[i]) {
        line[x] = kClipped;
        ++num_clipped;
        continue;
      }
      line[x] = qRgb(Encode(rgb[i * 3] * gains[0] * gain), Encode(rgb[i * 3 + 1] * gains[1] * gain),
                     Encode(rgb[i * 3 + 2] * gains[2] * gain));
    }
  }
  out.clipped_fraction = double(num_clipped) / (double(width) * height);
  out.image = frame;
  return out;
}

LiveFrame LiveFrameFromRaw(const RawImage& raw, double clip_fraction, int max_width) {
  LiveFrame live;
  live.from_raw = true;
  const DevelopedRawPreview developed = DevelopRawPreview(raw, clip_fraction, max_width);
  if (developed.image.isNull()) {
    live.error = QStringLiteral("the RAW frame is empty");
    return live;
  }
  live.clipped_fraction = developed.clipped_fraction;
  live.image = WithHistogram(developed.image, developed.bins, developed.first_hot_bin);
  return live;
}

LiveFrame LiveFrameFromPreview(const std::vector<uint8_t>& bytes, int clip_code) {
  LiveFrame live;
  QImage frame = QImage::fromData(bytes.data(), int(bytes.size())).convertToFormat(QImage::Format_RGB32);
  if (frame.isNull()) {
    live.error = QStringLiteral("the preview could not be decoded");
    return live;
  }
  std::array<double, 3> sums{0, 0, 0};
  for (int y = 0; y < frame.height(); ++y) {
    const auto* line = reinterpret_cast<const QRgb*>(frame.constScanLine(y));
    for (int x = 0; x < frame.width(); ++x) {
      sums[0] += qRed(line[x]);
      sums[1] += qGreen(line[x]);
      sums[2] += qBlue(line[x]);
    }
  }
  const std::array<double, 3> gains = GreyWorldGains(sums);
  std::vector<int> bins(256, 0);
  size_t num_clipped = 0;
  for (int y = 0; y < frame.height(); ++y) {
    auto* line = reinterpret_cast<QRgb*>(frame.scanLine(y));
    for (int x = 0; x < frame.width(); ++x) {
      const QRgb p = line[x];
      ++bins[qGray(p)];
      // Judged before white balance: the camera's own channels hit the top.
      if (qRed(p) >= clip_code || qGreen(p) >= clip_code || qBlue(p) >= clip_code) {
        line[x] = kClipped;
        ++num_clipped;
        continue;
      }
      line[x] = qRgb(std::min(255, int(std::lround(qRed(p) * gains[0]))), qGreen(p),
                     std::min(255, int(std::lround(qBlue(p) * gains[2]))));
    }
  }
  live.clipped_fraction = double(num_clipped) / (double(frame.width()) * frame.height());
  live.image = WithHistogram(frame, bins, clip_code);
  return live;
}

}  // namespace scanbench
