#include "app/devices/camera/raw_preview.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace scanbench {

std::vector<uint8_t> EncodePreviewPpm(const RawImage& raw, int max_width) {
  const int tiles_x = raw.width() / 2;
  const int tiles_y = raw.height() / 2;
  const int step = std::max(1, (tiles_x + std::max(1, max_width) - 1) / std::max(1, max_width));
  const int width = std::max(1, tiles_x / step);
  const int height = std::max(1, tiles_y / step);
  const double range = std::max(1, raw.white_level - *std::max_element(raw.black_level.begin(), raw.black_level.end()));

  // Linear RGB per output pixel: mean of its step x step CFA tiles.
  std::vector<float> rgb(static_cast<size_t>(width) * height * 3, 0.0f);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      for (int ty = y * step; ty < std::min(tiles_y, (y + 1) * step); ++ty) {
        for (int tx = x * step; tx < std::min(tiles_x, (x + 1) * step); ++tx) {
          for (int dy = 0; dy < 2; ++dy) {
            for (int dx = 0; dx < 2; ++dx) {
              const int px = 2 * tx + dx, py = 2 * ty + dy;
              const int color = CfaColorAt(raw.cfa, px, py);
              sum[color] += std::max(0.0, double(raw.mosaic(px, py)) - raw.BlackAt(px, py)) / range;
              ++count[color];
            }
          }
        }
      }
      for (int c = 0; c < 3; ++c) {
        rgb[(static_cast<size_t>(y) * width + x) * 3 + c] = count[c] ? float(sum[c] / count[c]) : 0.0f;
      }
    }
  }

  std::vector<float> green;
  green.reserve(static_cast<size_t>(width) * height);
  for (size_t i = 1; i < rgb.size(); i += 3) green.push_back(rgb[i]);
  const size_t rank = green.size() * 99 / 100;
  std::nth_element(green.begin(), green.begin() + rank, green.end());
  const double gain = 0.9 / std::max(1e-4f, green[rank]);

  const std::string header = "P6\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
  std::vector<uint8_t> bytes(header.begin(), header.end());
  bytes.reserve(bytes.size() + rgb.size());
  for (const float value : rgb) {
    const double encoded = std::pow(std::clamp(value * gain, 0.0, 1.0), 1.0 / 2.2);
    bytes.push_back(static_cast<uint8_t>(std::lround(encoded * 255.0)));
  }
  return bytes;
}

}  // namespace scanbench
