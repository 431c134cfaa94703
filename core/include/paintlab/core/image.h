#pragma once
// A plain interleaved image: width x height pixels of `channels` values of T, row-major.
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace paintlab {

template <class T>
class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels = 1, T fill = T{})
      : width_(width), height_(height), channels_(channels),
        data_(static_cast<std::size_t>(width) * height * channels, fill) {}

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  std::size_t size() const { return data_.size(); }
  std::size_t pixel_count() const { return static_cast<std::size_t>(width_) * height_; }

  T& at(int x, int y, int c = 0) {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_ && c >= 0 && c < channels_);
    return data_[(static_cast<std::size_t>(y) * width_ + x) * channels_ + c];
  }
  const T& at(int x, int y, int c = 0) const {
    assert(x >= 0 && x < width_ && y >= 0 && y < height_ && c >= 0 && c < channels_);
    return data_[(static_cast<std::size_t>(y) * width_ + x) * channels_ + c];
  }
  T* row(int y) { return data_.data() + static_cast<std::size_t>(y) * width_ * channels_; }
  const T* row(int y) const { return data_.data() + static_cast<std::size_t>(y) * width_ * channels_; }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  std::vector<T>& values() { return data_; }
  const std::vector<T>& values() const { return data_; }

 private:
  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  std::vector<T> data_;
};

using ImageF = Image<float>;
using ImageU16 = Image<std::uint16_t>;
using ImageU8 = Image<std::uint8_t>;

}  // namespace paintlab
