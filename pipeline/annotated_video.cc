#include "pipeline/annotated_video.h"

#include <chrono>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::pipeline {
namespace {

// The tracked points on one eye's picture (`eye`, a view into the canvas:
// drawing clips to it), where that eye sees them.
void DrawTrackedPoints(const FramePacket& packet, bool right_eye, cv::Mat eye) {
  const cv::Scalar corner(60, 220, 60), mser(0, 160, 255);  // BGR
  for (const stages::TrackedPoint& p : packet.tracks.points) {
    const Eigen::Vector2d& uv = right_eye ? p.uv_right_px : p.uv_left_px;
    // Sub-pixel positions: 2 fractional bits, so a circle sits where the point is.
    cv::circle(eye, cv::Point2d(uv.x(), uv.y()) * 4, 3 * 4, p.kind == stages::FeatureKind::kMser ? mser : corner, 1,
               cv::LINE_AA, 2);
  }
}

void DrawTracks(const FramePacket& packet, VideoLayout layout, cv::Mat& canvas) {
  const cv::Size eye = packet.raw.left.size();
  DrawTrackedPoints(packet, false, canvas(cv::Rect({0, 0}, eye)));
  if (layout == VideoLayout::kSideBySide) DrawTrackedPoints(packet, true, canvas(cv::Rect({eye.width, 0}, eye)));
  char label[128];
  std::snprintf(label, sizeof label, "frame %lld  t %.3f s  %zu tracks", static_cast<long long>(packet.index),
                packet.t_s, packet.tracks.points.size());
  cv::putText(canvas, label, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(canvas, label, {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
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
                               Policy policy, int ring_frames)
    : path_(path),
      layout_(layout),
      policy_(policy),
      writer_(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps,
              LayoutSize(eye_size, layout)),
      ring_(ring_frames) {
  if (!writer_.isOpened()) {
    throw Error("cannot open the annotated video for writing", path, "check the directory exists and is writable");
  }
  writer_.set(cv::VIDEOWRITER_PROP_QUALITY, 90);
  encoder_ = std::thread([this] { Encode(); });
}

AnnotatedVideo::~AnnotatedVideo() {
  try {
    Close();
  } catch (const std::exception& e) {
    Logger("pipeline").error("{}", e.what());
  }
}

void AnnotatedVideo::Add(const FramePacket& packet) {
  ArrangePicture(packet, layout_, &canvas_);
  DrawTracks(packet, layout_, canvas_);
  if (policy_ == Policy::kRealtime) {
    ring_.PushOrDrop(canvas_);
  } else {
    while (!ring_.TryPush(canvas_)) {
      if (closing_.load()) throw Error("the annotated video was closed while frames were still coming", path_,
                                       "close it after the graph has finished");
      wake_.notify_one();
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  wake_.notify_one();
}

void AnnotatedVideo::Encode() {
  cv::Mat frame;
  for (;;) {
    while (ring_.TryPop(frame)) {
      writer_.write(frame);
      ++written_;
    }
    if (closing_.load()) {
      while (ring_.TryPop(frame)) {  // what arrived between the last pop and the close
        writer_.write(frame);
        ++written_;
      }
      return;
    }
    std::unique_lock lock(wake_mutex_);
    wake_.wait_for(lock, std::chrono::milliseconds(5));
  }
}

void AnnotatedVideo::Close() {
  if (!encoder_.joinable()) return;
  closing_ = true;
  wake_.notify_one();
  encoder_.join();
  writer_.release();
  if (dropped() > 0) {
    Logger("pipeline").warn("{}: {} frames dropped because the encoder fell behind", path_, dropped());
  }
}

}  // namespace dg::pipeline
