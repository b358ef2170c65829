#pragma once

#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <utility>
#include <vector>

#include "sim/error.h"

namespace dg::pipeline {

// A bounded blocking queue between threads (as COLMAP's JobQueue, and the
// I/O thread behind oneTBB's fgbzip2 example): Push() waits while the queue
// is full, Pop() while it is empty, both on condition variables, never by
// polling; Close() ends both waits, after which Pop() still drains what was
// queued. TryPush() is the producer's choice not to wait (a real-time run
// drops the value instead).
//
// Values are swapped in and out of slots constructed up front, so in the
// steady state a push hands its caller back the storage of a value popped
// earlier (a cv::Mat of the same size keeps its buffer) and allocates nothing.
//
// Threading: any number of producers and consumers; the lock guards the
// indices and the swaps only.
template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : slots_(capacity) { DG_CHECK(capacity > 0); }
  BoundedQueue(const BoundedQueue&) = delete;
  BoundedQueue& operator=(const BoundedQueue&) = delete;

  // Swaps `value` into the queue, waiting while it is full. False (and
  // `value` unchanged) if the queue is closed.
  bool Push(T& value) {
    std::unique_lock lock(mutex_);
    not_full_.wait(lock, [this] { return closed_ || size_ < slots_.size(); });
    if (closed_) return false;
    PushLocked(value);
    lock.unlock();
    not_empty_.notify_one();
    return true;
  }

  // Swaps `value` into the queue if it has room and is open; never waits.
  bool TryPush(T& value) {
    {
      std::lock_guard lock(mutex_);
      if (closed_ || size_ == slots_.size()) return false;
      PushLocked(value);
    }
    not_empty_.notify_one();
    return true;
  }

  // Swaps the oldest value into `out`, waiting while the queue is empty and
  // open. False once it is closed and empty.
  bool Pop(T& out) {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [this] { return closed_ || size_ > 0; });
    if (size_ == 0) return false;
    std::swap(out, slots_[head_]);
    head_ = (head_ + 1) % slots_.size();
    --size_;
    lock.unlock();
    not_full_.notify_one();
    return true;
  }

  // No more pushes; waiting producers and consumers return.
  void Close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    not_full_.notify_all();
    not_empty_.notify_all();
  }

  std::size_t capacity() const { return slots_.size(); }

 private:
  void PushLocked(T& value) {
    std::swap(slots_[(head_ + size_) % slots_.size()], value);
    ++size_;
  }

  std::mutex mutex_;
  std::condition_variable not_full_, not_empty_;
  std::vector<T> slots_;
  std::size_t head_ = 0, size_ = 0;
  bool closed_ = false;
};

}  // namespace dg::pipeline
