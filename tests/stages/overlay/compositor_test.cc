// The compositor against hand-computed blends, and the ages of the layers it
// is given (where they come from is pipeline/overlay_stages.h's).
#include "stages/overlay/compositor.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <catch2/catch.hpp>
#include <opencv2/imgproc.hpp>

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

// The header's saliency formula over whole-frame OpenCV filters, as Saliency() once was.
cv::Mat SaliencyFromOpenCv(const cv::Mat& frame_bgr, const InverseRealismOptions& o) {
  cv::Mat grey, smooth, blurred, gx, gy;
  cv::cvtColor(frame_bgr, grey, cv::COLOR_BGR2GRAY);
  cv::GaussianBlur(grey, smooth, cv::Size(3, 3), 0);
  cv::GaussianBlur(smooth, blurred, cv::Size(9, 9), 0);
  cv::Sobel(smooth, gx, CV_16S, 1, 0, 3);
  cv::Sobel(smooth, gy, CV_16S, 0, 1, 3);
  cv::Mat saliency(frame_bgr.size(), CV_32F);
  for (int y = 0; y < frame_bgr.rows; ++y) {
    for (int x = 0; x < frame_bgr.cols; ++x) {
      const cv::Vec3b p = frame_bgr.at<cv::Vec3b>(y, x);
      const float dx = gx.at<std::int16_t>(y, x), dy = gy.at<std::int16_t>(y, x);
      const float edge = o.w_edge / (8 * 255.0f * o.edge_scale) * std::sqrt(dx * dx + dy * dy);
      const float detail = o.w_detail / (255.0f * o.detail_scale) *
                           std::abs(float(smooth.at<std::uint8_t>(y, x)) - float(blurred.at<std::uint8_t>(y, x)));
      const float value = std::max({p[0], p[1], p[2]}) / 255.0f, low = std::min({p[0], p[1], p[2]}) / 255.0f;
      const float saturation = value > 0 ? (value - low) / value : 0.0f;
      const float ramp = std::clamp((value - o.highlight_lo) / (o.highlight_hi - o.highlight_lo), 0.0f, 1.0f);
      saliency.at<float>(y, x) = std::min(1.0f, edge + detail + o.w_highlight * ramp * (1 - saturation));
    }
  }
  return saliency;
}

// Noise smoothed a little (edges and texture at every level), with saturated
// highlights spread over it.
cv::Mat TexturedFrame(int width, int height, int seed) {
  cv::RNG rng(seed);
  cv::Mat frame(height, width, CV_8UC3);
  rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(frame, frame, cv::Size(3, 3), 0.8);
  for (int i = 0; i < width * height / 40; ++i)
    frame.at<cv::Vec3b>(rng.uniform(0, height), rng.uniform(0, width)) = cv::Vec3b::all(rng.uniform(200, 256));
  return frame;
}

// The saliency is computed a band at a time from integer copies of OpenCV's
// 8-bit filters (grey, 3x3 and 9x9 Gaussians, Sobel): it must equal the
// filters' own result, borders included. A filter off by one level would move
// s by at least 1/255 w_detail / detail_scale = 0.04; 1e-6 is the formula's
// float round-off.
TEST_CASE("inverse realism: the band-wise saliency equals OpenCV's filters, at every size and band", "[stages][unit]") {
  const InverseRealismOptions options;
  int seed = 1;
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(5, 7), cv::Size(8, 9), cv::Size(9, 8), cv::Size(9, 9),
                              cv::Size(13, 10), cv::Size(37, 29), cv::Size(80, 70), cv::Size(161, 121)}) {
    const cv::Mat frame = TexturedFrame(size.width, size.height, seed++);
    const cv::Mat expected = SaliencyFromOpenCv(frame, options);
    INFO(size.width << "x" << size.height);
    REQUIRE(cv::norm(Saliency(frame, options), expected, cv::NORM_INF) <= 1e-6);
    for (int y_begin = 0; y_begin < size.height; y_begin += 3) {
      const int y_end = std::min(size.height, y_begin + 1 + y_begin % 7);
      cv::Mat band;
      SaliencyBand(frame, options, y_begin, y_end, &band);
      INFO("rows " << y_begin << " to " << y_end);
      REQUIRE(cv::norm(band, expected.rowRange(y_begin, y_end), cv::NORM_INF) <= 1e-6);
    }
  }
}

