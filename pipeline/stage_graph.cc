#include "pipeline/stage_graph.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <map>
#include <mutex>
#include <sstream>
#include <tuple>

#include <oneapi/tbb/flow_graph.h>
#include <oneapi/tbb/task_arena.h>

#include "pipeline/pacer.h"
#include "pipeline/stop_request.h"
#include "sim/log.h"
#include "sim/error.h"

namespace dg::pipeline {

namespace flow = tbb::flow;

Policy ParsePolicy(const std::string& name) {
  if (name == "offline") return Policy::kOffline;
  if (name == "realtime") return Policy::kRealtime;
  throw Error("unknown policy '" + name + "'", "--policy", "use offline (lossless) or realtime (paced, drops frames)");
}

const char* PolicyName(Policy policy) { return policy == Policy::kOffline ? "offline" : "realtime"; }

std::string GraphOptions::Validate() const {
  if (max_in_flight < 1) return "at least one frame must be allowed in flight";
  if (capture_buffer_frames < 1) return "the capture buffer must hold at least one frame";
  if (first_frame < 0) return "the first frame must not be negative";
  if (end_frame >= 0 && end_frame <= first_frame) return "the frame range is empty";
  if (!drop_frames.empty() && policy == Policy::kRealtime) {
    return "frames to drop are for the offline policy (the realtime policy drops the frames it is behind on)";
  }
  if (!drop_frames.empty() && *drop_frames.begin() < 0) return "a frame to drop must not be negative";
  return {};
}

StageGraph::StageGraph(std::unique_ptr<PacketSource> source, std::vector<std::unique_ptr<PacketStage>> stages,
                       const GraphOptions& options, std::vector<std::shared_ptr<SideBranch>> branches)
    : source_(std::move(source)), stages_(std::move(stages)), branches_(std::move(branches)), options_(options) {
  if (const std::string wrong = options_.Validate(); !wrong.empty()) {
    throw Error("invalid graph options: " + wrong, "pipeline", "check --frames, --policy and --drop");
  }
  if (!source_) throw Error("the graph has no source", "pipeline", "give a capture stage");
  if (stages_.size() + 2 > static_cast<size_t>(FramePacket::kMaxStages)) {
    throw Error("the graph has " + std::to_string(stages_.size()) + " stages; a packet times at most " +
                    std::to_string(FramePacket::kMaxStages - 2),
                "pipeline", "raise FramePacket::kMaxStages");
  }
  Plan();
}

StageGraph::~StageGraph() = default;

void StageGraph::Plan() {
  stage_names_ = {source_->name()};
  for (const auto& stage : stages_) stage_names_.push_back(stage->name());
  stage_names_.push_back("sink");

  auto add = [this](std::string name, std::string kind) {
    nodes_.push_back({std::move(name), std::move(kind)});
    return static_cast<int>(nodes_.size()) - 1;
  };
  const int free_packets = add("free_packets", "buffer");
  const int ticker = add("ticker", "ticker");
  const int join = add("limiter", "join");
  edges_ = {{free_packets, join}, {ticker, join}};
  int previous = add(source_->name(), "source");
  edges_.push_back({join, previous});
  edges_.push_back({previous, free_packets});  // a packet the source could not fill goes straight back

  // A stateful stage and the sink need the frames in order, and a sequencer
  // before each restores it. A stateless (unlimited) stage reorders frames;
  // so, rarely, does a chain of serial nodes: a serial node's queue keeps the
  // order of the puts, but the puts of consecutive frames come from the
  // tasks of the node before it, on any thread, and may cross (TBB keeps
  // order only for puts from one thread).
  auto chain = [&](int node) {
    edges_.push_back({previous, node});
    previous = node;
  };
  std::map<std::string, int> stage_nodes;
  for (size_t i = 0; i < stages_.size(); ++i) {
    const PacketStage& stage = *stages_[i];
    if (OpensCoreSpan(i) && !stage.stateful()) {
      throw Error("stage '" + stage.name() + "' begins a run of stages that work on all cores but is stateless",
                  "pipeline", "begin such a run with a stateful stage, so that frames enter it in order");
    }
    if (stage.stateful()) chain(add("order_before_" + stage.name(), "sequencer"));
    if (OpensCoreSpan(i)) chain(add("one_frame_from_" + stage.name(), "limiter"));
    chain(add(stage.name(), stage.stateful() ? "stateful" : "stateless"));
    stage_nodes[stage.name()] = previous;
  }
  for (const auto& branch : branches_) {
    const auto feeder = stage_nodes.find(branch->fed_by());
    if (feeder == stage_nodes.end()) {
      throw Error("side branch '" + branch->name() + "' is fed by '" + branch->fed_by() + "', which is not in the graph",
                  "pipeline", "add the feeding stage, or leave the branch out");
    }
    edges_.push_back({feeder->second, add(branch->name(), "side")});
  }
  const int last_stage = previous;
  previous = last_stage;
  chain(add("order_before_sink", "sequencer"));
  chain(add("sink", "sink"));
  edges_.push_back({previous, free_packets});
}

bool StageGraph::OpensCoreSpan(size_t stage) const {
  return stages_[stage]->parallel_inside() && (stage == 0 || !stages_[stage - 1]->parallel_inside());
}

bool StageGraph::ClosesCoreSpan(size_t stage) const {
  return stages_[stage]->parallel_inside() &&
         (stage + 1 == stages_.size() || !stages_[stage + 1]->parallel_inside());
}

std::string StageGraph::Describe() const {
  std::ostringstream text;
  text << "nodes:\n";
  for (const Node& node : nodes_) text << "  " << node.name << " (" << node.kind << ")\n";
  text << "edges:\n";
  for (const Edge& edge : edges_) text << "  " << nodes_[edge.from].name << " -> " << nodes_[edge.to].name << "\n";
  return text.str();
}

// The flow graph of one run: built from the plan, run once, torn down.
class StageGraph::Runner {
 public:
  Runner(StageGraph& plan, GraphSink& sink)
      : plan_(plan),
        sink_(sink),
        clock_(plan.options_.clock ? *plan.options_.clock : SteadyRunClock()),
        packets_(plan.options_.max_in_flight),
        free_(graph_),
        ticker_(graph_, [this](tbb::flow_control& control) { return NextTick(control); }),
        paced_ticks_(graph_),
        join_(graph_),
        source_node_(graph_, flow::serial, [this](const std::tuple<Packet, Tick>& in, SourceNode::output_ports_type& out) {
          Packet packet = std::get<0>(in);
          if (Capture(*packet)) {
            std::get<0>(out).try_put(packet);
          } else {
            std::get<1>(out).try_put(packet);
          }
        }) {
    flow::make_edge(free_, flow::input_port<0>(join_));
    // Offline, the ticker gives a tick whenever the join asks. In real time
    // the pacer's thread puts each tick when its frame arrives: no TBB
    // worker waits for the video clock (docs/design.md#threads).
    if (Realtime()) {
      pacer_ = std::make_unique<Pacer>([this] { paced_ticks_.try_put(ticks_++); }, [this] { graph_.release_wait(); },
                                       clock_);
      flow::make_edge(paced_ticks_, flow::input_port<1>(join_));
    } else {
      flow::make_edge(ticker_, flow::input_port<1>(join_));
    }
    flow::make_edge(join_, source_node_);
    flow::make_edge(flow::output_port<1>(source_node_), free_);

    flow::sender<Packet>* previous = &flow::output_port<0>(source_node_);
    auto chain = [&](auto& node) {
      flow::make_edge(*previous, node);
      previous = &node;
    };
    // A run of stages that each work on all cores admits one frame at a
    // time (PacketStage::parallel_inside): a limiter before its first stage,
    // whose count the last stage's node releases when a frame leaves it.
    OneFrame* span = nullptr;
    for (size_t i = 0; i < plan_.stages_.size(); ++i) {
      PacketStage& stage = *plan_.stages_[i];
      if (stage.stateful()) chain(AddSequencer());
      if (plan_.OpensCoreSpan(i)) {
        spans_.push_back(std::make_unique<OneFrame>(graph_, 1));
        span = spans_.back().get();
        chain(*span);
      }
      OneFrame* closes = plan_.ClosesCoreSpan(i) ? span : nullptr;
      const int index = static_cast<int>(i) + 1;
      stage_nodes_.push_back(std::make_unique<StageNode>(
          graph_, stage.stateful() ? flow::serial : flow::unlimited, [this, &stage, index, closes](Packet packet) {
            Timed(*packet, index, [&] { stage.Process(*packet); });
            if (closes) closes->decrementer().try_put(flow::continue_msg());
            return packet;
          }));
      chain(*stage_nodes_.back());
    }
    chain(AddSequencer());
    const int sink_index = static_cast<int>(plan_.stage_names_.size()) - 1;
    sink_node_ = std::make_unique<StageNode>(graph_, flow::serial, [this, sink_index](Packet packet) {
      Consume(*packet, sink_index);
      return packet;
    });
    chain(*sink_node_);
    flow::make_edge(*sink_node_, free_);

    // The side branches share one serial node that rejects what arrives while
    // it runs: a wake marks its branch pending and wakes the node, which
    // drains the pending branches in turn. (A node per branch starves all but
    // the busiest: the others' one task, spawned once, stays under its newer
    // tasks in a worker's last-in-first-out deque for the whole run.)
    if (!plan_.branches_.empty()) {
      side_pending_ = std::make_unique<std::atomic<bool>[]>(plan_.branches_.size());
      side_node_ = std::make_unique<SideNode>(graph_, flow::serial, [this](flow::continue_msg) {
        DrainPendingSides();
        return flow::continue_msg();
      });
    }
    for (size_t b = 0; b < plan_.branches_.size(); ++b) {
      plan_.branches_[b]->wake_ = [this, b] {
        side_pending_[b] = true;
        side_node_->try_put(flow::continue_msg());
      };
    }
  }

