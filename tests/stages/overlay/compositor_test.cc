// The compositor against hand-computed blends, and its hand-over: a slow
// overlay never holds the video back, its layer's age is reported, and no more
// than one layer per overlay is ever held.
#include "stages/overlay/compositor.h"

#include <future>
#include <thread>

#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::stages::overlay {
namespace {

OverlayLayer ConstantLayer(int width, int height, const cv::Vec4f& bgra, std::int64_t frame) {
  return {cv::Mat(height, width, CV_32FC4, cv::Scalar(bgra[0], bgra[1], bgra[2], bgra[3])), frame};
}

// Premultiplied "over": out = c + (1 - a) video, layers in order.
TEST_CASE("compositor: alpha blending in the given order", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"under", BlendMode::kAlpha}, {"over", BlendMode::kAlpha}};
  Compositor compositor(options);
  const cv::Mat video(4, 6, CV_8UC3, cv::Scalar(100, 150, 200));
  compositor.Offer(0, ConstantLayer(6, 4, {0.5f, 0.0f, 0.0f, 0.5f}, 2));
  compositor.Offer(1, ConstantLayer(6, 4, {0.0f, 0.25f, 0.0f, 0.25f}, 3));
  const CompositeFrame out = compositor.Compose(video, 5);
  REQUIRE(out.frame == 5);
  REQUIRE(out.layer_age_frames == std::vector<std::int64_t>{3, 2});
  const auto expect = [](double v, double under, double over, double a_under, double a_over) {
    return 255 * (over + (1 - a_over) * (under + (1 - a_under) * v / 255));
  };
  const cv::Vec3b p = out.bgr.at<cv::Vec3b>(2, 3);
  REQUIRE(p[0] == Approx(expect(100, 0.5, 0, 0.5, 0.25)).margin(0.5));
  REQUIRE(p[1] == Approx(expect(150, 0, 0.25, 0.5, 0.25)).margin(0.5));
  REQUIRE(p[2] == Approx(expect(200, 0, 0, 0.5, 0.25)).margin(0.5));
}

// A frame half flat, half with a sharp stripe pattern: under Inverse Realism an
// opaque layer covers the flat half and lets the stripes' edges through.
TEST_CASE("compositor: Inverse Realism keeps the frame's salient cues over the anatomy", "[stages][unit]") {
  cv::Mat video(40, 80, CV_8UC3, cv::Scalar(40, 60, 150));
  for (int x = 40; x < 80; x += 4) video.colRange(x, x + 2).setTo(cv::Scalar(200, 200, 200));
  const cv::Mat saliency = Saliency(video, {});
  REQUIRE(saliency.at<float>(20, 10) == Approx(0).margin(1e-6));  // flat: no cue
  REQUIRE(saliency.at<float>(20, 60) >= 0.99f);                    // stripes: edges everywhere

  CompositorOptions options;
  options.layers = {{"anatomy", BlendMode::kInverseRealism}};
  Compositor compositor(options);
  compositor.Offer(0, ConstantLayer(80, 40, {0, 1, 0, 1}, 0));  // opaque green
  const CompositeFrame out = compositor.Compose(video, 0);
  REQUIRE(out.bgr.at<cv::Vec3b>(20, 10) == cv::Vec3b(0, 255, 0));
  // Where salient, the frame shows through by the strength: 0.85 of the video.
  const float strength = options.inverse_realism.strength;
  const cv::Vec3b stripe = out.bgr.at<cv::Vec3b>(20, 60), original = video.at<cv::Vec3b>(20, 60);
  REQUIRE(stripe[0] == Approx(strength * original[0]).margin(1));
  REQUIRE(stripe[1] == Approx((1 - strength) * 255 + strength * original[1]).margin(1));
}

// The video loop composes 60 frames while the slow overlay's second layer is
// still being made (it waits on a promise the loop only fulfils at the end):
// every frame is composed, reusing the slow overlay's first layer, whose age grows.
TEST_CASE("compositor: a slow overlay does not hold the video back and its age is recorded", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"fast", BlendMode::kAlpha}, {"slow", BlendMode::kAlpha}};
  Compositor compositor(options);
  std::promise<void> first_offered, release;
  std::thread slow([&] {
    compositor.Offer(1, ConstantLayer(8, 6, {0, 0, 0.5f, 0.5f}, 0));
    first_offered.set_value();
    release.get_future().wait();                                      // the slow render
    compositor.Offer(1, ConstantLayer(8, 6, {0, 0, 0.5f, 0.5f}, 60));
  });
  first_offered.get_future().wait();
  const cv::Mat video(6, 8, CV_8UC3, cv::Scalar(10, 10, 10));
  std::vector<std::int64_t> slow_ages;
  for (std::int64_t j = 0; j < 60; ++j) {
    compositor.Offer(0, ConstantLayer(8, 6, {0.1f, 0, 0, 0.1f}, j));
    const CompositeFrame out = compositor.Compose(video, j);
    REQUIRE(out.layer_age_frames[0] == 0);
    slow_ages.push_back(out.layer_age_frames[1]);
    REQUIRE(compositor.held_layers() <= 2);  // one per overlay, whatever the rates
  }
  release.set_value();
  slow.join();
  for (std::int64_t j = 0; j < 60; ++j) REQUIRE(slow_ages[j] == j);
  REQUIRE(compositor.Compose(video, 60).layer_age_frames == std::vector<std::int64_t>{1, 0});
  // An older layer offered late does not replace a newer one.
  compositor.Offer(1, ConstantLayer(8, 6, {0, 0, 0, 0}, 30));
  REQUIRE(compositor.Compose(video, 61).layer_age_frames[1] == 1);
}

TEST_CASE("compositor: a layer from a later frame waits; bad input is rejected", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"mesh", BlendMode::kAlpha}};
  Compositor compositor(options);
  const cv::Mat video(6, 8, CV_8UC3, cv::Scalar::all(0));
  REQUIRE(compositor.Compose(video, 0).layer_age_frames[0] == -1);  // nothing yet
  compositor.Offer(0, ConstantLayer(8, 6, {1, 1, 1, 1}, 5));
  REQUIRE(compositor.Compose(video, 4).layer_age_frames[0] == -1);
  REQUIRE(compositor.Compose(video, 4).bgr.at<cv::Vec3b>(0, 0) == cv::Vec3b(0, 0, 0));
  REQUIRE_THROWS_WITH(compositor.Compose(cv::Mat(7, 8, CV_8UC3), 5), Catch::Contains("has a 8x6 layer for a 8x7 frame"));
  REQUIRE_THROWS_WITH(compositor.Offer(1, {}), Catch::Contains("no overlay 1"));
  options.layers.push_back({"mesh", BlendMode::kAlpha});
  REQUIRE_THROWS_WITH(Compositor(options), Catch::Contains("listed twice"));
}

}  // namespace
}  // namespace dg::stages::overlay
