#pragma once

#include <cstdint>

#include <opencv2/core/mat.hpp>

#include "stages/render/rasterizer.h"

namespace dg::stages::overlay {

// What an overlay stage hands the compositor for one video frame: an image to
// lay over that frame and the index of the frame whose geometry it shows.
// bgra is CV_32FC4 at the camera's resolution with premultiplied colour:
// the composite is bgr + (1 - a) * video. Never written after it is handed over.
struct OverlayLayer {
  cv::Mat bgra;
  std::int64_t frame = -1;

  bool empty() const { return bgra.empty(); }
};

// The rasterizer's image as a layer: colour (drawn over black) and coverage
// (the fraction of each pixel's samples that anything was drawn on), both
// times opacity.
// @pre the rasterizer was cleared to black before drawing.
OverlayLayer LayerFromRender(const render::Rasterizer& rasterizer, float opacity, std::int64_t frame);

}  // namespace dg::stages::overlay
