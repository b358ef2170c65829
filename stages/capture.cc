#include "stages/capture.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgproc.hpp>

#include <spdlog/logger.h>
#include <tbb/parallel_invoke.h>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::stages {
namespace {

std::string SizeText(const cv::Size& size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

std::string RateText(double fps) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", fps);
  return text;
}

// Both eyes of one recording: same frame size, same rate, lengths reconciled.
void CheckPair(const FrameSource& left, const FrameSource& right) {
  if (left.size() != right.size()) {
    throw Error("the left and right inputs differ in frame size: " + left.name() + " is " +
                    SizeText(left.size()) + ", " + right.name() + " is " + SizeText(right.size()),
                left.name() + ", " + right.name(), "give the two eyes of one stereo recording");
  }
  if (std::abs(left.fps() - right.fps()) > 1e-3 * std::max(left.fps(), right.fps())) {
    throw Error("the left and right videos differ in frame rate: " + left.name() + " at " +
                    std::to_string(left.fps()) + " fps, " + right.name() + " at " + std::to_string(right.fps()) +
                    " fps",
                left.name() + ", " + right.name(), "give the two eyes of one stereo recording");
  }
}

// What the caller states about the recording (a scene's video.fps and
// video.frames) against what the file says: a contradiction is an error, as
// a wrong rate would scale every time and a wrong count hides a cut recording.
void CheckStatedRecording(const CaptureStage::Options& options, const FrameSource& left, std::int64_t frames) {
  const bool video = options.layout != CaptureStage::Layout::kImageSequences;
  if (video && options.fps > 0 && left.fps() > 0 && std::abs(options.fps - left.fps()) > 1e-3 * left.fps()) {
    throw Error("the stated frame rate, " + RateText(options.fps) + " fps, contradicts the video's own, " +
                    RateText(left.fps()) + " fps",
                options.left_path, "state the video's rate (video.fps: " + RateText(left.fps()) + ")");
  }
  if (options.expected_frames > 0 && options.expected_frames != frames) {
    throw Error("the recording holds " + std::to_string(frames) + " frames, not the " +
                    std::to_string(options.expected_frames) + " stated",
                options.left_path, "state its length (video.frames: " + std::to_string(frames) +
                                       ") or leave video.frames out");
  }
}

}  // namespace

std::string CaptureStage::Options::Validate() const {
  if (left_path.empty()) return "no input given";
  if (layout == Layout::kSideBySide && !right_path.empty()) {
    return "a side-by-side video is one file; a right path was given too";
  }
  if (layout != Layout::kSideBySide && right_path.empty()) return "no right input given";
  if (!(fps >= 0) || !std::isfinite(fps)) return "fps must be positive, or 0 for the container's";
  if (expected_frames < 0) return "expected_frames must be positive, or 0 when not stated";
  if (layout == Layout::kImageSequences && fps == 0) return "an image sequence needs its frame rate (fps)";
  return "";
}

CaptureStage::CaptureStage(const Options& options) : options_(options) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw Error(problem, "capture options", "give --left and --right (or one side-by-side video), and --fps for images");
  }
  const bool images = options.layout == Layout::kImageSequences;
  left_ = images ? OpenImageSequence(options.left_path) : OpenVideo(options.left_path);
  frame_count_ = left_->frame_count();
  size_ = left_->size();
  if (options.layout == Layout::kSideBySide) {
    if (size_.width % 2 != 0) {
      throw Error("a side-by-side video needs an even width, this one is " + SizeText(size_), options.left_path,
                  "give the two eyes' images side by side, each half the width");
    }
    size_.width /= 2;
  } else {
    right_ = images ? OpenImageSequence(options.right_path) : OpenVideo(options.right_path);
    CheckPair(*left_, *right_);
    if (left_->frame_count() != right_->frame_count()) {
      frame_count_ = std::min(left_->frame_count(), right_->frame_count());
      truncation_ = "unequal lengths: " + left_->name() + " has " + std::to_string(left_->frame_count()) +
                    " frames, " + right_->name() + " has " + std::to_string(right_->frame_count()) +
                    "; reading the first " + std::to_string(frame_count_) + " of each";
      Logger("stages").warn("capture: {}", truncation_);
    }
  }
  CheckStatedRecording(options, *left_, frame_count_);
  fps_ = options.fps > 0 ? options.fps : left_->fps();
  container_times_ = options.fps == 0;
  if (!(fps_ > 0)) {
    throw Error("the video does not state its frame rate", options.left_path, "give the frame rate (--fps)");
  }
}

