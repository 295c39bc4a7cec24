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
#include "core/format.h"

namespace scanbench {
namespace {

constexpr double kMinNormalZ = 0.01;  // slope at most 100 (89.4 deg): keeps grazing normals finite

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

// Where a box of valid pixels fits, by the integral image of the invalid ones.
class ValidWindows {
 public:
  ValidWindows(const ImageU8* valid, int width, int height)
      : width_(width), height_(height), invalid_sums_(InvalidMap(valid, width, height)) {}

  // visit(x, y) for every top-left where a box_width x box_height box lies on
  // valid pixels only, row by row, until visit returns false.
  template <typename Visit>
  void ForEachFit(int box_width, int box_height, const Visit& visit) const {
    for (int y = 0; y + box_height <= height_; ++y) {
      for (int x = 0; x + box_width <= width_; ++x) {
        if (invalid_sums_.Sum(x, y, box_width, box_height) == 0 && !visit(x, y)) return;
      }
    }
  }
  // A tile with its blend band fits somewhere.
  bool Fits(int tile_width, int tile_height, int band) const {
    if (tile_width + band > width_ || tile_height + band > height_) return false;
    bool found = false;
    ForEachFit(tile_width + band, tile_height + band, [&](int, int) { return !(found = true); });
    return found;
  }

 private:
  static cv::Mat InvalidMap(const ImageU8* valid, int width, int height) {
    cv::Mat invalid(height, width, CV_8U, cv::Scalar(0));
    if (valid != nullptr) {
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) invalid.at<uint8_t>(y, x) = (*valid)(x, y) == 0 ? 1 : 0;
      }
    }
    return invalid;
  }
  int width_, height_;
  BoxSums invalid_sums_;
};

// The tile size: as asked, or the largest power of two (>= the band) that
// fits for each automatic side; 0 where none does.
std::pair<int, int> ChooseTileSize(const TileableCropOptions& options, const ValidWindows& windows, int width,
                                   int height) {
  const int band = options.blend_width_px;
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
    tile_w = tile_h = largest_power_of_two([&](int size) { return windows.Fits(size, size, band); });
  } else if (tile_w == 0) {
    tile_w = largest_power_of_two([&](int size) { return windows.Fits(size, tile_h, band); });
  } else if (tile_h == 0) {
    tile_h = tile_w;
  }
  return {tile_w, tile_h};
}

// Why no automatic power-of-two tile fits.
std::string NoPowerOfTwoFits(const TileableCropOptions& options, int width, int height, bool masked) {
  const int band = options.blend_width_px;
  int smallest = 1;  // the smallest power of two not below the band
  while (smallest < band) smallest *= 2;
  const int smallest_h = options.tile_height > 0 ? options.tile_height : smallest;
  std::ostringstream failure;
  failure << "no power-of-two tile fits: the smallest, " << SizeText(smallest, smallest_h) << " (not below the "
          << band << " px blend band), needs " << SizeText(smallest + band, smallest_h + band)
          << " valid pixels in one window; the maps are " << SizeText(width, height)
          << (masked ? " with a valid mask" : "");
  return failure.str();
}

// Why the asked tile size does not fit.
std::string TileDoesNotFit(int tile_w, int tile_h, int band, int width, int height, bool masked) {
  std::ostringstream failure;
  failure << "a " << SizeText(tile_w, tile_h) << " tile with its " << band << " px blend band needs "
          << SizeText(tile_w + band, tile_h + band) << " valid pixels in one window; the maps are "
          << SizeText(width, height) << (masked ? " and no such window is all valid" : "");
  return failure.str();
}

struct TilePosition {
  int x0 = -1, y0 = -1;
  double seam_cost = 0;
};

// The top-left of the window whose wrap seam differs least: the cost of a
// position is the mean difference of the two copies mixed in the bands
// (columns x0 .. x0 + B against x0 + W .., rows alike) of `first`. Ties (and
// every position without the search) go to the one nearest the centre.
TilePosition FindTilePosition(const ImageF& first, const ValidWindows& windows, int tile_w, int tile_h, int band,
                              bool search_position) {
  const int width = first.width(), height = first.height();
  const BoxSums horizontal(ShiftedDifference(first, tile_w, 0));
  const BoxSums vertical(ShiftedDifference(first, 0, tile_h));
  const double band_pixels = static_cast<double>(band) * (tile_w + tile_h) * first.channels();
  auto cost = [&](int x, int y) {
    return (horizontal.Sum(x, y, band, tile_h) + vertical.Sum(x, y, tile_w, band)) / band_pixels;
  };
  const double centre_x = 0.5 * (width - tile_w - band), centre_y = 0.5 * (height - tile_h - band);
  double best_cost = std::numeric_limits<double>::infinity(), best_distance = best_cost;
  TilePosition best;
  windows.ForEachFit(tile_w + band, tile_h + band, [&](int x, int y) {
    const double distance = std::hypot(x - centre_x, y - centre_y);
    const double c = search_position ? cost(x, y) : 0.0;
    if (c < best_cost || (c == best_cost && distance < best_distance)) {
      best_cost = c;
      best_distance = distance;
      best.x0 = x;
      best.y0 = y;
    }
    return true;
  });
  best.seam_cost = cost(best.x0, best.y0);
  return best;
}

