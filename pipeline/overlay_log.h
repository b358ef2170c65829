#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/h5_table.h"
#include "io/run_log.h"
#include "pipeline/frame_packet.h"
#include "pipeline/overlay_stages.h"

namespace dg::pipeline {

// The overlays' record in the run log (a consumer of the run-log sink):
//   /composite        per composed frame: frame, layer_age_frames (one
//                     column per overlay, in drawing order: frames since the
//                     geometry of the layer that was laid over it; -1 none yet);
//                     attributes overlay_names and, after the run,
//                     missing_overlays (MissingOverlays(): empty when every
//                     overlay reached the video);
//   /overlay_timings  per draw: frame, overlay (index), start_ns, end_ns on
//                     the run clock; attributes <name>_published, _dropped
//                     and _drawn per overlay.
class OverlayLog {
 public:
  OverlayLog(io::RunLog& log, std::vector<std::shared_ptr<OverlayBranch>> overlays);

  void Consume(const FramePacket& packet);
  // After the run: the draws' timings and counts. start_steady_ns: the run clock's zero.
  void Finish(std::int64_t start_steady_ns);

  // The overlays none of whose layers was laid over a composed frame, and
  // why, as a sentence for the run to say; empty when each overlay reached
  // the video or no frame was composed with overlays at all.
  std::string MissingOverlays() const;

 private:
  io::RunLog& log_;
  std::vector<std::shared_ptr<OverlayBranch>> overlays_;
  io::H5Table& ages_;
  std::vector<bool> composed_;  // per overlay: a layer of it was laid over a frame
  bool any_frame_ = false;      // a frame was composed with the overlays
};

}  // namespace dg::pipeline
