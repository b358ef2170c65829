#pragma once

#include <cmath>
#include <cstdint>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace dg::stages::render {

// Bilinear lookup in a CV_8UC3 (BGR) texture, values scaled to [0, 1] and
// treated as linear. Texel (i, j) is centred at (u, v) = ((i + 1/2)/W, (j + 1/2)/H).
// u wraps (a closed surface's seam meets itself without a visible line); v is
// clamped (the poles of such a surface do not wrap). Does not own the texture.
class TextureSampler {
 public:
  // @pre texture is non-empty CV_8UC3 and outlives the sampler.
  explicit TextureSampler(const cv::Mat& texture)
      : data_(texture.data), step_(texture.step[0]), width_(texture.cols), height_(texture.rows) {}

  // @pre uv finite, |u| and |v| below 2^20 (so texel indices fit an int).
  Eigen::Vector3f Sample(const Eigen::Vector2f& uv) const {
    const float x = uv.x() * width_ - 0.5f;
    const float y = uv.y() * height_ - 0.5f;
    const float x_floor = std::floor(x), y_floor = std::floor(y);
    const float ax = x - x_floor, ay = y - y_floor;
    int i0 = static_cast<int>(x_floor);
    if (i0 < 0 || i0 >= width_) {
      i0 %= width_;
      if (i0 < 0) i0 += width_;
    }
    const int i1 = i0 + 1 == width_ ? 0 : i0 + 1;
    const int j = static_cast<int>(y_floor);
    const int j0 = j < 0 ? 0 : (j >= height_ ? height_ - 1 : j);
    const int j1 = j + 1 < 0 ? 0 : (j + 1 >= height_ ? height_ - 1 : j + 1);
    const std::uint8_t* row0 = data_ + j0 * step_;
    const std::uint8_t* row1 = data_ + j1 * step_;
    Eigen::Vector3f bgr;
    for (int c = 0; c < 3; ++c) {
      const float top = (1 - ax) * row0[3 * i0 + c] + ax * row0[3 * i1 + c];
      const float bottom = (1 - ax) * row1[3 * i0 + c] + ax * row1[3 * i1 + c];
      bgr[c] = ((1 - ay) * top + ay * bottom) * (1.0f / 255.0f);
    }
    return bgr;
  }

 private:
  const std::uint8_t* data_;
  std::size_t step_;
  int width_, height_;
};

}  // namespace dg::stages::render