// One map's tile: the window at `at`, its first `band` columns and rows
// cross-faded with the continuation past the right and bottom edges.
ImageF BlendTile(const TileableMapInput& input, const TilePosition& at, int tile_w, int tile_h, int band) {
  // Weight of the window's own pixel (1 - weight goes to the continuation).
  std::vector<double> weight_x(tile_w, 1.0), weight_y(tile_h, 1.0);
  for (int i = 0; i < band; ++i) {
    weight_x[i] = Smoothstep((i + 0.5) / band);
    weight_y[i] = Smoothstep((i + 0.5) / band);
  }
  const ImageF& source = *input.image;
  const int channels = source.channels();
  ImageF tile(tile_w, tile_h, channels);
  for (int y = 0; y < tile_h; ++y) {
    for (int x = 0; x < tile_w; ++x) {
      const int sx = at.x0 + x, sy = at.y0 + y;
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
      const std::array<std::array<int, 2>, 4> from = {
          {{sx, sy}, {sx + tile_w, sy}, {sx, sy + tile_h}, {sx + tile_w, sy + tile_h}}};
      const std::array<double, 4> weight = {wx * wy, (1 - wx) * wy, wx * (1 - wy), (1 - wx) * (1 - wy)};
      if (input.kind == TileMapKind::kNormal) {
        double px = 0, py = 0;
        for (int k = 0; k < 4; ++k) {
          if (weight[k] == 0.0) continue;  // outside the band the continuation lies beyond the window + band
          const std::array<double, 2> slope = NormalToSlope(source, from[k][0], from[k][1]);
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
            if (weight[k] != 0.0) value += weight[k] * source(from[k][0], from[k][1], c);
          }
          tile(x, y, c) = static_cast<float>(value);
        }
      }
    }
  }
  return tile;
}

// The summary's differences: across the wrap and between interior neighbours
// of the blended tile, and across the wrap of the plain window.
void MeasureWrap(const ImageF& first, const ImageF& first_tile, const TilePosition& at,
                 TileableCropSummary* summary) {
  const int tile_w = first_tile.width(), tile_h = first_tile.height();
  const TileFigures blended = MeasureTile(first_tile);
  ImageF naive(tile_w, tile_h, first.channels());
  for (int y = 0; y < tile_h; ++y) {
    for (int x = 0; x < tile_w; ++x) {
      for (int c = 0; c < first.channels(); ++c) naive(x, y, c) = first(at.x0 + x, at.y0 + y, c);
    }
  }
  summary->wrap_difference = blended.wrap;
  summary->neighbour_difference = blended.neighbour;
  summary->naive_wrap_difference = MeasureTile(naive).wrap;
}

}  // namespace

void TileableCropOptions::Check() const {
  SCANBENCH_REQUIRE_GE("TileableCropOptions", "tile_width", tile_width, 0, "(0 = automatic)");
  SCANBENCH_REQUIRE_GE("TileableCropOptions", "tile_height", tile_height, 0, "(0 = automatic)");
  SCANBENCH_REQUIRE_GE("TileableCropOptions", "blend_width_px", blend_width_px, 1);
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

std::string TileableCropSummary::BriefReport() const {
  std::string report = std::string("Tileable crop: ") + TerminationName(termination);
  if (termination == Termination::kSuccess) {
    report += ", " + SizeText(tile_width, tile_height) + " at (" + std::to_string(x0) + ", " + std::to_string(y0) +
              "), blend " + std::to_string(blend_width_px) + " px, wrap difference " + Fixed(wrap_difference, 3) +
              " (plain crop " + Fixed(naive_wrap_difference, 3) + ")";
  }
  report += ", " + Fixed(seconds, 2) + " s";
  if (termination != Termination::kSuccess) report += " (" + message + ")";
  return report;
}

TileableCropSummary MakeTileableCrop(const TileableCropOptions& options, const std::vector<TileableMapInput>& maps,
                                     const ImageU8* valid, std::vector<ImageF>* tiles,
                                     const ProgressCallback& progress) {
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
    summary.seconds = SecondsSince(start);
    if (termination != Termination::kSuccess) tiles->clear();
    return summary;
  };
  auto cancelled = [&](double fraction) { return progress && !progress(fraction); };

  const ValidWindows windows(valid, width, height);
  const auto [tile_w, tile_h] = ChooseTileSize(options, windows, width, height);
  if (tile_w == 0 || tile_h == 0) {
    return finish(Termination::kFailure, NoPowerOfTwoFits(options, width, height, valid != nullptr));
  }
  if (!windows.Fits(tile_w, tile_h, band)) {
    return finish(Termination::kFailure, TileDoesNotFit(tile_w, tile_h, band, width, height, valid != nullptr));
  }
  summary.tile_width = tile_w;
  summary.tile_height = tile_h;

  const TilePosition at = FindTilePosition(first, windows, tile_w, tile_h, band, options.search_position);
  summary.x0 = at.x0;
  summary.y0 = at.y0;
  summary.seam_cost = at.seam_cost;
  if (cancelled(0.5)) return finish(Termination::kCancelled, "tileable crop cancelled after the window search");

  tiles->reserve(maps.size());
  for (size_t i = 0; i < maps.size(); ++i) {
    tiles->push_back(BlendTile(maps[i], at, tile_w, tile_h, band));
    if (cancelled(0.5 + 0.5 * static_cast<double>(i + 1) / maps.size())) {
      return finish(Termination::kCancelled, "tileable crop cancelled after " + std::to_string(i + 1) + " of " +
                                                 std::to_string(maps.size()) + " maps");
    }
  }
  MeasureWrap(first, tiles->front(), at, &summary);

  std::ostringstream message;
  message << "tile " << SizeText(tile_w, tile_h) << " at (" << at.x0 << ", " << at.y0 << ") of "
          << SizeText(width, height) << ", blend " << band << " px"
          << (options.search_position ? ", placed by seam search" : ", centred") << "; wrap difference "
          << summary.wrap_difference << " (plain crop " << summary.naive_wrap_difference << ", interior neighbours "
          << summary.neighbour_difference << ")";
  return finish(Termination::kSuccess, message.str());
}

}  // namespace scanbench
