#include "pipeline/front_end_stages.h"

#include <opencv2/imgproc.hpp>

namespace dg::pipeline {
namespace {

// Into `grey`'s existing buffer when it has the size already (no allocation).
void ToGrey(const cv::Mat& image, cv::Mat& grey) {
  if (image.channels() == 1) {
    image.copyTo(grey);
  } else {
    cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  }
}

}  // namespace

CaptureSource::CaptureSource(const stages::CaptureStage::Options& options, bool rectified_input)
    : capture_(options), rectified_input_(rectified_input) {}

bool CaptureSource::Read(FramePacket& packet) {
  std::optional<stages::StereoFrame> frame = capture_.Next();
  if (!frame) return false;
  packet.index = frame->index;
  packet.t_s = frame->t_s;
  packet.raw = std::move(*frame);
  // Grey before rectification: the tracker needs grey, and remapping one channel is a third of the work.
  ToGrey(packet.raw.left, packet.left_grey);
  ToGrey(packet.raw.right, packet.right_grey);
  if (rectified_input_) packet.rectified = {packet.index, packet.t_s, packet.left_grey, packet.right_grey};
  return true;
}

bool CaptureSource::Skip() { return capture_.Next().has_value(); }

void RectifyAdapter::Process(FramePacket& packet) {
  rectify_->Process({packet.index, packet.t_s, packet.left_grey, packet.right_grey}, &packet.rectified);
}

void TrackAdapter::Process(FramePacket& packet) {
  packet.tracks = tracker_.Process(packet.rectified.left, packet.rectified.right);
}

}  // namespace dg::pipeline
