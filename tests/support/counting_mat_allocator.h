#pragma once

#include <atomic>

#include <opencv2/core.hpp>

namespace dg::testing {

// OpenCV's own allocator, counting the image buffers it hands out, split by
// size: an image of at least `frame_pixels` pixels is a frame buffer (an eye,
// a pyramid's base, a layer, a composite), a smaller one a kernel's scratch.
// Install it with cv::Mat::setDefaultAllocator(&allocator) and remove it
// (setDefaultAllocator(nullptr)) before it goes out of scope.
class CountingMatAllocator final : public cv::MatAllocator {
 public:
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag flags,
                         cv::UMatUsageFlags usage) const override {
    if (!data) {  // a header over existing memory costs nothing
      long long pixels = 1;
      for (int d = 0; d < dims; ++d) pixels *= sizes[d];
      (pixels >= frame_pixels ? frame_images : scratch_images).fetch_add(1, std::memory_order_relaxed);
    }
    return base_->allocate(dims, sizes, type, data, step, flags, usage);
  }
  bool allocate(cv::UMatData* data, cv::AccessFlag flags, cv::UMatUsageFlags usage) const override {
    return base_->allocate(data, flags, usage);
  }
  void deallocate(cv::UMatData* data) const override { base_->deallocate(data); }

  long long frame_pixels = 0;
  mutable std::atomic<long long> frame_images{0}, scratch_images{0};

 private:
  cv::MatAllocator* base_ = cv::Mat::getStdAllocator();
};

}  // namespace dg::testing