  // Tasks the nodes spawned on their own (a buffer forwarding to a new
  // successor) finish before the nodes are destroyed.
  ~Runner() {
    graph_.wait_for_all();
    for (const auto& branch : plan_.branches_) branch->wake_ = nullptr;
  }

  GraphRunResult Run() {
    start_ = clock_.Now();
    if (SkipToFirstFrame()) {
      for (FramePacket& packet : packets_) free_.try_put(&packet);
      if (pacer_) {
        graph_.reserve_wait();  // released by the pacer's thread as it ends
        pacer_->Start();
        pacing_thread_ = true;
        pacer_->Schedule(start_);  // the first frame arrives now
      } else {
        ticker_.activate();
      }
      graph_.wait_for_all();
      if (pacer_) pacer_->Join();
    }
    for (const auto& branch : plan_.branches_) DrainSide(*branch);  // what the last wakes left
    return Finish();
  }

  // The same stage calls, timings and sink, one frame after another on the
  // calling thread without the flow graph: the reference the graph's overhead
  // is measured against.
  GraphRunResult RunInline() {
    start_ = clock_.Now();
    // Inline, a wake drains at once: every value handed over is taken.
    for (const auto& branch : plan_.branches_) branch->wake_ = [this, b = branch.get()] { DrainSide(*b); };
    if (SkipToFirstFrame()) {
      FramePacket& packet = packets_.front();
      const int sink_index = static_cast<int>(plan_.stage_names_.size()) - 1;
      while (!Failed() && WaitForArrival() && Capture(packet)) {
        for (size_t i = 0; i < plan_.stages_.size(); ++i) {
          Timed(packet, static_cast<int>(i) + 1, [&] { plan_.stages_[i]->Process(packet); });
        }
        Consume(packet, sink_index);
      }
    }
    return Finish();
  }

