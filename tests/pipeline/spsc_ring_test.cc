#include "pipeline/spsc_ring.h"

#include <cstdint>
#include <thread>

#include <catch2/catch.hpp>

namespace dg::pipeline {

// Two threads, a ring much smaller than the stream: every value arrives once,
// in order (the producer retries when full, as the offline policy does).
TEST_CASE("spsc ring: a million values cross threads once each, in order", "[pipeline][unit]") {
  constexpr std::int64_t kValues = 1'000'000;
  SpscRing<std::int64_t> ring(7);
  std::thread producer([&] {
    for (std::int64_t v = 0; v < kValues; ++v) {
      std::int64_t value = v;
      while (!ring.TryPush(value)) std::this_thread::yield();
    }
  });
  std::int64_t expected = 0, out_of_order = 0;
  while (expected < kValues) {
    std::int64_t value;
    if (!ring.TryPop(value)) continue;
    out_of_order += value != expected;
    ++expected;
  }
  producer.join();
  REQUIRE(out_of_order == 0);
  std::int64_t left;
  REQUIRE_FALSE(ring.TryPop(left));
  REQUIRE(ring.dropped() == 0);
}

// A full ring refuses without blocking and counts what was dropped; the
// latest-value pop skips to the newest value and counts the skipped ones.
TEST_CASE("spsc ring: drops are counted, the latest value wins", "[pipeline][unit]") {
  SpscRing<int> ring(4);
  REQUIRE(ring.capacity() == 4);
  int pushed = 0;
  for (int v = 0; v < 10; ++v) {
    int value = v;
    pushed += ring.PushOrDrop(value);
  }
  REQUIRE(pushed == 4);
  REQUIRE(ring.dropped() == 6);
  int newest = -1;
  REQUIRE(ring.TryPopLatest(newest));
  REQUIRE(newest == 3);  // 0..3 were kept; 4..9 dropped at the push
  REQUIRE(ring.dropped() == 9);
  REQUIRE_FALSE(ring.TryPopLatest(newest));
}

}  // namespace dg::pipeline
