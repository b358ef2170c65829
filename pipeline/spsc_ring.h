#pragma once

#include <atomic>
#include <cstddef>
#include <utility>
#include <vector>

namespace dg::pipeline {

// A bounded single-producer/single-consumer ring (Lamport's queue with
// acquire/release indices): one thread pushes, one other thread pops, neither
// ever blocks or locks. It carries results from the simulation side to the
// overlay and sink side: a producer whose consumer is
// slow gets `false` from TryPush and decides itself whether to drop (counted
// here) or to wait, so a slow consumer never holds the producer back.
//
// Slots are constructed once, up front: in the steady state push and pop move
// values in and out of existing slots and allocate nothing (for types whose
// move assignment reuses storage, such as cv::Mat of an unchanged size).
template <typename T>
class SpscRing {
 public:
  explicit SpscRing(std::size_t capacity) : slots_(capacity + 1) {}

  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  // Producer side. False when the ring is full; `value` is then left unchanged.
  bool TryPush(T& value) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    const std::size_t next = Next(tail);
    if (next == head_.load(std::memory_order_acquire)) return false;
    std::swap(slots_[tail], value);
    tail_.store(next, std::memory_order_release);
    return true;
  }

  // Producer side: pushes, or drops `value` and counts the drop when full.
  bool PushOrDrop(T& value) {
    if (TryPush(value)) return true;
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }

  // Consumer side. Swaps the oldest value into `out`; false when empty.
  bool TryPop(T& out) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) return false;
    std::swap(out, slots_[head]);
    head_.store(Next(head), std::memory_order_release);
    return true;
  }

  // Consumer side: discards all but the newest value and swaps that into
  // `out` (the latest-value hand-over an overlay wants); false when empty.
  // Values skipped over are released (not left in their slots) and counted
  // as dropped.
  bool TryPopLatest(T& out) {
    if (!TryPop(out)) return false;
    while (head_.load(std::memory_order_relaxed) != tail_.load(std::memory_order_acquire)) {
      out = T{};  // the value skipped over; TryPop then leaves this empty one in the slot
      TryPop(out);
      dropped_.fetch_add(1, std::memory_order_relaxed);
    }
    return true;
  }

  std::size_t capacity() const { return slots_.size() - 1; }
  // Values dropped so far by PushOrDrop and TryPopLatest (either side may read it).
  std::size_t dropped() const { return dropped_.load(std::memory_order_relaxed); }

 private:
  std::size_t Next(std::size_t index) const { return index + 1 == slots_.size() ? 0 : index + 1; }

  std::vector<T> slots_;
  // Producer and consumer indices on their own cache lines: no false sharing.
  alignas(64) std::atomic<std::size_t> head_{0};  // next slot to pop (consumer)
  alignas(64) std::atomic<std::size_t> tail_{0};  // next slot to push (producer)
  alignas(64) std::atomic<std::size_t> dropped_{0};
};

}  // namespace dg::pipeline
