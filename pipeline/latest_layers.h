#pragma once

#include <cstdint>
#include <mutex>
#include <span>
#include <vector>

#include "stages/overlay/overlay_layer.h"

namespace dg::pipeline {

// The newest layer of each overlay for one eye: the hand-over between the
// overlays' side branches, each drawing at its own rate, and the composite
// stage, which lays the newest layers over every frame
// (docs/design.md#threads). Offer() keeps a layer only if it is newer than
// the one it replaces, so a slow overlay never holds the video back: its last
// layer is reused, older each frame. Memory is bounded by one held layer per
// overlay.
//
// Threading: Offer() and Take() may be called from any thread at once. The
// lock guards only the copy of the layers' headers (a layer's pixels are never
// written after it is handed over), never a draw or a compose; a replaced
// layer is released after the lock.
class LatestLayers {
 public:
  // overlays: the entries of the compositor's options, in their order.
  explicit LatestLayers(int overlays);

  // Keeps `layer` as overlay `overlay`'s if it is from a later frame than the one held.
  // @pre 0 <= overlay < overlays.
  void Offer(int overlay, stages::overlay::OverlayLayer layer);

  // The held layers (an empty one where an overlay has none yet) into
  // `layers`, one per overlay; a copy of the headers, sharing the pixels.
  // @pre layers.size() == overlays.
  void Take(std::span<stages::overlay::OverlayLayer> layers) const;

  int overlays() const { return static_cast<int>(latest_.size()); }
  // Layers held (at most one per overlay).
  int held() const;

 private:
  mutable std::mutex mutex_;
  std::vector<stages::overlay::OverlayLayer> latest_;
};

}  // namespace dg::pipeline
