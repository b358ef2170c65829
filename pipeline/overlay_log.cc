#include "pipeline/overlay_log.h"

namespace dg::pipeline {

OverlayLog::OverlayLog(io::RunLog& log, std::vector<std::shared_ptr<OverlayBranch>> overlays)
    : log_(log),
      overlays_(std::move(overlays)),
      ages_(log.AddTable("/composite", {{"frame", io::H5Type::kInt64},
                                        {"layer_age_frames", io::H5Type::kInt64, overlays_.size()}})),
      composed_(overlays_.size(), false) {
  std::string names;
  for (const auto& overlay : overlays_) names += (names.empty() ? "" : ",") + overlay->name();
  log_.file().WriteAttribute("/composite", "overlay_names", names);
}

void OverlayLog::Consume(const FramePacket& packet) {
  if (packet.layer_age_frames.size() != overlays_.size()) return;  // not composed (the run stopped early)
  ages_.AppendRow({packet.index, packet.layer_age_frames});
  any_frame_ = true;
  for (size_t k = 0; k < overlays_.size(); ++k) composed_[k] = composed_[k] || packet.layer_age_frames[k] >= 0;
}

std::string OverlayLog::MissingOverlays() const {
  if (!any_frame_) return {};
  std::string missing;
  for (size_t k = 0; k < overlays_.size(); ++k) {
    if (composed_[k]) continue;
    const OverlayBranch& overlay = *overlays_[k];
    missing += (missing.empty() ? "" : "; ") + overlay.name() + " (geometry handed over " +
               std::to_string(overlay.published()) + " times, drawn " + std::to_string(overlay.drawn()) + " times)";
  }
  if (missing.empty()) return {};
  // Overlays draw beside the chain of frames at their own pace and never hold
  // it (SideBranch, pipeline/stage_graph.h): offline, a short simulated range
  // can end before a drawing does.
  return "no layer of " + missing + " reached the video: each drawing finished after the last frame was composed";
}

void OverlayLog::Finish(std::int64_t start_steady_ns) {
  // A log that could not be written (a full disk) takes no more: its error says why.
  if (log_.write_failed()) return;
  using io::H5Type;
  io::H5Table& table = log_.AddTable("/overlay_timings", {{"frame", H5Type::kInt64},
                                                           {"overlay", H5Type::kInt32},
                                                           {"start_ns", H5Type::kInt64},
                                                           {"end_ns", H5Type::kInt64}});
  for (size_t k = 0; k < overlays_.size(); ++k) {
    const OverlayBranch& overlay = *overlays_[k];
    for (const OverlayTiming& t : overlay.timings()) {
      table.AppendRow({t.frame, static_cast<std::int32_t>(k), t.start_steady_ns - start_steady_ns,
                       t.end_steady_ns - start_steady_ns});
    }
    const std::string& name = overlay.name();
    log_.file().WriteAttribute("/overlay_timings", name + "_published", overlay.published());
    log_.file().WriteAttribute("/overlay_timings", name + "_dropped", static_cast<std::int64_t>(overlay.dropped()));
    log_.file().WriteAttribute("/overlay_timings", name + "_drawn", overlay.drawn());
  }
  table.Flush();
  log_.file().WriteAttribute("/composite", "missing_overlays", MissingOverlays());
}

}  // namespace dg::pipeline
