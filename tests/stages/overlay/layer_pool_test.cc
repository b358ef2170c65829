// The overlays' layer pool: reserved images are handed out again once their
// holders let go, so that a pool reserved to the most layers alive at once
// never allocates while drawing.

#include <set>
#include <vector>

#include <catch2/catch.hpp>

#include "stages/overlay/overlay_layer.h"

namespace dg::stages::overlay {
namespace {

TEST_CASE("layer pool: a pool reserved to the layers alive at once hands out only its own images",
          "[stages][unit]") {
  const cv::Size size(16, 12);
  LayerPool pool;
  pool.Reserve(3, size);
  std::set<const uchar*> reserved;
  std::vector<cv::Mat> held;
  for (int i = 0; i < 3; ++i) {
    held.push_back(pool.Take(size));
    reserved.insert(held.back().data);
  }
  REQUIRE(reserved.size() == 3);  // three distinct images while three are held
  REQUIRE(held[0].type() == CV_32FC4);
  REQUIRE(held[0].size() == size);
  // Let go of one at a time, in any order: the next Take is that image again.
  for (int round = 0; round < 6; ++round) {
    const size_t released = round % 3;
    const uchar* freed = held[released].data;
    held[released].release();
    held[released] = pool.Take(size);
    REQUIRE(held[released].data == freed);
  }
  // A fourth alive at once is beyond the reservation: a new image.
  const cv::Mat fourth = pool.Take(size);
  REQUIRE(reserved.count(fourth.data) == 0);
  // Reserving no more than the pool holds allocates nothing.
  pool.Reserve(2, size);
  held.clear();
  std::set<const uchar*> again;
  for (int i = 0; i < 3; ++i) {
    held.push_back(pool.Take(size));
    again.insert(held.back().data);
  }
  REQUIRE(again == reserved);
}

}  // namespace
}  // namespace dg::stages::overlay
