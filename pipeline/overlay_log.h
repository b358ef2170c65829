#pragma once

#include <cstdint>
#include <memory>
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
//                     attribute overlay_names;
//   /overlay_timings  per draw: frame, overlay (index), start_ns, end_ns on
//                     the run clock; attributes <name>_published, _dropped
//                     and _drawn per overlay.
class OverlayLog {
 public:
  OverlayLog(io::RunLog& log, std::vector<std::shared_ptr<OverlayBranch>> overlays);

  void Consume(const FramePacket& packet);
  // After the run: the draws' timings and counts. start_steady_ns: the run clock's zero.
  void Finish(std::int64_t start_steady_ns);

 private:
  io::RunLog& log_;
  std::vector<std::shared_ptr<OverlayBranch>> overlays_;
  io::H5Table& ages_;
};

}  // namespace dg::pipeline