double CaptureStage::FrameTime(std::int64_t index, const std::optional<double>& container_t_s) {
  if (index == 0 && container_t_s) first_container_t_s_ = *container_t_s;
  const std::optional<double> t_s =
      container_t_s ? std::optional<double>(*container_t_s - first_container_t_s_) : std::nullopt;
  container_times_ = container_times_ && t_s && (index == 0 || *t_s > last_t_s_);
  last_t_s_ = container_times_ ? *t_s : index / fps_;
  return last_t_s_;
}

bool CaptureStage::Read(StereoFrame* frame) {
  if (next_index_ >= frame_count_) return false;
  std::optional<double> container_t_s, unused;
  bool read = false;
  if (right_) {
    // Two independent readers: decoding a compressed recording is most of
    // capture's time, so both eyes are decoded at once.
    bool right_read = false;
    tbb::parallel_invoke([&] { read = left_->Read(frame->left, &container_t_s); },
                         [&] { right_read = right_->Read(frame->right, &unused); });
    read = read && right_read;
  } else if ((read = left_->Read(side_by_side_, &container_t_s))) {
    // Copies, not views: each eye's buffer stays the frame's own to reuse.
    OwnBuffer(frame->left);
    OwnBuffer(frame->right);
    side_by_side_(cv::Rect(0, 0, size_.width, size_.height)).copyTo(frame->left);
    side_by_side_(cv::Rect(size_.width, 0, size_.width, size_.height)).copyTo(frame->right);
  }
  if (!read) {  // the container promised more frames than it holds
    truncation_ = "the input ended after " + std::to_string(next_index_) + " of the " +
                  std::to_string(frame_count_) + " frames its container states";
    Logger("stages").warn("capture: {}", truncation_);
    frame_count_ = static_cast<int>(next_index_);
    return false;
  }
  if (!eyes_differ_) CheckEyesDiffer(*frame);
  frame->index = next_index_;
  frame->t_s = FrameTime(next_index_, container_t_s);
  ++next_index_;
  return true;
}

void CaptureStage::CheckEyesDiffer(const StereoFrame& frame) {
  // A uniform frame (black before the recording starts) is equal in both eyes
  // of any recording: only a frame with content tells.
  double lowest = 0, highest = 0;
  cv::minMaxLoc(frame.left.reshape(1), &lowest, &highest);
  if (lowest == highest) return;
  if (cv::norm(frame.left, frame.right, cv::NORM_INF) == 0) {
    throw Error("frame " + std::to_string(next_index_) +
                    " is the same in both eyes, pixel for pixel: both eyes show the same video",
                options_.left_path + (options_.right_path.empty() ? "" : " and " + options_.right_path),
                "give each eye its own recording (the scene's video.left and video.right, or --left and --right)");
  }
  eyes_differ_ = true;
}

std::optional<StereoFrame> CaptureStage::Next() {
  StereoFrame frame;
  if (!Read(&frame)) return std::nullopt;
  return frame;
}

void ConvertToGrey(const cv::Mat& image, cv::Mat& grey) {
  if (image.channels() == 1) {
    if (grey.data != image.data) image.copyTo(grey);  // converting in place leaves grey as it is
  } else {
    cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  }
}

}  // namespace dg::stages
