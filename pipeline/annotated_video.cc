#include "pipeline/annotated_video.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::pipeline {
namespace {

// High enough that the tracked points' one-pixel circles and the labels stay sharp.
constexpr int kJpegQuality = 90;

// The tracked points on one eye's picture (`eye`, a view into the picture:
// drawing clips to it), where that eye sees them.
void DrawTrackedPoints(const std::vector<stages::TrackedPoint>& points, bool right_eye, cv::Mat eye) {
  const cv::Scalar corner(60, 220, 60), mser(0, 160, 255);  // BGR
  for (const stages::TrackedPoint& p : points) {
    const Eigen::Vector2d& uv = right_eye ? p.uv_right_px : p.uv_left_px;
    // Sub-pixel positions: 2 fractional bits, so a circle sits where the point is.
    cv::circle(eye, cv::Point2d(uv.x(), uv.y()) * 4, 3 * 4, p.kind == stages::FeatureKind::kMser ? mser : corner, 1,
               cv::LINE_AA, 2);
  }
}

void DrawLabel(const std::string& text, int baseline_y, cv::Mat& picture) {
  cv::putText(picture, text, {8, baseline_y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(picture, text, {8, baseline_y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

// "layer age: texture 0, volume 0, meshes 0 frames" ("-" for an overlay with no layer).
std::string AgeLabel(const std::vector<std::string>& names, const std::vector<std::int64_t>& ages) {
  std::string label = "layer age:";
  for (size_t k = 0; k < names.size() && k < ages.size(); ++k) {
    label += fmt::format("{} {} {}", k == 0 ? "" : ",", names[k], ages[k] < 0 ? "-" : std::to_string(ages[k]));
  }
  return label + " frames";
}

// The frame's tracks and labels, drawn on its picture.
void DrawTracks(VideoLayout layout, const std::vector<std::string>& age_labels, AnnotatedVideo::Frame* frame) {
  cv::Mat& picture = frame->picture;
  const cv::Size eye(layout == VideoLayout::kSideBySide ? picture.cols / 2 : picture.cols, picture.rows);
  DrawTrackedPoints(frame->points, false, picture(cv::Rect({0, 0}, eye)));
  if (layout == VideoLayout::kSideBySide) {
    DrawTrackedPoints(frame->points, true, picture(cv::Rect({eye.width, 0}, eye)));
  }
  DrawLabel(fmt::format("frame {}  t {:.3f} s  {} tracks", frame->index, frame->t_s, frame->points.size()), 20,
            picture);
  if (!age_labels.empty()) DrawLabel(AgeLabel(age_labels, frame->layer_age_frames), 40, picture);
}

}  // namespace

cv::Size LayoutSize(cv::Size eye, VideoLayout layout) {
  return layout == VideoLayout::kSideBySide ? cv::Size(2 * eye.width, eye.height) : eye;
}

void ArrangePicture(const FramePacket& packet, VideoLayout layout, cv::Mat* picture) {
  const cv::Mat& left = packet.composite.empty() ? packet.raw.left : packet.composite;
  if (layout == VideoLayout::kLeft) {
    left.copyTo(*picture);
    return;
  }
  const cv::Mat& right = packet.composite_right.empty() ? packet.raw.right : packet.composite_right;
  if (right.size() != left.size() || right.type() != left.type()) {
    throw Error("the right frame is " + std::to_string(right.cols) + "x" + std::to_string(right.rows) +
                    ", the left " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                    ": they cannot be shown side by side",
                "side-by-side picture of frame " + std::to_string(packet.index),
                "record both eyes at the same resolution, or use the left layout");
  }
  picture->create(LayoutSize(left.size(), layout), left.type());
  left.copyTo((*picture)(cv::Rect({0, 0}, left.size())));
  right.copyTo((*picture)(cv::Rect({left.cols, 0}, right.size())));
}

AnnotatedVideo::AnnotatedVideo(const std::string& path, double fps, cv::Size eye_size, VideoLayout layout,
                               Policy policy, std::vector<std::string> age_labels, int queue_frames)
    : path_(path),
      layout_(layout),
      age_labels_(std::move(age_labels)),
      policy_(policy),
      writer_(path, fps, LayoutSize(eye_size, layout), kJpegQuality),
      queue_(queue_frames) {}

AnnotatedVideo::~AnnotatedVideo() {
  try {
    Close();
  } catch (const std::exception& e) {
    Logger("pipeline").error("{}", e.what());
  }
}

void AnnotatedVideo::Start() {
  DG_CHECK(!encoder_.joinable() && !closed_);
  encoder_ = std::thread([this] { Encode(); });
}

void AnnotatedVideo::Add(const FramePacket& packet) {
  if (closed_) {
    throw Error("the annotated video was closed while frames were still coming", path_,
                "close it after the graph has finished");
  }
  DG_CHECK(encoder_.joinable());  // Start() first
  if (failed_.load(std::memory_order_acquire)) {
    error_thrown_ = true;
    std::rethrow_exception(error_);
  }
  ArrangePicture(packet, layout_, &next_.picture);
  next_.points.assign(packet.tracks.points.begin(), packet.tracks.points.end());
  next_.index = packet.index;
  next_.t_s = packet.t_s;
  if (!age_labels_.empty()) next_.layer_age_frames.assign(packet.layer_age_frames.begin(), packet.layer_age_frames.end());
  // Realtime never waits for the encoder; offline waits for room, so every frame is written.
  const bool queued = policy_ == Policy::kRealtime ? queue_.TryPush(next_) : queue_.Push(next_);
  if (!queued) ++dropped_;
}

void AnnotatedVideo::Encode() {
  Frame frame;
  try {
    while (queue_.Pop(frame)) {  // false once closed and drained
      DrawTracks(layout_, age_labels_, &frame);
      writer_.Write(frame.picture);
      ++written_;
    }
  } catch (...) {
    error_ = std::current_exception();
    failed_.store(true, std::memory_order_release);
    // Take what is still queued, so that a sink waiting for room goes on to its error.
    while (queue_.Pop(frame)) {
    }
  }
}

void AnnotatedVideo::Close() {
  if (closed_) return;
  closed_ = true;
  queue_.Close();
  if (encoder_.joinable()) encoder_.join();
  writer_.Close();
  if (dropped() > 0) {
    Logger("pipeline").warn("{}: {} frames dropped because the encoder fell behind", path_, dropped());
  }
  if (error_ && !error_thrown_) {
    error_thrown_ = true;
    std::rethrow_exception(error_);
  }
}

}  // namespace dg::pipeline
