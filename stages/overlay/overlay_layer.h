#pragma once

#include <cstdint>
#include <vector>

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

// The images an overlay hands out as layers, each reused once nothing else
// holds it (the compositor keeps a layer until a newer one replaces it), so
// an overlay allocates layers only until as many exist as are ever alive at
// once. One caller at a time.
class LayerPool {
 public:
  // Allocates images of `size` until the pool holds `count`, so that Take()
  // allocates nothing while at most `count` are alive at once.
  void Reserve(int count, cv::Size size);

  // A CV_32FC4 image of `size` that no cv::Mat outside the pool shares;
  // its pixels are left from earlier use.
  cv::Mat Take(cv::Size size);

 private:
  std::vector<cv::Mat> images_;
};

// The rasterizer's image as a layer from `pool`: colour (drawn over black)
// and coverage (the fraction of each pixel's samples that anything was drawn
// on), both times opacity.
// @pre the rasterizer was cleared to black before drawing.
OverlayLayer LayerFromRender(const render::Rasterizer& rasterizer, float opacity, std::int64_t frame, LayerPool* pool);

}  // namespace dg::stages::overlay
