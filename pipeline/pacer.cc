#include "pipeline/pacer.h"

#include <utility>

#include "sim/error.h"

namespace dg::pipeline {

Pacer::Pacer(std::function<void()> tick, std::function<void()> on_exit, const RunClock& clock)
    : tick_(std::move(tick)), on_exit_(std::move(on_exit)), clock_(clock) {}

Pacer::~Pacer() {
  Stop();
  Join();
}

void Pacer::Start() {
  DG_CHECK(!thread_.joinable());
  thread_ = std::thread([this] { Loop(); });
}

void Pacer::Schedule(TimePoint due) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    DG_CHECK(!due_);
    due_ = due;
  }
  wake_.notify_one();
}

void Pacer::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
}

void Pacer::Join() {
  if (thread_.joinable()) thread_.join();
}

bool Pacer::WaitUntil(TimePoint due) {
  std::unique_lock lock(mutex_);
  return !clock_.WaitUntil(lock, wake_, due, [this] { return stopping_; });
}

void Pacer::Loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || due_.has_value(); });
    if (stopping_) break;
    if (clock_.WaitUntil(lock, wake_, *due_, [this] { return stopping_; })) break;
    due_.reset();
    lock.unlock();  // the tick may schedule the next one
    tick_();
    lock.lock();
  }
  lock.unlock();
  if (on_exit_) on_exit_();
}

}  // namespace dg::pipeline
