#include "tools/track/track_run.h"

#include <algorithm>
#include <cstdio>
#include <unordered_set>

#include "sim/error.h"
#include "tools/progress.h"
#include "tools/track/track_table.h"

namespace dg::tools {

TrackRunSummary RunTrack(const TrackRunOptions& options) {
  FrontEnd front_end(options.input);
  const std::int64_t end =
      options.end_frame < 0 ? front_end.frame_count() : std::min<std::int64_t>(options.end_frame, front_end.frame_count());
  if (options.first_frame < 0 || options.first_frame >= end) {
    throw Error("the frame range " + std::to_string(options.first_frame) + ":" + std::to_string(options.end_frame) +
                    " holds none of the " + std::to_string(front_end.frame_count()) + " frames",
                "--frames", "give A:B with 0 <= A < B, B at most the frame count");
  }
  front_end.Skip(options.first_frame);
  Progress progress("track", double(end - options.first_frame), options.progress);
  TrackTable table(options.out_h5, options.out_csv);
  TrackRunSummary summary;
  std::unordered_set<std::int64_t> ids;
  double total_ms = 0;
  for (std::int64_t i = options.first_frame; i < end; ++i) {
    FrontEndTimings timings;
    const std::optional<FrontEndFrame> frame = front_end.Next(&timings);
    if (!frame) break;
    table.Add(frame->index, frame->t_s, frame->tracks);
    for (const stages::TrackedPoint& p : frame->tracks.points) ids.insert(p.id);
    total_ms += timings.total_ms();
    ++summary.frames;
    char detail[96];
    std::snprintf(detail, sizeof detail, "%zu points, %.1f ms/frame", frame->tracks.points.size(),
                  total_ms / summary.frames);
    progress.Update(summary.frames, detail);
  }
  progress.Finish();
  table.Finish();
  summary.rows = table.rows();
  summary.tracks = static_cast<std::int64_t>(ids.size());
  summary.ms_per_frame = summary.frames > 0 ? total_ms / summary.frames : 0;
  return summary;
}

}  // namespace dg::tools