 private:
  GraphRunResult Finish() {
    result_.complete = !Failed() && stopped_by_ == 0;
    if (!Failed() && stopped_by_ != 0) {
      result_.stop_signal = stopped_by_;
      result_.error = "interrupted by " + SignalName(stopped_by_) +
                      (last_consumed_frame_ < 0 ? std::string(" before the first frame")
                                                : " at frame " + std::to_string(last_consumed_frame_) +
                                                      " (the last frame read: every frame read reached the log)");
    }
    result_.frames_dropped += trailing_drops_;
    for (std::int64_t k = 0; k < trailing_drops_; ++k) {
      sink_.RecordDrop(position_ - trailing_drops_ + k, NowNs());
    }
    result_.wall_s = NowNs() * 1e-9;
    result_.start_steady_ns =
        std::chrono::duration_cast<std::chrono::nanoseconds>(start_.time_since_epoch()).count();
    return std::move(result_);
  }

  using Packet = FramePacket*;
  using Tick = std::int64_t;
  using SourceNode = flow::multifunction_node<std::tuple<Packet, Tick>, std::tuple<Packet, Packet>>;
  using StageNode = flow::function_node<Packet, Packet>;
  using Sequencer = flow::sequencer_node<Packet>;
  using OneFrame = flow::limiter_node<Packet>;
  using SideNode = flow::function_node<flow::continue_msg, flow::continue_msg, flow::rejecting>;

