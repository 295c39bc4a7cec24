#include "maps/tileable_crop.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/field_error.h"

namespace scanbench {
namespace {

constexpr double kMinNormalZ = 0.01;  // slope at most 100 (89.4 deg): keeps grazing normals finite

std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// Sums of a W x H image over boxes, by its (W + 1) x (H + 1) integral image.
class BoxSums {
 public:
  explicit BoxSums(const cv::Mat& image) { cv::integral(image, integral_, CV_64F); }
  double Sum(int x, int y, int width, int height) const {
    return integral_.at<double>(y + height, x + width) - integral_.at<double>(y, x + width) -
           integral_.at<double>(y + height, x) + integral_.at<double>(y, x);
  }

 private:
  cv::Mat integral_;
};

// Per-pixel sum over channels of |image(x + dx, y + dy) - image(x, y)|, for
// the positions where both lie inside: (W - dx) x (H - dy).
cv::Mat ShiftedDifference(const ImageF& image, int dx, int dy) {
  cv::Mat difference(image.height() - dy, image.width() - dx, CV_32F);
  const int channels = image.channels();
  for (int y = 0; y < difference.rows; ++y) {
    float* out = difference.ptr<float>(y);
    for (int x = 0; x < difference.cols; ++x) {
      double sum = 0;
      for (int c = 0; c < channels; ++c) {
        sum += std::abs(static_cast<double>(image(x + dx, y + dy, c)) - image(x, y, c));
      }
      out[x] = static_cast<float>(sum);
    }
  }
  return difference;
}

double Smoothstep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

std::array<double, 2> NormalToSlope(const ImageF& image, int x, int y) {
  double nx = image(x, y, 0), ny = image(x, y, 1), nz = image(x, y, 2);
  if (!std::isfinite(nx) || !std::isfinite(ny) || !std::isfinite(nz) || nx * nx + ny * ny + nz * nz < 1e-12) {
    return {0.0, 0.0};
  }
  const double length = std::sqrt(nx * nx + ny * ny + nz * nz);
  nz = std::max(nz / length, kMinNormalZ);
  return {nx / length / nz, ny / length / nz};
}

// The normal at (x, y) normalised; zero or non-finite ones become (0, 0, 1).
std::array<float, 3> UnitNormal(const ImageF& image, int x, int y) {
  const double nx = image(x, y, 0), ny = image(x, y, 1), nz = image(x, y, 2);
  const double length = std::sqrt(nx * nx + ny * ny + nz * nz);
  if (!std::isfinite(length) || length < 1e-6) return {0.0f, 0.0f, 1.0f};
  return {static_cast<float>(nx / length), static_cast<float>(ny / length), static_cast<float>(nz / length)};
}

// The figures of the summary for one tile (first map).
struct TileFigures {
  double wrap = 0, neighbour = 0;
};

TileFigures MeasureTile(const ImageF& tile) {
  const int w = tile.width(), h = tile.height(), channels = tile.channels();
  auto difference = [&](int xa, int ya, int xb, int yb) {
    double sum = 0;
    for (int c = 0; c < channels; ++c) sum += std::abs(static_cast<double>(tile(xa, ya, c)) - tile(xb, yb, c));
    return sum / channels;
  };
  TileFigures figures;
  double wrap_sum = 0, neighbour_sum = 0;
  size_t wrap_count = 0, neighbour_count = 0;
  for (int y = 0; y < h; ++y) {
    wrap_sum += difference(0, y, w - 1, y);
    ++wrap_count;
    for (int x = 0; x + 1 < w; ++x) {
      neighbour_sum += difference(x + 1, y, x, y);
      ++neighbour_count;
    }
  }
  for (int x = 0; x < w; ++x) {
    wrap_sum += difference(x, 0, x, h - 1);
    ++wrap_count;
    for (int y = 0; y + 1 < h; ++y) {
      neighbour_sum += difference(x, y + 1, x, y);
      ++neighbour_count;
    }
  }
  figures.wrap = wrap_count > 0 ? wrap_sum / wrap_count : 0;
  figures.neighbour = neighbour_count > 0 ? neighbour_sum / neighbour_count : 0;
  return figures;
}

void CheckInputs(const std::vector<TileableMapInput>& maps, const ImageU8* valid, std::vector<ImageF>* tiles) {
  if (tiles == nullptr) throw std::invalid_argument("tileable crop: tiles must not be null");
  if (maps.empty()) throw std::invalid_argument("tileable crop: no maps given");
  for (size_t i = 0; i < maps.size(); ++i) {
    const ImageF* image = maps[i].image;
    const std::string name = "tileable crop: maps[" + std::to_string(i) + "]";
    if (image == nullptr || image->empty()) throw std::invalid_argument(name + " is null or empty");
    if (!image->SameSize(*maps[0].image)) {
      throw std::invalid_argument(name + " is " + SizeText(image->width(), image->height()) + ", maps[0] is " +
                                  SizeText(maps[0].image->width(), maps[0].image->height()) +
                                  "; all maps must share one size");
    }
    if (maps[i].kind == TileMapKind::kNormal && image->channels() != 3) {
      throw std::invalid_argument(name + " is a normal map with " + std::to_string(image->channels()) +
                                  " channels, must have 3");
    }
  }
  if (valid != nullptr && (!valid->SameSize(*maps[0].image) || valid->channels() != 1)) {
    throw std::invalid_argument("tileable crop: valid mask is " + SizeText(valid->width(), valid->height()) + "x" +
                                std::to_string(valid->channels()) + ", must be " +
                                SizeText(maps[0].image->width(), maps[0].image->height()) + "x1");
  }
}

}  // namespace

void TileableCropOptions::Check() const {
  if (tile_width < 0) throw FieldError("TileableCropOptions", "tile_width", tile_width, "must be >= 0 (0 = automatic)");
  if (tile_height < 0) {
    throw FieldError("TileableCropOptions", "tile_height", tile_height, "must be >= 0 (0 = automatic)");
  }
  if (blend_width_px < 1) throw FieldError("TileableCropOptions", "blend_width_px", blend_width_px, "must be >= 1");
  if (tile_width > 0 && blend_width_px > tile_width) {
    throw FieldError("TileableCropOptions", "blend_width_px", blend_width_px,
                     "must be <= tile_width (" + std::to_string(tile_width) + ")");
  }
  const int height = tile_height > 0 ? tile_height : tile_width;
  if (height > 0 && blend_width_px > height) {
    throw FieldError("TileableCropOptions", "blend_width_px", blend_width_px,
                     "must be <= tile_height (" + std::to_string(height) + ")");
  }
}

TileableCropSummary MakeTileableCrop(const std::vector<TileableMapInput>& maps, const ImageU8* valid,
                                     const TileableCropOptions& options, std::vector<ImageF>* tiles) {
  const auto start = std::chrono::steady_clock::now();
  options.Check();
  CheckInputs(maps, valid, tiles);
  tiles->clear();
  TileableCropSummary summary;
  const ImageF& first = *maps[0].image;
  const int width = first.width(), height = first.height();
  const int band = options.blend_width_px;
  summary.blend_width_px = band;
  auto finish = [&](Termination termination, const std::string& message) {
    summary.termination = termination;
    summary.message = message;
    summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return summary;
  };

  // Invalid pixels, counted over boxes: a window fits where its box holds none.
  cv::Mat invalid(height, width, CV_8U, cv::Scalar(0));
  if (valid != nullptr) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) invalid.at<uint8_t>(y, x) = (*valid)(x, y) == 0 ? 1 : 0;
    }
  }
  const BoxSums invalid_sums(invalid);
  // Every top-left where a box of this size lies on valid pixels only.
  auto for_each_fit = [&](int box_width, int box_height, const auto& visit) {
    for (int y = 0; y + box_height <= height; ++y) {
      for (int x = 0; x + box_width <= width; ++x) {
        if (invalid_sums.Sum(x, y, box_width, box_height) == 0 && !visit(x, y)) return;
      }
    }
  };
  auto fits = [&](int tile_w, int tile_h) {
    if (tile_w + band > width || tile_h + band > height) return false;
    bool found = false;
    for_each_fit(tile_w + band, tile_h + band, [&](int, int) { return !(found = true); });
    return found;
  };
  // The largest power of two >= band for the automatic size(s).
  auto largest_power_of_two = [&](const auto& fits_size) {
    int size = 1;
    while (size * 2 <= std::max(width, height)) size *= 2;
    for (; size >= std::max(band, 1); size /= 2) {
      if (fits_size(size)) return size;
    }
    return 0;
  };

  int tile_w = options.tile_width, tile_h = options.tile_height;
  if (tile_w == 0 && tile_h == 0) {
    tile_w = tile_h = largest_power_of_two([&](int size) { return fits(size, size); });
  } else if (tile_w == 0) {
    tile_w = largest_power_of_two([&](int size) { return fits(size, tile_h); });
  } else if (tile_h == 0) {
    tile_h = tile_w;
  }
  std::ostringstream failure;
  if (tile_w == 0 || tile_h == 0) {
    int smallest = 1;  // the smallest power of two not below the band
    while (smallest < band) smallest *= 2;
    const int smallest_h = options.tile_height > 0 ? options.tile_height : smallest;
    failure << "no power-of-two tile fits: the smallest, " << SizeText(smallest, smallest_h) << " (not below the "
            << band << " px blend band), needs " << SizeText(smallest + band, smallest_h + band)
            << " valid pixels in one window; the maps are " << SizeText(width, height)
            << (valid != nullptr ? " with a valid mask" : "");
    return finish(Termination::kFailure, failure.str());
  }
  if (!fits(tile_w, tile_h)) {
    failure << "a " << SizeText(tile_w, tile_h) << " tile with its " << band << " px blend band needs "
            << SizeText(tile_w + band, tile_h + band) << " valid pixels in one window; the maps are "
            << SizeText(width, height) << (valid != nullptr ? " and no such window is all valid" : "");
    return finish(Termination::kFailure, failure.str());
  }
  summary.tile_width = tile_w;
  summary.tile_height = tile_h;

  // Cost of a position: mean difference of the two copies mixed in the bands
  // (columns x0 .. x0 + B against x0 + W .., rows alike), first map.
  const BoxSums horizontal(ShiftedDifference(first, tile_w, 0));
  const BoxSums vertical(ShiftedDifference(first, 0, tile_h));
  const double band_pixels = static_cast<double>(band) * (tile_w + tile_h) * first.channels();
  auto cost = [&](int x, int y) {
    return (horizontal.Sum(x, y, band, tile_h) + vertical.Sum(x, y, tile_w, band)) / band_pixels;
  };
  const double centre_x = 0.5 * (width - tile_w - band), centre_y = 0.5 * (height - tile_h - band);
  double best_cost = std::numeric_limits<double>::infinity(), best_distance = best_cost;
  int best_x = -1, best_y = -1;
  for_each_fit(tile_w + band, tile_h + band, [&](int x, int y) {
    const double distance = std::hypot(x - centre_x, y - centre_y);
    const double c = options.search_position ? cost(x, y) : 0.0;
    if (c < best_cost || (c == best_cost && distance < best_distance)) {
      best_cost = c;
      best_distance = distance;
      best_x = x;
      best_y = y;
    }
    return true;
  });
  summary.x0 = best_x;
  summary.y0 = best_y;
  summary.seam_cost = cost(best_x, best_y);

  // Weight of the window's own pixel (1 - weight goes to the continuation).
  std::vector<double> weight_x(tile_w, 1.0), weight_y(tile_h, 1.0);
  for (int i = 0; i < band; ++i) {
    weight_x[i] = Smoothstep((i + 0.5) / band);
    weight_y[i] = Smoothstep((i + 0.5) / band);
  }
  tiles->reserve(maps.size());
  for (const TileableMapInput& input : maps) {
    const ImageF& source = *input.image;
    const int channels = source.channels();
    ImageF tile(tile_w, tile_h, channels);
    for (int y = 0; y < tile_h; ++y) {
      for (int x = 0; x < tile_w; ++x) {
        const int sx = best_x + x, sy = best_y + y;
        const double wx = weight_x[x], wy = weight_y[y];
        if (wx == 1.0 && wy == 1.0) {
          if (input.kind == TileMapKind::kNormal) {
            const std::array<float, 3> unit = UnitNormal(source, sx, sy);
            for (int c = 0; c < 3; ++c) tile(x, y, c) = unit[c];
          } else {
            for (int c = 0; c < channels; ++c) tile(x, y, c) = source(sx, sy, c);
          }
          continue;
        }
        // The window pixel and its continuations past the right, bottom and both edges.
        const std::array<std::array<int, 2>, 4> at = {
            {{sx, sy}, {sx + tile_w, sy}, {sx, sy + tile_h}, {sx + tile_w, sy + tile_h}}};
        const std::array<double, 4> weight = {wx * wy, (1 - wx) * wy, wx * (1 - wy), (1 - wx) * (1 - wy)};
        if (input.kind == TileMapKind::kNormal) {
          double px = 0, py = 0;
          for (int k = 0; k < 4; ++k) {
            if (weight[k] == 0.0) continue;  // outside the band the continuation lies beyond the window + band
            const std::array<double, 2> slope = NormalToSlope(source, at[k][0], at[k][1]);
            px += weight[k] * slope[0];
            py += weight[k] * slope[1];
          }
          const double length = std::sqrt(px * px + py * py + 1.0);
          tile(x, y, 0) = static_cast<float>(px / length);
          tile(x, y, 1) = static_cast<float>(py / length);
          tile(x, y, 2) = static_cast<float>(1.0 / length);
        } else {
          for (int c = 0; c < channels; ++c) {
            double value = 0;
            for (int k = 0; k < 4; ++k) {
              if (weight[k] != 0.0) value += weight[k] * source(at[k][0], at[k][1], c);
            }
            tile(x, y, c) = static_cast<float>(value);
          }
        }
      }
    }
    tiles->push_back(std::move(tile));
  }

  const TileFigures blended = MeasureTile(tiles->front());
  ImageF naive(tile_w, tile_h, first.channels());
  for (int y = 0; y < tile_h; ++y) {
    for (int x = 0; x < tile_w; ++x) {
      for (int c = 0; c < first.channels(); ++c) naive(x, y, c) = first(best_x + x, best_y + y, c);
    }
  }
  summary.wrap_difference = blended.wrap;
  summary.neighbour_difference = blended.neighbour;
  summary.naive_wrap_difference = MeasureTile(naive).wrap;
  std::ostringstream message;
  message << "tile " << SizeText(tile_w, tile_h) << " at (" << best_x << ", " << best_y << ") of "
          << SizeText(width, height) << ", blend " << band << " px"
          << (options.search_position ? ", placed by seam search" : ", centred") << "; wrap difference "
          << summary.wrap_difference << " (plain crop " << summary.naive_wrap_difference << ", interior neighbours "
          << summary.neighbour_difference << ")";
  return finish(Termination::kSuccess, message.str());
}

}  // namespace scanbench
