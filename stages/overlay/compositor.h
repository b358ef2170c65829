#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "stages/overlay/inverse_realism.h"
#include "stages/overlay/overlay_layer.h"

namespace dg::stages::overlay {

enum class BlendMode {
  kAlpha,           // the layer's own opacity
  kInverseRealism,  // opacity lowered where the frame is salient (inverse_realism.h)
};

struct CompositorOptions {
  // The overlays in drawing order, the first drawn first (lowest), each with its blend mode.
  struct Entry {
    std::string name;
    BlendMode blend = BlendMode::kAlpha;
  };
  std::vector<Entry> layers;  // at most kMaxLayers
  InverseRealismOptions inverse_realism;

  // Compose() keeps its per-frame lists on the stack, so it allocates nothing.
  static constexpr int kMaxLayers = 8;

  // Empty when valid; otherwise what is wrong.
  std::string Validate() const;
};

// One composed video frame and how old each layer in it was.
struct CompositeFrame {
  cv::Mat bgr;  // CV_8UC3
  std::int64_t frame = -1;
  // Per entry of the options: frame - the layer's frame; -1 if no layer was
  // usable (none produced yet, or only one from a later frame).
  std::vector<std::int64_t> layer_age_frames;
};

// Lays the overlays' newest layers over each video frame.
//
// Each overlay runs at its own rate; between the overlays and the compositor
// is a latest-value hand-over: Offer() keeps the newest layer per overlay and
// drops the one it replaces, so a slow overlay never holds the video back (its
// last layer is reused, older each frame, and the age is reported) and memory
// is bounded by one held layer per overlay. Offer() may be called from any
// thread while Compose() runs; Compose() is const and may run on several
// frames at once (its scratch rows are per thread).
//
// Compose() is one pass over the frame in bands of rows (in parallel): per
// band the saliency rows (SaliencyBand) and then every layer over each pixel
// in order, so the frame, the layers and the saliency are each read once. It
// writes into the caller's image, so a caller that keeps its image from frame
// to frame (the pipeline's pooled packets) allocates no image per frame.
//
// A stereo run has one compositor per eye: each eye's overlays are drawn
// through that eye's lens and offered to that eye's compositor.
class Compositor {
 public:
  // @throws dg::Error for invalid options.
  explicit Compositor(CompositorOptions options);

  // Hands over overlay `overlay`'s layer (index into options.layers); keeps it
  // if it is newer than the one held. @throws dg::Error for an unknown index.
  void Offer(int overlay, OverlayLayer layer);

  // The frame with the held layers composed over it, in order, into
  // *composite_bgr (CV_8UC3, the frame's size; its buffer is reused when it
  // has them already); each layer's age into *layer_age_frames unless null.
  // @pre composite_bgr is not video_bgr and shares no buffer another thread reads.
  // @throws dg::Error if the frame is not 8-bit BGR or a layer's size differs from it.
  void Compose(const cv::Mat& video_bgr, std::int64_t frame, cv::Mat* composite_bgr,
               std::vector<std::int64_t>* layer_age_frames) const;
  // The same into a new image, for one-off callers (snapshots, benchmarks).
  CompositeFrame Compose(const cv::Mat& video_bgr, std::int64_t frame) const;

  // Layers currently held (at most one per overlay).
  int held_layers() const;
  const CompositorOptions& options() const { return options_; }

 private:
  CompositorOptions options_;
  mutable std::mutex mutex_;
  std::vector<OverlayLayer> latest_;
};

}  // namespace dg::stages::overlay