  std::int64_t NowNs() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(clock_.Now() - start_).count();
  }

  Sequencer& AddSequencer() {
    sequencers_.push_back(std::make_unique<Sequencer>(graph_, [](const Packet& packet) {
      return static_cast<size_t>(packet->sequence);
    }));
    return *sequencers_.back();
  }

  bool SkipToFirstFrame() {
    for (; position_ < plan_.options_.first_frame; ++position_) {
      if (!plan_.source_->Skip()) {
        Fail("the recording has only " + std::to_string(position_) + " frames; the range starts at frame " +
                 std::to_string(plan_.options_.first_frame),
             0);
        return false;
      }
    }
    return true;
  }

  Tick NextTick(tbb::flow_control& control) {
    if (source_ended_.load() || Failed()) control.stop();
    return ticks_++;
  }

  bool Failed() const { return failed_sequence_.load() != kNone; }
  // Whether a packet comes after a failure: it is passed on untouched, so the
  // graph drains, and the frames before the failure all reach the sink.
  bool AfterFailure(const FramePacket& packet) const { return packet.sequence >= failed_sequence_.load(); }

  bool AtEnd() const { return plan_.options_.end_frame >= 0 && position_ >= plan_.options_.end_frame; }

  bool Realtime() const { return plan_.options_.policy == Policy::kRealtime; }

  // Realtime, inline: the caller's thread waits until the frame at the
  // current position arrives (the graph's pacer does this on its own thread).
  // False if the wait was stopped.
  bool WaitForArrival() {
    if (!pacer_ || video_clock_start_ns_ < 0) return true;
    return pacer_->WaitUntil(start_ + std::chrono::nanoseconds(ArrivalNs()));
  }

  // Realtime: the camera delivers frame `first + n` at n / fps on the video
  // clock (started with the first frame). Frames more than the capture buffer
  // behind the newest delivered one are lost. A frame not yet delivered is
  // never read: the pacer ticks for the frame at the current position only
  // once it has arrived. Returns the frames lost.
  int PaceToVideoClock() {
    if (video_clock_start_ns_ < 0) video_clock_start_ns_ = NowNs();  // the first frame arrives now
    const double fps = plan_.source_->fps();
    const std::int64_t first = plan_.options_.first_frame;
    const double video_s = (NowNs() - video_clock_start_ns_) * 1e-9;
    const std::int64_t newest = first + static_cast<std::int64_t>(std::floor(video_s * fps));
    const std::int64_t oldest_held = newest - plan_.options_.capture_buffer_frames + 1;
    int dropped = 0;
    while (position_ < oldest_held && !AtEnd() && plan_.source_->Skip()) {
      ++position_;
      ++dropped;
    }
    return dropped;
  }

