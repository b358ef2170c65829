#include "stages/overlay/overlay_layer.h"

#include <tbb/parallel_for.h>

namespace dg::stages::overlay {

cv::Mat LayerPool::Take(cv::Size size) {
  for (cv::Mat& image : images_) {
    // Only the pool's own reference left: the last other holder has let go.
    if (image.u->refcount == 1) {
      image.create(size, CV_32FC4);
      return image;
    }
  }
  return images_.emplace_back(size, CV_32FC4);
}

void LayerPool::Reserve(int count, cv::Size size) {
  while (static_cast<int>(images_.size()) < count) images_.emplace_back(size, CV_32FC4);
}

OverlayLayer LayerFromRender(const render::Rasterizer& rasterizer, float opacity, std::int64_t frame, LayerPool* pool) {
  const cv::Mat& color = rasterizer.ColorSamples();  // over black: already coverage-weighted
  const cv::Mat& ids = rasterizer.ObjectIdSamples();
  const int s = rasterizer.supersample();
  const float inv_count = 1.0f / static_cast<float>(s * s);
  const float sample_weight = opacity * inv_count;
  const cv::Size size(rasterizer.camera().width, rasterizer.camera().height);
  OverlayLayer layer{pool->Take(size), frame};
  // Only the pixels whose samples were drawn on: the rest is transparent.
  layer.bgra.setTo(cv::Scalar::all(0));
  const cv::Rect& drawn = rasterizer.DrawnSamples();
  if (drawn.empty()) return layer;
  const int x0 = drawn.x / s, x1 = (drawn.x + drawn.width - 1) / s + 1;
  const int y0 = drawn.y / s, y1 = (drawn.y + drawn.height - 1) / s + 1;
  tbb::parallel_for(y0, y1, [&](int y) {
    cv::Vec4f* out = layer.bgra.ptr<cv::Vec4f>(y);
    for (int x = x0; x < x1; ++x) {
      cv::Vec3f sum(0, 0, 0);
      int covered = 0;
      for (int dy = 0; dy < s; ++dy) {
        const cv::Vec3f* in = color.ptr<cv::Vec3f>(y * s + dy) + x * s;
        const int* id = ids.ptr<int>(y * s + dy) + x * s;
        for (int dx = 0; dx < s; ++dx) {
          sum += in[dx];
          covered += id[dx] >= 0;
        }
      }
      const cv::Vec3f mean = sum * inv_count;
      out[x] = cv::Vec4f(opacity * mean[0], opacity * mean[1], opacity * mean[2], sample_weight * covered);
    }
  });
  return layer;
}

}  // namespace dg::stages::overlay
