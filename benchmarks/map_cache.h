// What the maps benchmarks share: the field their synthetic maps span, one
// cached map per size, and the megapixel rate counter.
#pragma once

#include <functional>
#include <memory>
#include <mutex>
#include <utility>

#include <benchmark/benchmark.h>

#include "core/image.h"

namespace scanbench {

// Width of the field the benchmark maps span, mm: a size's pixel pitch is
// kFieldWidthMm / width, as on the rig.
inline constexpr double kFieldWidthMm = 150.0;

// A width x height map of `channels` whose pixel (x, y) is at(u_mm, v_mm,
// pixel): u = x, v = y times the pitch kFieldWidthMm / width.
inline ImageF SampleField(int width, int height, int channels,
                          const std::function<void(double u_mm, double v_mm, float* pixel)>& at) {
  ImageF map(width, height, channels);
  const double mm = kFieldWidthMm / width;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) at(x * mm, y * mm, &map(x, y));
  }
  return map;
}

// A synthetic map per size, made on first use and kept while that size is
// asked for: one map in memory at a time, so the 16 MP cases fit. The
// reference Get returns lives until Get is called for another size.
class MapCache {
 public:
  explicit MapCache(std::function<ImageF(int width, int height)> make) : make_(std::move(make)) {}

  const ImageF& Get(int width, int height) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (map_ == nullptr || size_ != std::make_pair(width, height)) {
      map_.reset();  // free the old one before making the next
      map_ = std::make_unique<ImageF>(make_(width, height));
      size_ = {width, height};
    }
    return *map_;
  }

 private:
  std::function<ImageF(int, int)> make_;
  std::mutex mutex_;
  std::unique_ptr<ImageF> map_;
  std::pair<int, int> size_{0, 0};
};

// The "MP/s" counter: width x height megapixels per iteration, as a rate.
inline void SetMegapixelRate(benchmark::State& state, int width, int height) {
  state.counters["MP/s"] = benchmark::Counter(static_cast<double>(width) * height * 1e-6 * state.iterations(),
                                              benchmark::Counter::kIsRate);
}

}  // namespace scanbench
