// The encoder's blocking queue: first in, first out within its capacity; a
// full queue refuses TryPush; Close() wakes a consumer waiting on an empty
// queue and a producer waiting on a full one, and what was queued is still
// drained. Threads meet on the queue's own waits and on joins, never sleeps.
#include "pipeline/bounded_queue.h"

#include <thread>

#include <catch2/catch.hpp>

namespace dg::pipeline {
namespace {

TEST_CASE("bounded queue: first in, first out, within its capacity", "[pipeline][unit]") {
  BoundedQueue<int> queue(3);
  for (int v : {1, 2, 3}) REQUIRE(queue.TryPush(v));
  int more = 4;
  REQUIRE_FALSE(queue.TryPush(more));
  REQUIRE(more == 4);  // left with the caller
  int out = 0;
  for (int expected : {1, 2, 3}) {
    REQUIRE(queue.Pop(out));
    REQUIRE(out == expected);
  }
  REQUIRE(queue.TryPush(more));  // room again, across the end of the slots
  REQUIRE(queue.Pop(out));
  REQUIRE(out == 4);
}

// Runs `wait` (a Push or Pop that must wait) on a thread of its own, closes
// the queue and joins: what the wait returned.
template <typename Wait>
bool ReturnOfWaitEndedByClose(BoundedQueue<int>& queue, Wait wait) {
  bool returned = true;
  std::thread waiting([&] { returned = wait(); });
  queue.Close();
  waiting.join();
  return returned;
}

TEST_CASE("bounded queue: Close() wakes a waiting consumer, and the queued values still drain", "[pipeline][unit]") {
  BoundedQueue<int> empty(2);
  REQUIRE_FALSE(ReturnOfWaitEndedByClose(empty, [&] {
    int out = 0;
    return empty.Pop(out);  // waits: the queue is empty
  }));

  BoundedQueue<int> full(2);
  int a = 7, b = 8;
  REQUIRE(full.Push(a));
  REQUIRE(full.Push(b));
  REQUIRE_FALSE(ReturnOfWaitEndedByClose(full, [&] {
    int c = 9;
    return full.Push(c);  // waits: the queue is full
  }));
  int out = 0;
  REQUIRE(full.Pop(out));
  REQUIRE(out == 7);
  REQUIRE(full.Pop(out));
  REQUIRE(out == 8);
  REQUIRE_FALSE(full.Pop(out));
}

// An offline producer pushing 200 values through 2 slots waits for the
// consumer each time the queue is full: every value arrives, in order.
TEST_CASE("bounded queue: a waiting producer loses nothing", "[pipeline][unit]") {
  BoundedQueue<int> queue(2);
  std::vector<int> received;
  std::thread consumer([&] {
    int out = 0;
    while (queue.Pop(out)) received.push_back(out);
  });
  for (int v = 0; v < 200; ++v) {
    int value = v;
    REQUIRE(queue.Push(value));
  }
  queue.Close();
  consumer.join();
  REQUIRE(received.size() == 200);
  for (int v = 0; v < 200; ++v) REQUIRE(received[v] == v);
}

}  // namespace
}  // namespace dg::pipeline
