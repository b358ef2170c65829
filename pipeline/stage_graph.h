#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "pipeline/packet_stage.h"
#include "pipeline/run_clock.h"

namespace dg::pipeline {

enum class Policy {
  kOffline,   // lossless: every frame of the range is processed, as fast as possible
  kRealtime,  // paced to the video clock; frames are dropped at capture when the graph falls behind
};

// "offline" or "realtime". @throws dg::Error for another name.
Policy ParsePolicy(const std::string& name);
const char* PolicyName(Policy policy);

struct GraphOptions {
  Policy policy = Policy::kOffline;
  // Packets in flight (the limiter's tokens): two keep two cores busy (the
  // front end of one frame beside the simulation of the one before) and bound
  // the latency to about two frames; a third only queues (on the default
  // phantom: the same offline rate, and 30 ms more latency in real time).
  int max_in_flight = 2;
  // Realtime only: frames the camera's capture queue holds until the graph
  // takes them (a V4L2 driver queues 2 to 4; OpenCV's V4L2 backend asks for
  // 4). A frame is lost only once this many newer frames have arrived, so a
  // single slow frame (the first detection, the registration's solve) costs
  // latency, not frames. 1 keeps only the newest frame. A frame's latency
  // counts from its arrival, so the time it waits here is never hidden.
  int capture_buffer_frames = 3;
  std::int64_t first_frame = 0;  // frames before it are skipped
  std::int64_t end_frame = -1;   // one past the last frame; -1: to the end of the recording
  // Offline only: frames the source skips as the realtime policy skips the
  // frames it is behind on (logged to /drops, each packet's dropped_before
  // counting them), so a live run's drops replay deterministically.
  std::set<std::int64_t> drop_frames;
  // The clock real time is paced by and every timing is taken on; it must
  // outlive the run. Null: the steady clock (a test gives a simulated one).
  const RunClock* clock = nullptr;

  std::string Validate() const;  // empty when valid
};

// Where the graph's results go: called on one thread at a time, packets in
// order of their sequence, drops in order of frame.
class GraphSink {
 public:
  virtual ~GraphSink() = default;
  virtual void Consume(const FramePacket& packet) = 0;
  // The packet's stage timings, the sink's own last, after Consume returned.
  virtual void RecordTimings(std::span<const StageTiming> timings) = 0;
  // A frame the realtime policy dropped at capture; at_ns on the run clock.
  virtual void RecordDrop(std::int64_t frame, std::int64_t at_ns) = 0;
};

// Work beside the graph's chain of frames (the overlays): a stage hands it
// values through the branch's own bounded SPSC ring and calls Wake(). The
// graph runs the woken branches' Drain() beside the chain, one at a time, in
// turn; a wake while a branch waits or drains marks it for another turn
// rather than queueing a call. Drain() takes the newest value its ring holds
// (dropping the older), works on it and returns, so a slow branch skips to
// the newest value, never holds the chain back, and never keeps the others
// from their turns. After the last frame the graph calls every Drain() once
// more, so the newest value handed over is not left behind.
class SideBranch {
 public:
  virtual ~SideBranch() = default;
  virtual const std::string& name() const = 0;
  // The stage that feeds it (for the graph's description).
  virtual const std::string& fed_by() const = 0;
  // @throws anything: the graph stops reading frames, and the run fails naming the branch.
  virtual void Drain() = 0;
  // For the feeding stage, after it pushed into the ring.
  void Wake() const {
    if (wake_) wake_();
  }

 private:
  friend class StageGraph;
  std::function<void()> wake_;
};

// How a run ended.
struct GraphRunResult {
  std::int64_t frames_done = 0;
  std::int64_t frames_dropped = 0;
  double wall_s = 0;
  std::int64_t start_steady_ns = 0;  // the run clock's zero (timings' start_ns) on the steady clock
  bool complete = false;
  std::string error;  // when not complete: which stage failed at which frame, and why
  // The signal whose stop request (pipeline/stop_request.h) ended the run
  // early; 0 otherwise. Then error says at which frame.
  int stop_signal = 0;
};

// The TBB flow graph of a run:
//
//   ticker -> join(free packet, tick) -> source -> stages... -> sink -> free packets
//
// A packet is a token: the reserving join lets the source start a frame only
// when a packet is free, so at most max_in_flight frames are in the graph.
// A run of stages that each work on all cores (PacketStage::parallel_inside)
// sits behind a limiter that admits one frame at a time.
// Stateless stages run with unlimited concurrency; a sequencer restores the
// order before any stateful stage and before the sink. A stage that throws
// stops the graph: the source reads no more, the frames before the failing
// one complete and reach the sink, later ones drain through untouched, and
// the run result names the stage and the frame. Nothing aborts. A stop
// requested by a signal (pipeline/stop_request.h) ends a run the same way
// without a failure: the source reads no more, and every frame it read
// reaches the sink (docs/interrupts.md).
class StageGraph {
 public:
  // @throws dg::Error for invalid options, no source, more stages than a
  // packet can time, or a side branch fed by a stage the graph does not have.
  StageGraph(std::unique_ptr<PacketSource> source, std::vector<std::unique_ptr<PacketStage>> stages,
             const GraphOptions& options, std::vector<std::shared_ptr<SideBranch>> branches = {});
  ~StageGraph();

  // The names a timing's stage index refers to: the source, the stages, "sink".
  const std::vector<std::string>& stage_names() const { return stage_names_; }

  struct Node {
    std::string name, kind;  // kind: ticker, join, source, stateless, stateful, sequencer, limiter, sink, buffer, side
  };
  struct Edge {
    int from, to;  // indices into nodes()
  };
  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<Edge>& edges() const { return edges_; }
  // The nodes and edges as text, one per line (for `dynaguide run --print-graph`).
  std::string Describe() const;

  // Streams the frame range through the graph in the calling thread's task
  // arena (its parallelism is the caller's to bound). Once per graph.
  GraphRunResult Run(GraphSink& sink);
  // The same stages, timings and sink called in sequence on the calling
  // thread, without the flow graph: the reference for the graph's overhead
  // (`dynaguide bench pipeline`). Once per graph, instead of Run().
  GraphRunResult RunInline(GraphSink& sink);

  const PacketSource& source() const { return *source_; }

 private:
  class Runner;
  void Plan();
  // Whether stage i starts, or ends, a run of adjacent stages that work on
  // all cores (PacketStage::parallel_inside).
  bool OpensCoreSpan(size_t stage) const;
  bool ClosesCoreSpan(size_t stage) const;

  std::unique_ptr<PacketSource> source_;
  std::vector<std::unique_ptr<PacketStage>> stages_;
  std::vector<std::shared_ptr<SideBranch>> branches_;
  GraphOptions options_;
  std::vector<std::string> stage_names_;
  std::vector<Node> nodes_;
  std::vector<Edge> edges_;
  bool ran_ = false;
};

}  // namespace dg::pipeline