  // Realtime: when the frame at the current position arrived (or arrives) on the run clock.
  std::int64_t ArrivalNs() const {
    const double due_s = (position_ - plan_.options_.first_frame) / plan_.source_->fps();
    return video_clock_start_ns_ + static_cast<std::int64_t>(std::llround(due_s * 1e9));
  }

  // Offline: the frames the options name to drop, from the current position on.
  int SkipFramesToDrop() {
    int dropped = 0;
    while (plan_.options_.drop_frames.contains(position_) && !AtEnd() && plan_.source_->Skip()) {
      ++position_;
      ++dropped;
    }
    return dropped;
  }

  // The source stage: fills the packet with the next frame; false at the
  // end. In real time it then asks the pacer for the tick of the next frame.
  bool Capture(FramePacket& packet) {
    const bool read = CaptureFrame(packet);
    if (pacing_thread_) {
      if (read) {
        pacer_->Schedule(start_ + std::chrono::nanoseconds(ArrivalNs()));
      } else {
        pacer_->Stop();
      }
    }
    return read;
  }

  bool CaptureFrame(FramePacket& packet) {
    if (source_ended_.load() || Failed()) return false;
    if (const int signal = StopSignal(); signal != 0) {  // the frames in flight still finish
      stopped_by_ = signal;
      source_ended_ = true;
      return false;
    }
    const bool realtime = Realtime();
    const int dropped = realtime ? PaceToVideoClock() : SkipFramesToDrop();
    // Offline, capture starts after pacing. In real time it starts when the
    // camera delivered the frame, so the source's span and the frame's
    // latency include the time it waited in the capture buffer.
    const std::int64_t start = realtime ? std::min(ArrivalNs(), NowNs()) : NowNs();
    bool read = false;
    packet.ResetFor(next_sequence_);
    Guard(plan_.source_->name(), packet, position_, [&] { read = !AtEnd() && plan_.source_->Read(packet); });
    if (!read) {
      trailing_drops_ += dropped;
      source_ended_ = true;
      return false;
    }
    ++position_;
    ++next_sequence_;
    packet.dropped_before = dropped;
    packet.captured_ns = start;
    Record(packet, 0, start);
    return true;
  }

  void Consume(FramePacket& packet, int sink_index) {
    if (AfterFailure(packet)) return;
    const std::int64_t start = NowNs();
    Guard("sink", packet, packet.index, [&] {
      for (int k = packet.dropped_before; k > 0; --k) sink_.RecordDrop(packet.index - k, packet.captured_ns);
      sink_.Consume(packet);
    });
    Record(packet, sink_index, start);
    if (AfterFailure(packet)) return;
    Guard("sink", packet, packet.index,
          [&] { sink_.RecordTimings({packet.timings.data(), size_t(packet.timing_count)}); });
    ++result_.frames_done;
    result_.frames_dropped += packet.dropped_before;
    last_consumed_frame_ = packet.index;
  }

  template <typename Work>
  void Timed(FramePacket& packet, int stage_index, Work&& work) {
    if (AfterFailure(packet)) return;
    const std::int64_t start = NowNs();
    Guard(plan_.stage_names_[stage_index], packet, packet.index, work);
    Record(packet, stage_index, start);
  }

  void Record(FramePacket& packet, int stage_index, std::int64_t start) {
    packet.timings[packet.timing_count++] = {packet.index, stage_index,
                                             tbb::this_task_arena::current_thread_index(), start, NowNs()};
  }

  // A side branch that throws stops the source; the frames already read still complete.
  // The pending side branches, each in turn from the one after the last
  // drained, until none is pending.
  void DrainPendingSides() {
    const size_t count = plan_.branches_.size();
    for (bool drained = true; drained && !Failed();) {
      drained = false;
      for (size_t k = 0; k < count && !drained; ++k) {
        const size_t b = (next_side_ + k) % count;
        if (!side_pending_[b].exchange(false)) continue;
        DrainSide(*plan_.branches_[b]);
        next_side_ = (b + 1) % count;
        drained = true;
      }
    }
  }

