#pragma once

#include <functional>
#include <vector>

#include "io/h5_table.h"
#include "io/run_log.h"
#include "pipeline/stage_graph.h"

namespace dg::pipeline {

// The graph's sink for `dynaguide run`: every frame's results and timings
// into the run log (/tracks, /timings, /drops), then to further consumers
// (the annotated video, progress), in frame order on one thread at a time.
// The log is flushed every `flush_every` frames, so a killed run loses at
// most that many frames of its log.
class RunLogSink final : public GraphSink {
 public:
  using Consumer = std::function<void(const FramePacket&)>;

  RunLogSink(io::RunLog& log, std::vector<Consumer> consumers, int flush_every = 30);

  void Consume(const FramePacket& packet) override;
  void RecordTimings(std::span<const StageTiming> timings) override;
  void RecordDrop(std::int64_t frame, std::int64_t at_ns) override;

  // Every timing recorded, for the run's summary.
  const std::vector<StageTiming>& timings() const { return timings_; }

 private:
  io::RunLog& log_;
  io::H5Table& tracks_;
  std::vector<Consumer> consumers_;
  int flush_every_;
  std::int64_t frames_ = 0;
  std::vector<StageTiming> timings_;
};

}  // namespace dg::pipeline
