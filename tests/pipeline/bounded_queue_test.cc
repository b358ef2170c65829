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

TEST_CASE("bounded queue: Close() wakes a waiting consumer, and the queued values still drain", "[pipeline][unit]") {
  BoundedQueue<int> queue(2);
  bool popped = true;
  std::thread consumer([&] {
    int out = 0;
    popped = queue.Pop(out);  // waits: the queue is empty
  });
  queue.Close();
  consumer.join();
  REQUIRE_FALSE(popped);

  BoundedQueue<int> drained(2);
  int a = 7, b = 8;
  REQUIRE(drained.Push(a));
  REQUIRE(drained.Push(b));
  bool pushed = true;
  std::thread producer([&] {
    int c = 9;
    pushed = drained.Push(c);  // waits: the queue is full
  });
  drained.Close();
  producer.join();
  REQUIRE_FALSE(pushed);
  int out = 0;
  REQUIRE(drained.Pop(out));
  REQUIRE(out == 7);
  REQUIRE(drained.Pop(out));
  REQUIRE(out == 8);
  REQUIRE_FALSE(drained.Pop(out));
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
