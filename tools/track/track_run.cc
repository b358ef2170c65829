#include "tools/track/track_run.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <unordered_set>

#include "pipeline/stop_request.h"
#include "sim/error.h"
#include "sim/progress.h"
#include "tools/track/track_table.h"

namespace dg::tools {
namespace {

// The graph's frames into the table, with progress.
class TrackSink final : public pipeline::GraphSink {
 public:
  TrackSink(TrackTable& table, Progress& progress) : table_(table), progress_(progress) {}

  void Consume(const pipeline::FramePacket& packet) override {
    table_.Add(packet.index, packet.t_s, packet.tracks);
    for (const stages::TrackedPoint& p : packet.tracks.points) ids_.insert(p.id);
    char detail[64];
    std::snprintf(detail, sizeof detail, "%zu points", packet.tracks.points.size());
    progress_.Update(double(table_.frames()), detail);
  }
  void RecordTimings(std::span<const pipeline::StageTiming>) override {}
  void RecordDrop(std::int64_t, std::int64_t) override {}  // offline: the graph drops nothing

  std::int64_t tracks() const { return static_cast<std::int64_t>(ids_.size()); }

 private:
  TrackTable& table_;
  Progress& progress_;
  std::unordered_set<std::int64_t> ids_;
};

}  // namespace

TrackRunSummary RunTrack(const TrackRunOptions& options) {
  pipeline::GraphOptions graph_options;
  graph_options.first_frame = options.first_frame;
  graph_options.end_frame = options.end_frame;
  pipeline::SceneGraph built =
      pipeline::BuildSceneGraph(FrontEndScene(options.input), graph_options, FrontEndSettingsOf(options.input));
  const std::int64_t frame_count = built.graph->source().frame_count();
  const std::int64_t end = options.end_frame < 0 ? frame_count : std::min(options.end_frame, frame_count);
  if (options.first_frame < 0 || options.first_frame >= end) {
    throw Error("the frame range " + std::to_string(options.first_frame) + ":" + std::to_string(options.end_frame) +
                    " holds none of the " + std::to_string(frame_count) + " frames",
                "--frames", "give A:B with 0 <= A < B, B at most the frame count");
  }
  if (const std::filesystem::path folder = std::filesystem::path(options.out_h5).parent_path(); !folder.empty()) {
    std::error_code error;
    std::filesystem::create_directories(folder, error);
    if (error) throw Error("cannot create the folder: " + error.message(), folder.string(), "give --out in a writable place");
  }
  TrackTable table(options.out_h5, options.out_csv);
  Progress progress("track", double(end - options.first_frame), options.progress);
  TrackSink sink(table, progress);
  const pipeline::GraphRunResult result = built.graph->Run(sink);
  progress.Finish();
  if (!result.complete && result.stop_signal != 0) {
    throw pipeline::Interrupted(result.stop_signal, result.error, options.out_h5,
                                "the frames tracked are saved (marked complete = 0); run again for the whole recording");
  }
  if (!result.complete) {
    throw Error(result.error, options.out_h5, "the frames before the failure are saved (marked complete = 0)");
  }
  table.Finish();
  TrackRunSummary summary;
  summary.frames = static_cast<int>(result.frames_done);
  summary.rows = table.rows();
  summary.tracks = sink.tracks();
  summary.ms_per_frame = summary.frames > 0 ? 1e3 * result.wall_s / summary.frames : 0;
  return summary;
}

}  // namespace dg::tools
