#include "pipeline/overlay_log.h"

#include <algorithm>

#include <fmt/format.h>

#include "sim/statistics.h"

namespace dg::pipeline {

std::string OverlaySummary::Text(double wall_s) const {
  if (composed_frames == 0) return "overlays: no frame was simulated, so none was drawn\n";
  std::string draw_times;
  for (size_t k = 0; k < names.size(); ++k) {
    draw_times += fmt::format("{}{} {:.1f}", k == 0 ? "" : ", ", names[k], draw_ms_median[k]);
  }
  return fmt::format(
      "overlays: {} of {} simulated frames composed with every overlay's layer; layer age median {} / max {} "
      "frames; {:.1f} overlay frames/s ({} draws per overlay in {:.2f} s); draw ms median: {}\n",
      frames_with_layers, composed_frames, age_median_frames, age_max_frames, draws / std::max(wall_s, 1e-9), draws,
      wall_s, draw_times);
}

OverlayLog::OverlayLog(io::RunLog& log, std::vector<std::string> overlay_names)
    : log_(log),
      names_(std::move(overlay_names)),
      ages_(log.AddTable("/composite", {{"frame", io::H5Type::kInt64},
                                        {"layer_age_frames", io::H5Type::kInt64, names_.size()}})),
      frames_with_layer_(names_.size(), 0),
      drawn_(names_.size(), 0) {
  std::string names;
  for (const std::string& name : names_) names += (names.empty() ? "" : ",") + name;
  log_.file().WriteAttribute("/composite", "overlay_names", names);
}

void OverlayLog::Consume(const FramePacket& packet) {
  if (packet.layer_age_frames.size() != names_.size()) return;  // not composed (the run stopped early)
  ages_.AppendRow({packet.index, packet.layer_age_frames});
  for (size_t k = 0; k < names_.size(); ++k) {
    if (packet.draw_end_steady_ns[k] != 0) {
      draws_.push_back({packet.index, static_cast<std::int32_t>(k), packet.draw_start_steady_ns[k],
                        packet.draw_end_steady_ns[k]});
      ++drawn_[k];
    }
  }
  if (!packet.simulation) return;
  ++summary_.composed_frames;
  for (size_t k = 0; k < names_.size(); ++k) {
    const std::int64_t age = packet.layer_age_frames[k];
    if (age < 0) continue;
    ++frames_with_layer_[k];
    shown_ages_.push_back(age);
  }
}

void OverlayLog::Finish(std::int64_t start_steady_ns, const std::string& quality) {
  summary_.names = names_;
  for (size_t k = 0; k < names_.size(); ++k) {
    std::vector<double> ms;
    for (const Draw& draw : draws_) {
      if (draw.overlay == static_cast<std::int32_t>(k)) ms.push_back((draw.end_steady_ns - draw.start_steady_ns) * 1e-6);
    }
    summary_.draw_ms_median.push_back(sim::Median(ms));
  }
  summary_.frames_with_layers = *std::min_element(frames_with_layer_.begin(), frames_with_layer_.end());
  summary_.draws = *std::min_element(drawn_.begin(), drawn_.end());
  if (!shown_ages_.empty()) {
    const std::vector<double> ages(shown_ages_.begin(), shown_ages_.end());
    summary_.age_median_frames = static_cast<std::int64_t>(sim::Median(ages));
    summary_.age_max_frames = *std::max_element(shown_ages_.begin(), shown_ages_.end());
  }
  // A log that could not be written (a full disk) takes no more: its error says why.
  if (log_.write_failed()) return;
  using io::H5Type;
  io::H5Table& table = log_.AddTable("/overlay_timings", {{"frame", H5Type::kInt64},
                                                           {"overlay", H5Type::kInt32},
                                                           {"start_ns", H5Type::kInt64},
                                                           {"end_ns", H5Type::kInt64}});
  for (const Draw& draw : draws_) {
    table.AppendRow({draw.frame, draw.overlay, draw.start_steady_ns - start_steady_ns,
                     draw.end_steady_ns - start_steady_ns});
  }
  table.Flush();
  for (size_t k = 0; k < names_.size(); ++k) {
    log_.file().WriteAttribute("/overlay_timings", names_[k] + "_drawn", drawn_[k]);
  }
  log_.file().WriteAttribute("/composite", "quality", quality);
}

}  // namespace dg::pipeline