// The fused, banded compose against the blend of the class comment evaluated
// per pixel in double: each channel is that value rounded, unless it lies
// within float round-off (1e-3 of a level) of a half level.
TEST_CASE("compositor: each pixel is the in-order blend of every layer, at any size", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"under", BlendMode::kAlpha}, {"anatomy", BlendMode::kInverseRealism},
                    {"mesh", BlendMode::kInverseRealism}, {"over", BlendMode::kAlpha}};
  int seed = 100;
  for (const cv::Size size : {cv::Size(1, 1), cv::Size(7, 5), cv::Size(13, 33), cv::Size(70, 97), cv::Size(161, 121)}) {
    const cv::Mat video = TexturedFrame(size.width, size.height, seed++);
    Compositor compositor(options);
    cv::RNG rng(seed++);
    std::vector<cv::Mat> layers;
    for (int l = 0; l < 4; ++l) {
      cv::Mat bgra(size, CV_32FC4);
      for (auto it = bgra.begin<cv::Vec4f>(); it != bgra.end<cv::Vec4f>(); ++it) {
        const float a = rng.uniform(0, 3) == 0 ? 0.0f : rng.uniform(0.0f, 1.0f);  // a third uncovered
        *it = cv::Vec4f(a * rng.uniform(0.0f, 1.0f), a * rng.uniform(0.0f, 1.0f), a * rng.uniform(0.0f, 1.0f), a);
      }
      layers.push_back(bgra);
      compositor.Offer(l, {bgra, 0});
    }
    const cv::Mat out = compositor.Compose(video, 0).bgr;
    const cv::Mat saliency = SaliencyFromOpenCv(video, options.inverse_realism);
    double worst = 0;
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        const double keep = 1 - double(options.inverse_realism.strength) * saliency.at<float>(y, x);
        for (int k = 0; k < 3; ++k) {
          double c = video.at<cv::Vec3b>(y, x)[k] / 255.0;
          for (int l = 0; l < 4; ++l) {
            const cv::Vec4f p = layers[l].at<cv::Vec4f>(y, x);
            const double opacity = options.layers[l].blend == BlendMode::kInverseRealism ? keep : 1.0;
            c = opacity * p[k] + (1 - opacity * p[3]) * c;
          }
          const double expected = std::clamp(255 * c, 0.0, 255.0);
          worst = std::max(worst, std::abs(out.at<cv::Vec3b>(y, x)[k] - expected));
        }
      }
    }
    INFO(size.width << "x" << size.height);
    REQUIRE(worst <= 0.5 + 1e-3);
  }
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

// Composing into the caller's image (the pipeline's pooled packets): an image
// of another size is given the frame's, one of the right size keeps its buffer
// frame after frame, and each frame is the hand-computed blend of its own video.
TEST_CASE("compositor: composing into the caller's image reuses its buffer", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"mesh", BlendMode::kAlpha}};
  Compositor compositor(options);
  compositor.Offer(0, ConstantLayer(6, 4, {0.5f, 0.0f, 0.0f, 0.5f}, 1));
  cv::Mat into(2, 3, CV_8UC3);
  std::vector<std::int64_t> ages{7, 7, 7};
  const std::uint8_t* buffer = nullptr;
  for (std::int64_t j = 1; j <= 3; ++j) {
    const double grey = 40.0 * j;
    compositor.Compose(cv::Mat(4, 6, CV_8UC3, cv::Scalar::all(grey)), j, &into, j == 3 ? nullptr : &ages);
    REQUIRE(into.size() == cv::Size(6, 4));
    if (j == 1) buffer = into.data;
    REQUIRE(into.data == buffer);
    // out = c + (1 - a) video, per channel.
    REQUIRE(into.at<cv::Vec3b>(3, 5)[0] == Approx(255 * 0.5 + 0.5 * grey).margin(0.5));
    REQUIRE(into.at<cv::Vec3b>(0, 0)[1] == Approx(0.5 * grey).margin(0.5));
    if (j < 3) REQUIRE(ages == std::vector<std::int64_t>{j - 1});
  }
  REQUIRE(ages == std::vector<std::int64_t>{1});  // untouched when not asked for
}

// Each frame composes the layers it is given: a layer's age is the frame's
// index minus the layer's, whatever the rates at which the layers were made.
TEST_CASE("compositor: the layers passed are composed, and their ages reported", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"fast", BlendMode::kAlpha}, {"slow", BlendMode::kAlpha}};
  const Compositor compositor(options);
  const cv::Mat video(6, 8, CV_8UC3, cv::Scalar(10, 10, 10));
  const OverlayLayer slow = ConstantLayer(8, 6, {0, 0, 0.5f, 0.5f}, 0);
  for (std::int64_t j = 0; j < 60; ++j) {
    const std::array<OverlayLayer, 2> layers{ConstantLayer(8, 6, {0.1f, 0, 0, 0.1f}, j), slow};
    const CompositeFrame out = compositor.Compose(video, j, layers);
    REQUIRE(out.layer_age_frames == std::vector<std::int64_t>{0, j});
    // out = c + (1 - a) video, the slow layer over the fast one.
    REQUIRE(out.bgr.at<cv::Vec3b>(5, 7)[2] == Approx(255 * (0.5 + 0.5 * 0.9 * 10 / 255.0)).margin(0.5));
  }
  REQUIRE_THROWS_WITH(compositor.Compose(video, 0, std::array<OverlayLayer, 1>{slow}),
                      Catch::Contains("1 layers for 2 overlays"));
}

// The one-thread convenience: Offer() keeps the newer of two layers.
TEST_CASE("compositor: an offered layer replaces only an older one", "[stages][unit]") {
  CompositorOptions options;
  options.layers = {{"mesh", BlendMode::kAlpha}};
  Compositor compositor(options);
  const cv::Mat video(6, 8, CV_8UC3, cv::Scalar(10, 10, 10));
  compositor.Offer(0, ConstantLayer(8, 6, {0, 0, 0, 0}, 60));
  compositor.Offer(0, ConstantLayer(8, 6, {0, 0, 0, 0}, 30));
  REQUIRE(compositor.held_layers() == 1);
  REQUIRE(compositor.Compose(video, 61).layer_age_frames == std::vector<std::int64_t>{1});
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
