#include "stages/overlay/compositor.h"

#include <tbb/parallel_for.h>

#include "sim/error.h"

namespace dg::stages::overlay {

std::string CompositorOptions::Validate() const {
  for (size_t i = 0; i < layers.size(); ++i) {
    if (layers[i].name.empty()) return "layer " + std::to_string(i) + " has no name";
    for (size_t j = 0; j < i; ++j) {
      if (layers[j].name == layers[i].name) return "overlay '" + layers[i].name + "' is listed twice";
    }
  }
  return inverse_realism.Validate();
}

Compositor::Compositor(CompositorOptions options) : options_(std::move(options)), latest_(options_.layers.size()) {
  if (const std::string problem = options_.Validate(); !problem.empty())
    throw Error("invalid compositor options: " + problem, "overlay order", "correct the scene's overlay order and blending");
  for (const auto& entry : options_.layers) needs_saliency_ |= entry.blend == BlendMode::kInverseRealism;
}

void Compositor::Offer(int overlay, OverlayLayer layer) {
  if (overlay < 0 || overlay >= static_cast<int>(latest_.size()))
    throw Error("no overlay " + std::to_string(overlay), "Compositor::Offer",
                "offer layers only of the overlays the compositor was configured with");
  std::lock_guard lock(mutex_);
  if (latest_[overlay].empty() || layer.frame > latest_[overlay].frame) latest_[overlay] = std::move(layer);
}

int Compositor::held_layers() const {
  std::lock_guard lock(mutex_);
  int held = 0;
  for (const OverlayLayer& layer : latest_) held += !layer.empty();
  return held;
}

CompositeFrame Compositor::Compose(const cv::Mat& video_bgr, std::int64_t frame) const {
  const std::string where = "compositor, frame " + std::to_string(frame);
  if (video_bgr.type() != CV_8UC3) throw Error("the video frame is not 8-bit BGR", where, "pass the captured colour frame");
  std::vector<OverlayLayer> layers;
  {
    std::lock_guard lock(mutex_);
    layers = latest_;  // headers only: a handed-over layer is never written again
  }
  CompositeFrame out{cv::Mat(video_bgr.size(), CV_8UC3), frame, {}};
  std::vector<const OverlayLayer*> used;
  std::vector<bool> salient;
  for (size_t i = 0; i < layers.size(); ++i) {
    const OverlayLayer& layer = layers[i];
    const bool usable = !layer.empty() && layer.frame <= frame;
    out.layer_age_frames.push_back(usable ? frame - layer.frame : -1);
    if (!usable) continue;
    if (layer.bgra.size() != video_bgr.size() || layer.bgra.type() != CV_32FC4)
      throw Error("overlay '" + options_.layers[i].name + "' has a " + std::to_string(layer.bgra.cols) + "x" +
                      std::to_string(layer.bgra.rows) + " layer for a " + std::to_string(video_bgr.cols) + "x" +
                      std::to_string(video_bgr.rows) + " frame",
                  where, "render the overlays with the video's calibration (image_size)");
    used.push_back(&layer);
    salient.push_back(options_.layers[i].blend == BlendMode::kInverseRealism);
  }
  const cv::Mat saliency = needs_saliency_ ? Saliency(video_bgr, options_.inverse_realism) : cv::Mat();
  const float strength = options_.inverse_realism.strength;
  tbb::parallel_for(0, video_bgr.rows, [&](int y) {
    const cv::Vec3b* in = video_bgr.ptr<cv::Vec3b>(y);
    cv::Vec3b* result = out.bgr.ptr<cv::Vec3b>(y);
    const float* s = saliency.empty() ? nullptr : saliency.ptr<float>(y);
    for (int x = 0; x < video_bgr.cols; ++x) {
      cv::Vec3f c(in[x][0] * (1 / 255.0f), in[x][1] * (1 / 255.0f), in[x][2] * (1 / 255.0f));
      for (size_t l = 0; l < used.size(); ++l) {
        const cv::Vec4f& p = used[l]->bgra.ptr<cv::Vec4f>(y)[x];
        const float keep = salient[l] ? 1 - strength * s[x] : 1.0f;  // of the layer, where the frame is salient
        c = keep * cv::Vec3f(p[0], p[1], p[2]) + (1 - keep * p[3]) * c;
      }
      result[x] = cv::Vec3b(cv::saturate_cast<uchar>(255 * c[0]), cv::saturate_cast<uchar>(255 * c[1]),
                            cv::saturate_cast<uchar>(255 * c[2]));
    }
  });
  return out;
}

}  // namespace dg::stages::overlay