  void DrainSide(SideBranch& branch) {
    try {
      branch.Drain();
    } catch (const std::exception& e) {
      Fail("side branch '" + branch.name() + "' failed: " + e.what(), kNone - 1);
    }
  }

  // Runs one stage's work on a packet; an exception stops the graph, naming stage and frame.
  template <typename Work>
  void Guard(const std::string& stage, const FramePacket& packet, std::int64_t frame, Work&& work) {
    try {
      work();
    } catch (const std::exception& e) {
      Fail("stage '" + stage + "' failed at frame " + std::to_string(frame) + ": " + e.what(), packet.sequence);
    } catch (...) {
      Fail("stage '" + stage + "' failed at frame " + std::to_string(frame) + " with an unknown exception",
           packet.sequence);
    }
  }

  // Stops the graph at the packet of this sequence: the source reads no more,
  // and it and later packets drain through untouched. (Cancelling the graph's
  // task group instead would also stop the frames before the failure that are
  // still queued, and their results would be lost.)
  void Fail(const std::string& message, std::int64_t sequence) {
    std::lock_guard lock(error_mutex_);
    if (sequence >= failed_sequence_.load()) return;  // a consequence of an earlier frame's failure
    failed_sequence_ = sequence;
    result_.error = message;
    Logger("pipeline").error("{}", message);
    if (pacer_) pacer_->Stop();  // the source reads no more: no frame to wait for
  }

  StageGraph& plan_;
  GraphSink& sink_;
  const RunClock& clock_;
  std::vector<FramePacket> packets_;
  RunClock::TimePoint start_;

  // Written by the serial source only.
  std::int64_t position_ = 0;  // frames taken from the source, read or skipped
  std::int64_t next_sequence_ = 0;
  std::int64_t trailing_drops_ = 0;
  std::int64_t video_clock_start_ns_ = -1;  // realtime: when the first frame was live
  int stopped_by_ = 0;  // the signal whose stop request ended the reading
  Tick ticks_ = 0;  // written by the ticker, or in real time by the pacer's thread, only
  bool pacing_thread_ = false;  // realtime, in the graph: the pacer's thread ticks

  static constexpr std::int64_t kNone = INT64_MAX;
  std::atomic<bool> source_ended_{false};
  std::atomic<std::int64_t> failed_sequence_{kNone};  // the first failed packet's
  std::mutex error_mutex_;
  GraphRunResult result_;  // counts written by the serial sink; error under error_mutex_
  std::int64_t last_consumed_frame_ = -1;  // written by the serial sink

  flow::graph graph_;
  flow::buffer_node<Packet> free_;
  flow::input_node<Tick> ticker_;                 // offline
  flow::buffer_node<Tick> paced_ticks_;           // realtime: the pacer's ticks
  std::unique_ptr<Pacer> pacer_;                  // realtime only
  flow::join_node<std::tuple<Packet, Tick>, flow::reserving> join_;
  SourceNode source_node_;
  std::vector<std::unique_ptr<Sequencer>> sequencers_;
  std::vector<std::unique_ptr<OneFrame>> spans_;  // one per run of stages that work on all cores
  std::vector<std::unique_ptr<StageNode>> stage_nodes_;
  std::unique_ptr<StageNode> sink_node_;
  std::unique_ptr<SideNode> side_node_;                 // runs DrainPendingSides
  std::unique_ptr<std::atomic<bool>[]> side_pending_;  // per branch: woken since its last drain
  size_t next_side_ = 0;                               // the branch drained first next time
};

GraphRunResult StageGraph::Run(GraphSink& sink) {
  if (ran_) throw Error("a graph runs once", "pipeline", "build a new graph for another run");
  ran_ = true;
  Runner runner(*this, sink);
  return runner.Run();
}

GraphRunResult StageGraph::RunInline(GraphSink& sink) {
  if (ran_) throw Error("a graph runs once", "pipeline", "build a new graph for another run");
  ran_ = true;
  Runner runner(*this, sink);
  return runner.RunInline();
}

}  // namespace dg::pipeline
