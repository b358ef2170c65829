#include "pipeline/latest_layers.h"

#include <algorithm>
#include <utility>

#include "sim/error.h"

namespace dg::pipeline {

LatestLayers::LatestLayers(int overlays) : latest_(overlays) { DG_CHECK(overlays >= 0); }

void LatestLayers::Offer(int overlay, stages::overlay::OverlayLayer layer) {
  DG_CHECK(overlay >= 0 && overlay < overlays());
  {
    std::lock_guard lock(mutex_);
    stages::overlay::OverlayLayer& held = latest_[overlay];
    if (held.empty() || layer.frame > held.frame) std::swap(held, layer);
  }
  // `layer` now holds the replaced (or refused) one: released here, outside the lock.
}

void LatestLayers::Take(std::span<stages::overlay::OverlayLayer> layers) const {
  DG_CHECK(layers.size() == latest_.size());
  std::lock_guard lock(mutex_);
  std::copy(latest_.begin(), latest_.end(), layers.begin());
}

int LatestLayers::held() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(std::count_if(latest_.begin(), latest_.end(),
                                        [](const stages::overlay::OverlayLayer& layer) { return !layer.empty(); }));
}

}  // namespace dg::pipeline
