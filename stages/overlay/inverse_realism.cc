#include "stages/overlay/inverse_realism.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages::overlay {

std::string InverseRealismOptions::Validate() const {
  if (!(w_edge >= 0 && w_detail >= 0 && w_highlight >= 0)) return "weights must be non-negative";
  if (!(edge_scale > 0 && detail_scale > 0)) return "edge_scale and detail_scale must be positive";
  if (!(highlight_lo < highlight_hi)) return "highlight_lo must be below highlight_hi";
  if (!(strength >= 0 && strength <= 1)) return "strength must be within [0, 1]";
  return {};
}

cv::Mat Saliency(const cv::Mat& frame_bgr, const InverseRealismOptions& options) {
  if (frame_bgr.type() != CV_8UC3)
    throw Error("the video frame is not 8-bit BGR", "inverse realism", "pass the captured colour frame");
  cv::Mat grey, smooth, blurred, gx, gy;
  cv::cvtColor(frame_bgr, grey, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(grey, smooth, cv::Size(3, 3), 0);          // sensor noise is not an edge
  cv::GaussianBlur(smooth, blurred, cv::Size(9, 9), 0);       // below this scale: fine texture
  cv::Sobel(smooth, gx, CV_16S, 1, 0, 3);
  cv::Sobel(smooth, gy, CV_16S, 0, 1, 3);
  cv::Mat saliency(frame_bgr.size(), CV_32F);
  // Sobel's 3x3 kernel weighs the gradient by 8; 8-bit levels to [0, 1].
  const float edge_gain = options.w_edge / (8 * 255.0f * options.edge_scale);
  const float detail_gain = options.w_detail / (255.0f * options.detail_scale);
  const float highlight_ramp = 1 / (options.highlight_hi - options.highlight_lo);
  tbb::parallel_for(0, frame_bgr.rows, [&](int y) {
    const cv::Vec3b* bgr = frame_bgr.ptr<cv::Vec3b>(y);
    const std::uint8_t* s = smooth.ptr<std::uint8_t>(y);
    const std::uint8_t* b = blurred.ptr<std::uint8_t>(y);
    const std::int16_t* dx = gx.ptr<std::int16_t>(y);
    const std::int16_t* dy = gy.ptr<std::int16_t>(y);
    float* out = saliency.ptr<float>(y);
    for (int x = 0; x < frame_bgr.cols; ++x) {
      const float edge = edge_gain * std::sqrt(float(dx[x]) * dx[x] + float(dy[x]) * dy[x]);
      const float detail = detail_gain * std::abs(float(s[x]) - float(b[x]));
      const float value = std::max({bgr[x][0], bgr[x][1], bgr[x][2]}) * (1 / 255.0f);
      const float low = std::min({bgr[x][0], bgr[x][1], bgr[x][2]}) * (1 / 255.0f);
      const float saturation = value > 0 ? (value - low) / value : 0.0f;
      const float ramp = std::clamp((value - options.highlight_lo) * highlight_ramp, 0.0f, 1.0f);
      const float highlight = options.w_highlight * ramp * (1 - saturation);
      out[x] = std::min(1.0f, edge + detail + highlight);
    }
  });
  return saliency;
}

}  // namespace dg::stages::overlay
