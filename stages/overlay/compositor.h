#pragma once

#include <cstdint>
#include <span>
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

// Lays the overlays' layers over each video frame.
//
// The caller hands Compose() one layer per entry of the options (an empty
// layer where an overlay has none yet); a layer from a frame after the one
// composed is left out, and each layer's age is reported. Where the layers
// come from is the caller's business: the pipeline draws them from the
// frame's own state and carries them in the frame's packet
// (pipeline/overlay_stages.h), so the compositor knows nothing of threads. Compose() is const and may run on
// several frames at once (its scratch rows are per thread).
//
// Compose() is one pass over the frame in bands of rows (in parallel): per
// band the saliency rows (SaliencyBand) and then every layer over each pixel
// in order, so the frame, the layers and the saliency are each read once. It
// writes into the caller's image, so a caller that keeps its image from frame
// to frame (the pipeline's pooled packets) allocates no image per frame.
class Compositor {
 public:
  // @throws dg::Error for invalid options.
  explicit Compositor(CompositorOptions options);

  // The frame with `layers` (one per entry of the options, in their order)
  // composed over it, into *composite_bgr (CV_8UC3, the frame's size; its
  // buffer is reused when it has them already); each layer's age into
  // *layer_age_frames unless null.
  // @pre composite_bgr is not video_bgr and shares no buffer another thread reads;
  //      no layer is written while Compose() runs.
  // @throws dg::Error if the frame is not 8-bit BGR, the number of layers is
  //         not the number of entries, or a layer's size differs from the frame's.
  void Compose(const cv::Mat& video_bgr, std::int64_t frame, std::span<const OverlayLayer> layers,
               cv::Mat* composite_bgr, std::vector<std::int64_t>* layer_age_frames) const;
  // The same into a new image, for one-off callers.
  CompositeFrame Compose(const cv::Mat& video_bgr, std::int64_t frame, std::span<const OverlayLayer> layers) const;

  // For callers that compose one set of layers on one thread (snapshots,
  // benchmarks): Offer() keeps overlay `overlay`'s layer (index into
  // options.layers) if it is newer than the one held, and the Compose()
  // overloads without layers compose the held ones. Not for concurrent use:
  // no Offer() while a Compose() runs.
  // @throws dg::Error for an unknown index.
  void Offer(int overlay, OverlayLayer layer);
  void Compose(const cv::Mat& video_bgr, std::int64_t frame, cv::Mat* composite_bgr,
               std::vector<std::int64_t>* layer_age_frames) const;
  CompositeFrame Compose(const cv::Mat& video_bgr, std::int64_t frame) const;
  // Layers held by Offer() (at most one per overlay).
  int held_layers() const;

  const CompositorOptions& options() const { return options_; }

 private:
  CompositorOptions options_;
  std::vector<OverlayLayer> held_;  // Offer()'s, one per entry
};

}  // namespace dg::stages::overlay
