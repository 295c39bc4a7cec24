// An image in memory: interleaved channels, row-major, no file I/O.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace scanbench {

template <typename T>
class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, T fill = T{})
      : width_(width), height_(height), channels_(channels) {
    if (width < 0 || height < 0 || channels < 0) {
      throw std::invalid_argument("Image size " + std::to_string(width) + "x" +
                                  std::to_string(height) + "x" + std::to_string(channels) +
                                  " must not be negative");
    }
    data_.assign(static_cast<size_t>(width) * height * channels, fill);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  size_t num_pixels() const { return static_cast<size_t>(width_) * height_; }
  size_t size() const { return data_.size(); }

  T& operator()(int x, int y, int c = 0) { return data_[Index(x, y, c)]; }
  const T& operator()(int x, int y, int c = 0) const { return data_[Index(x, y, c)]; }

  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  T* row(int y) { return data_.data() + static_cast<size_t>(y) * width_ * channels_; }
  const T* row(int y) const { return data_.data() + static_cast<size_t>(y) * width_ * channels_; }

  // Gives the image the shape width x height x channels: its buffer is kept when it has that shape already
  // (an image filled again band after band: no fresh memory, whose first touch costs more than a fill), else
  // the image is made anew. The first form leaves the values undefined for the caller to overwrite (those of
  // before when the buffer was kept, T{} when made anew); the second sets every value to `fill` either way.
  void Reshape(int width, int height, int channels) {
    if (!SameShape(width, height, channels)) *this = Image(width, height, channels);
  }
  void Reshape(int width, int height, int channels, T fill) {
    if (SameShape(width, height, channels)) {
      std::fill(data_.begin(), data_.end(), fill);
    } else {
      *this = Image(width, height, channels, fill);
    }
  }

  bool SameSize(int width, int height) const { return width_ == width && height_ == height; }
  template <typename U>
  bool SameSize(const Image<U>& other) const {
    return width_ == other.width() && height_ == other.height();
  }

 private:
  bool SameShape(int width, int height, int channels) const {
    return width_ == width && height_ == height && channels_ == channels;
  }
  size_t Index(int x, int y, int c) const {
    return (static_cast<size_t>(y) * width_ + x) * channels_ + c;
  }

  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  std::vector<T> data_;
};

// For error messages: "1232x816" and "1232x816x3".
inline std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }
template <typename T>
std::string ShapeText(const Image<T>& image) {
  return SizeText(image.width(), image.height()) + "x" + std::to_string(image.channels());
}

using ImageF = Image<float>;
using ImageU8 = Image<uint8_t>;
using ImageU16 = Image<uint16_t>;

}  // namespace scanbench
