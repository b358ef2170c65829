#include "pipeline/run_log_sink.h"

#include "stages/track/track_rows.h"

namespace dg::pipeline {

RunLogSink::RunLogSink(io::RunLog& log, std::vector<Consumer> consumers, int flush_every)
    : log_(log),
      tracks_(log.AddTable("/tracks", stages::TrackRowColumns())),
      consumers_(std::move(consumers)),
      flush_every_(flush_every) {}

void RunLogSink::Consume(const FramePacket& packet) {
  stages::AppendTrackRows(tracks_, packet.index, packet.t_s, packet.tracks);
  for (const Consumer& consume : consumers_) consume(packet);
  if (++frames_ % flush_every_ == 0) log_.Flush();
}

void RunLogSink::RecordTimings(std::span<const StageTiming> timings) {
  for (const StageTiming& t : timings) log_.AppendTiming(t.frame, t.stage, t.thread, t.start_ns, t.end_ns);
  timings_.insert(timings_.end(), timings.begin(), timings.end());
}

void RunLogSink::RecordDrop(std::int64_t frame, std::int64_t at_ns) { log_.AppendDrop(frame, at_ns); }

}  // namespace dg::pipeline
