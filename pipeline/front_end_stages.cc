#include "pipeline/front_end_stages.h"

namespace dg::pipeline {

CaptureSource::CaptureSource(const stages::CaptureStage::Options& options, bool rectified_input)
    : capture_(options), rectified_input_(rectified_input) {}

bool CaptureSource::Read(FramePacket& packet) {
  if (!capture_.Read(&packet.raw)) return false;  // into the pooled packet's own images
  packet.index = packet.raw.index;
  packet.t_s = packet.raw.t_s;
  // Grey before rectification: the tracker needs grey, and remapping one channel is a third of the work.
  stages::ConvertToGrey(packet.raw.left, packet.left_grey);
  stages::ConvertToGrey(packet.raw.right, packet.right_grey);
  if (rectified_input_) packet.rectified = {packet.index, packet.t_s, packet.left_grey, packet.right_grey};
  return true;
}

bool CaptureSource::Skip() { return capture_.Read(&skipped_); }

void RectifyAdapter::Process(FramePacket& packet) {
  rectify_->Process({packet.index, packet.t_s, packet.left_grey, packet.right_grey}, &packet.rectified);
}

void TrackAdapter::Process(FramePacket& packet) {
  tracker_.Process(packet.rectified.left, packet.rectified.right, &packet.tracks, &packet.track_timings);
}

}  // namespace dg::pipeline
