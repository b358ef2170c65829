#pragma once

#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace dg::stages {

// One recorded stream of frames (a video file or an image sequence), read in
// order. Not thread-safe: one reader.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // The next frame (BGR, 8-bit) into `frame`, and its time from the container
  // in seconds when it gives one; false at the end. A video decodes into
  // frame's own buffer when it has the size and no one else holds it (see
  // OwnBuffer), so a reader that keeps its frames allocates none per frame;
  // an image sequence hands over the decoder's new image.
  // @throws dg::Error for an image of another size than the first.
  virtual bool Read(cv::Mat& frame, std::optional<double>* container_t_s) = 0;
  virtual int frame_count() const = 0;
  virtual double fps() const = 0;  // 0 when the source does not say
  virtual cv::Size size() const = 0;
  virtual const std::string& name() const = 0;  // the path or pattern, for messages
};

// Makes `image` safe to write over: its buffer is dropped (and a new one made
// by the next create()) when another cv::Mat still shares it, e.g. a frame
// an earlier packet handed downstream.
void OwnBuffer(cv::Mat& image);

// A video file through cv::VideoCapture.
// @throws dg::Error when the file is missing or cannot be decoded.
std::unique_ptr<FrameSource> OpenVideo(const std::string& path);

// An image sequence (see ListImageSequence for the pattern).
// @throws dg::Error when nothing matches or the first image cannot be read.
std::unique_ptr<FrameSource> OpenImageSequence(const std::string& pattern);

}  // namespace dg::stages
