#include "stages/overlay/overlay_layer.h"

#include <tbb/parallel_for.h>

namespace dg::stages::overlay {

OverlayLayer LayerFromRender(const render::Rasterizer& rasterizer, float opacity, std::int64_t frame) {
  const cv::Mat color = rasterizer.Color();  // over black: already coverage-weighted
  const cv::Mat ids = rasterizer.ObjectIds();
  const int s = rasterizer.supersample();
  const float sample_weight = opacity / static_cast<float>(s * s);
  OverlayLayer layer{cv::Mat(color.size(), CV_32FC4), frame};
  tbb::parallel_for(0, color.rows, [&](int y) {
    const cv::Vec3f* in = color.ptr<cv::Vec3f>(y);
    cv::Vec4f* out = layer.bgra.ptr<cv::Vec4f>(y);
    for (int x = 0; x < color.cols; ++x) {
      int covered = 0;
      for (int dy = 0; dy < s; ++dy) {
        const int* id = ids.ptr<int>(y * s + dy) + x * s;
        for (int dx = 0; dx < s; ++dx) covered += id[dx] >= 0;
      }
      out[x] = cv::Vec4f(opacity * in[x][0], opacity * in[x][1], opacity * in[x][2], sample_weight * covered);
    }
  });
  return layer;
}

}  // namespace dg::stages::overlay
