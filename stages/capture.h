#pragma once

#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "stages/frame_source.h"
#include "stages/stereo_frame.h"

namespace dg::stages {

// Reads recorded stereo video as a user has it, frame by frame, in order.
// Not thread-safe (one reader); knows nothing of the graph that calls it.
//
// Times come from the container (CAP_PROP_POS_MSEC, counted from the first
// frame's, which some files put at one frame period) while it gives strictly
// increasing ones, and are index / fps otherwise (image sequences, or
// containers without timestamps), so the first frame is at 0 s.
// Two inputs of unequal length are read to the end of the shorter: the
// truncation is stated in truncation() and logged once.
class CaptureStage {
 public:
  enum class Layout {
    kTwoFiles,        // left and right video files
    kSideBySide,      // one video file, left eye in the left half
    kImageSequences,  // left and right image sequences (printf field or glob)
  };

  struct Options {
    Layout layout = Layout::kTwoFiles;
    std::string left_path, right_path;  // kSideBySide: left_path only
    // Frame rate: required for image sequences; for videos 0 takes the
    // container's, and a positive value must agree with it (within 0.1%): a
    // rate that contradicts the file would scale every time in the run.
    double fps = 0;
    // Frames the caller expects the recording to hold (a scene's
    // video.frames); 0: not stated. Any other count is an error.
    std::int64_t expected_frames = 0;

    // Empty when valid; otherwise which field is wrong and why.
    std::string Validate() const;
  };

  // Opens the inputs and checks that they agree.
  // @throws dg::Error for invalid options, a missing or unreadable input,
  // inputs of different frame size or frame rate (naming both and their
  // values), or a stated rate or frame count the file contradicts.
  explicit CaptureStage(const Options& options);

  // The next frame into `frame`, reusing its images' buffers (see
  // FrameSource::Read); false after the last.
  // @throws dg::Error when an image of another size turns up mid-stream, or
  // when the first frame with content is the same in both eyes.
  bool Read(StereoFrame* frame);
  // The next frame in new buffers, or std::nullopt after the last.
  std::optional<StereoFrame> Next();

  int frame_count() const { return frame_count_; }  // after any truncation
  double fps() const { return fps_; }
  cv::Size size() const { return size_; }  // of one eye
  // Empty, or which input was cut to which length and why.
  const std::string& truncation() const { return truncation_; }

 private:
  double FrameTime(std::int64_t index, const std::optional<double>& container_t_s);
  // Until a frame with content has been seen: that frame's eyes must differ.
  // @throws dg::Error when they are equal pixel for pixel.
  void CheckEyesDiffer(const StereoFrame& frame);

  Options options_;
  std::unique_ptr<FrameSource> left_, right_;  // right_ is null for side-by-side input
  int frame_count_ = 0;
  double fps_ = 0;
  cv::Size size_;
  std::string truncation_;
  cv::Mat side_by_side_;  // the whole frame of side-by-side input, reused
  std::int64_t next_index_ = 0;
  double first_container_t_s_ = 0;
  double last_t_s_ = -1;
  bool container_times_ = true;
  bool eyes_differ_ = false;  // a frame with content had different eyes
};

// A captured image as the tracker takes it: grey (BGR and BGRA converted,
// grey copied), into `grey`'s buffer when it has the size already.
void ConvertToGrey(const cv::Mat& image, cv::Mat& grey);

}  // namespace dg::stages
