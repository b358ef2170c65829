// The newest-layer hand-over between the overlays and the composite stage: a
// slow overlay on a thread of its own never holds the video loop back (its
// layer is reused, one frame older each frame), an older layer never replaces
// a newer one, and a replaced or refused layer is let go at once.
#include "pipeline/latest_layers.h"

#include <array>
#include <future>
#include <thread>

#include <catch2/catch.hpp>

namespace dg::pipeline {
namespace {

using stages::overlay::OverlayLayer;

OverlayLayer Layer(std::int64_t frame) { return {cv::Mat(6, 8, CV_32FC4, cv::Scalar::all(0.25)), frame}; }

// The video loop takes the layers of 60 frames while the slow overlay's second
// layer is still being made (its thread waits on a promise the loop fulfils
// only at the end): every frame finds the slow overlay's first layer.
TEST_CASE("latest layers: a slow overlay on another thread never holds the frames back", "[pipeline][unit]") {
  LatestLayers latest(2);
  std::promise<void> first_offered, release;
  std::thread slow([&] {
    latest.Offer(1, Layer(0));
    first_offered.set_value();
    release.get_future().wait();  // the slow draw
    latest.Offer(1, Layer(60));
  });
  first_offered.get_future().wait();
  std::array<OverlayLayer, 2> layers;
  for (std::int64_t j = 0; j < 60; ++j) {
    latest.Offer(0, Layer(j));
    latest.Take(layers);
    REQUIRE(layers[0].frame == j);
    REQUIRE(layers[1].frame == 0);
    REQUIRE(latest.held() == 2);  // one per overlay, whatever the rates
  }
  release.set_value();
  slow.join();
  latest.Take(layers);
  REQUIRE(layers[1].frame == 60);
}

TEST_CASE("latest layers: only a newer layer replaces the held one, and the other is let go", "[pipeline][unit]") {
  LatestLayers latest(1);
  std::array<OverlayLayer, 1> taken;
  latest.Take(taken);
  REQUIRE(taken[0].empty());  // nothing yet
  REQUIRE(latest.held() == 0);

  const OverlayLayer newer = Layer(5), older = Layer(3);
  latest.Offer(0, newer);
  REQUIRE(newer.bgra.u->refcount == 2);  // this test's and the mailbox's
  latest.Offer(0, older);
  REQUIRE(older.bgra.u->refcount == 1);  // refused, and not kept
  latest.Take(taken);
  REQUIRE(taken[0].frame == 5);
  REQUIRE(taken[0].bgra.data == newer.bgra.data);  // the same pixels, not a copy

  taken[0] = {};
  latest.Offer(0, Layer(6));
  REQUIRE(newer.bgra.u->refcount == 1);  // replaced: let go
}

}  // namespace
}  // namespace dg::pipeline
