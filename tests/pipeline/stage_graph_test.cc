// The flow graph on the tiny phantom's real video: lossless and ordered
// offline, dropping and bounded in real time, stopped cleanly by a failing
// stage, and built with exactly the stages a scene needs.
#include "pipeline/stage_graph.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <latch>
#include <map>
#include <mutex>
#include <set>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include "io/calibration.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/front_end_stages.h"
#include "pipeline/scene_graph.h"
#include "sim/error.h"
#include "stages/fem_stage.h"
#include "stages/rectify.h"
#include "tests/support/h5_plain.h"
#include "tests/support/simulated_clock.h"
#include "tests/support/tiny_phantom.h"

namespace dg::pipeline {
namespace {

using dg::testing::TinyPhantomDir;

io::Scene TinyScene() { return io::ReadScene(TinyPhantomDir() + "/scene.yaml"); }

// Frames in flight, counted from the source's read to the sink.
std::atomic<int> in_flight{0}, max_in_flight{0};

// The phantom's capture, counting the packets it fills.
class CountingSource final : public PacketSource {
 public:
  explicit CountingSource(const io::Scene& scene) : capture_(Options(scene), false) {}
  const std::string& name() const override { return capture_.name(); }
  bool Read(FramePacket& packet) override {
    if (!capture_.Read(packet)) return false;
    const int now = ++in_flight;
    int seen = max_in_flight.load();
    while (now > seen && !max_in_flight.compare_exchange_weak(seen, now)) {
    }
    return true;
  }
  bool Skip() override { return capture_.Skip(); }
  double fps() const override { return capture_.fps(); }
  int frame_count() const override { return capture_.frame_count(); }

 private:
  static stages::CaptureStage::Options Options(const io::Scene& scene) {
    stages::CaptureStage::Options options;
    options.left_path = scene.video.left;
    options.right_path = scene.video.right;
    return options;
  }
  CaptureSource capture_;
};

// A stateless stage that records the order in which frames finish it. With
// `overtake` (two threads or more), frame 0 waits until frame 1 has finished,
// so frame 1 overtakes it for certain: the stage runs two frames at once, and
// the sequencer after it must restore the order.
class OvertakingStage final : public PacketStage {
 public:
  explicit OvertakingStage(bool overtake) : overtake_(overtake) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return false; }
  void Process(FramePacket& packet) override {
    if (overtake_ && packet.index == 0) frame_1_done_.wait();
    {
      std::lock_guard lock(mutex_);
      finished_.push_back(packet.index);
    }
    if (overtake_ && packet.index == 1) frame_1_done_.count_down();
  }
  // The frames in the order they finished this stage (after the run).
  std::vector<std::int64_t> finished() const {
    std::lock_guard lock(mutex_);
    return finished_;
  }

 private:
  std::string name_ = "overtake";
  bool overtake_;
  std::latch frame_1_done_{1};
  mutable std::mutex mutex_;
  std::vector<std::int64_t> finished_;
};

// A stateful stage: records the order it sees, may fail, and may take a
// given time a frame on a simulated clock.
class RecordingStage final : public PacketStage {
 public:
  RecordingStage(const testing::SimulatedClock* clock, std::chrono::nanoseconds work, std::int64_t fail_at)
      : clock_(clock), work_(work), fail_at_(fail_at) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override {
    if (packet.index == fail_at_) throw Error("injected failure", "the test's stage", "none: the test wants it");
    seen.push_back(packet.index);
    if (clock_) clock_->AdvanceTo(clock_->Now() + work_);
  }
  std::vector<std::int64_t> seen;

 private:
  std::string name_ = "recorder";
  const testing::SimulatedClock* clock_;
  std::chrono::nanoseconds work_;
  std::int64_t fail_at_;
};

class RecordingSink final : public GraphSink {
 public:
  void Consume(const FramePacket& packet) override {
    --in_flight;
    frames.push_back(packet.index);
  }
  void RecordTimings(std::span<const StageTiming> timings) override { timing_rows += timings.size(); }
  void RecordDrop(std::int64_t frame, std::int64_t) override { drops.push_back(frame); }
  std::vector<std::int64_t> frames, drops;
  std::size_t timing_rows = 0;
};

struct Outcome {
  GraphRunResult result;
  std::vector<std::int64_t> recorded;        // as the stateful stage saw them
  std::vector<std::int64_t> overtaken;       // as frames finished the stateless stage
  RecordingSink sink;
};

// work_per_frame: the recorder's, on a simulated clock the run is paced by and
// timed on; zero: no work, on the steady clock.
Outcome RunTestGraph(int threads, GraphOptions options, std::chrono::nanoseconds work_per_frame = {},
                     std::int64_t fail_at = -1) {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  const testing::SimulatedClock clock;
  const bool simulated = work_per_frame.count() > 0;
  if (simulated) options.clock = &clock;
  in_flight = 0;
  max_in_flight = 0;
  std::vector<std::unique_ptr<PacketStage>> stages;
  auto overtaking = std::make_unique<OvertakingStage>(threads > 1 && options.first_frame == 0);
  OvertakingStage* overtake = overtaking.get();
  stages.push_back(std::move(overtaking));
  auto recorder = std::make_unique<RecordingStage>(simulated ? &clock : nullptr, work_per_frame, fail_at);
  RecordingStage* recorded = recorder.get();
  stages.push_back(std::move(recorder));
  StageGraph graph(std::make_unique<CountingSource>(TinyScene()), std::move(stages), options);
  Outcome outcome;
  outcome.result = graph.Run(outcome.sink);
  outcome.recorded = recorded->seen;
  outcome.overtaken = overtake->finished();
  return outcome;
}

std::vector<std::int64_t> Range(std::int64_t first, std::int64_t end) {
  std::vector<std::int64_t> values;
  for (std::int64_t v = first; v < end; ++v) values.push_back(v);
  return values;
}

}  // namespace

namespace {

// The scene text without one of its top-level blocks.
std::string WithoutBlock(std::string text, const std::string& block) {
  const size_t start = text.find(block + ":\n");
  REQUIRE(start != std::string::npos);
  size_t end = text.find('\n', start);
  while (end + 1 < text.size() && text[end + 1] == ' ') end = text.find('\n', end + 1);
  return text.erase(start, end + 1 - start);
}

io::Scene SceneFromText(const std::string& name, const std::string& text) {
  const std::string path = TinyPhantomDir() + "/" + name;
  std::ofstream(path) << text;
  return io::ReadScene(path);
}

std::vector<std::string> NodeNames(const StageGraph& graph) {
  std::vector<std::string> names;
  for (const StageGraph::Node& node : graph.nodes()) names.push_back(node.name);
  return names;
}

}  // namespace

TEST_CASE("graph: built with exactly the stages the scene needs", "[pipeline][integration]") {
  const io::Scene scene = TinyScene();
  // The phantom's scene: registration from the video, then the combined
  // simulation, whose every frame the three overlays draw in the chain.
  const SceneGraph full = BuildSceneGraph(scene, {});
  REQUIRE(full.graph->stage_names() == std::vector<std::string>{"capture", "rectify", "track", "register",
                                                                "constraints", "simulate", "overlays", "composite", "sink"});
  // One frame at a time from the FEM step to the composite, all of which work on every core.
  std::vector<std::string> limiters;
  for (const StageGraph::Edge& edge : full.graph->edges()) {
    if (full.graph->nodes()[edge.from].kind != "limiter" || full.graph->nodes()[edge.from].name == "limiter") continue;
    limiters.push_back(full.graph->nodes()[edge.from].name + " -> " + full.graph->nodes()[edge.to].name);
  }
  REQUIRE(limiters == std::vector<std::string>{"one_frame_from_simulate -> simulate"});
  REQUIRE(full.overlay_names == std::vector<std::string>{"texture", "volume", "meshes"});
  REQUIRE(full.simulation->motion != nullptr);  // combined: the scan's motion drives the inverse simulation
  REQUIRE(full.simulation->predictor == full.simulation->motion);
  REQUIRE(full.given_registration == nullptr);

  SECTION("without a simulation the graph ends at tracking") {
    const io::Scene front_end =
        SceneFromText("scene_front_end.yaml", WithoutBlock(WithoutBlock(scene.text, "simulation"), "registration"));
    const SceneGraph raw = BuildSceneGraph(front_end, {});
    REQUIRE(raw.graph->stage_names() == std::vector<std::string>{"capture", "rectify", "track", "sink"});
    // A sequencer before the tracker and the sink: each needs the frames in order.
    REQUIRE(NodeNames(*raw.graph) == std::vector<std::string>{"free_packets", "ticker", "limiter", "capture",
                                                              "rectify", "order_before_track", "track",
                                                              "order_before_sink", "sink"});
    REQUIRE(raw.graph->edges().size() == 10);
    REQUIRE(raw.simulation == nullptr);
  }

  SECTION("a scene that gives the registration has no register stage") {
    io::Registration registration;  // the truth's pose: the working-distance check places the scan with it
    registration.period_s = scene.preoperative->period_s;
    const hid_t truth = H5Fopen((TinyPhantomDir() + "/truth.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    REQUIRE(truth >= 0);
    const std::vector<double> T_C_S = testing::h5_plain::Doubles(truth, "/T_C_S");
    H5Fclose(truth);
    registration.T_C_S = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(T_C_S.data());
    io::WriteRegistrationYaml(TinyPhantomDir() + "/registration.yaml", registration);
    const io::Scene given = SceneFromText(
        "scene_registered.yaml", WithoutBlock(scene.text, "registration") + "registration:\n  file: registration.yaml\n");
    const SceneGraph built = BuildSceneGraph(given, {});
    REQUIRE(built.graph->stage_names() ==
            std::vector<std::string>{"capture", "rectify", "track", "constraints", "simulate", "overlays", "composite", "sink"});
    REQUIRE(built.given_registration != nullptr);
  }

  SECTION("the scene's overlay order chooses the overlays; none, no composite stage") {
    std::string text = scene.text;
    text.replace(text.find("overlays:\n"), 10, "overlays:\n  order: [meshes]\n");
    const SceneGraph meshes_only = BuildSceneGraph(SceneFromText("scene_meshes.yaml", text), {});
    REQUIRE(meshes_only.overlay_names == std::vector<std::string>{"meshes"});
    const SceneGraph none = BuildSceneGraph(SceneFromText("scene_no_overlays.yaml", WithoutBlock(scene.text, "overlays")), {});
    REQUIRE(none.overlay_names.empty());
    REQUIRE(none.graph->stage_names().back() == "sink");
    REQUIRE(std::find(none.graph->stage_names().begin(), none.graph->stage_names().end(), "composite") ==
            none.graph->stage_names().end());
  }

  SECTION("surface mode has no inverse simulation, but predicts with the scan's motion across dropped frames") {
    std::string text = scene.text;
    text.replace(text.find("mode: combined"), 14, "mode: surface");
    const SceneGraph built = BuildSceneGraph(SceneFromText("scene_surface.yaml", text), {});
    REQUIRE(built.simulation->motion == nullptr);
    REQUIRE(built.simulation->predictor != nullptr);
  }

  SECTION("a recording that is already rectified has no rectify node") {
    io::StereoCalibration calibration = io::ReadStereoCalibration(scene.calibration);
    calibration.rectification = stages::ComputeRectification(calibration, 0);
    const std::string rectified_calibration = TinyPhantomDir() + "/calibration_rectified.yaml";
    io::WriteStereoCalibration(rectified_calibration, calibration);
    std::string text = WithoutBlock(WithoutBlock(scene.text, "simulation"), "registration");
    text.replace(text.find("calibration.yaml"), 16, "calibration_rectified.yaml");
    text.replace(text.find("video:\n"), 7, "video:\n  rectified: true\n");
    const SceneGraph rectified = BuildSceneGraph(SceneFromText("scene_rectified.yaml", text), {});
    REQUIRE(rectified.graph->stage_names() == std::vector<std::string>{"capture", "track", "sink"});
    // No stateless stage, yet the serial chain's order still needs its sequencers.
    REQUIRE(NodeNames(*rectified.graph) == std::vector<std::string>{"free_packets", "ticker", "limiter", "capture",
                                                                    "order_before_track", "track",
                                                                    "order_before_sink", "sink"});
  }
}

TEST_CASE("graph: offline runs are lossless and ordered on 1 and 2 threads", "[pipeline][integration]") {
  const int frames = TinyScene().video.frames;
  REQUIRE(frames >= 20);
  for (int threads : {1, 2}) {
    CAPTURE(threads);
    const Outcome outcome = RunTestGraph(threads, {});
    REQUIRE(outcome.result.complete);
    REQUIRE(outcome.result.frames_done == frames);
    REQUIRE(outcome.overtaken.size() == static_cast<size_t>(frames));
    if (threads > 1) {  // frame 1 finished the stateless stage before frame 0 ...
      REQUIRE(outcome.overtaken[0] == 1);
      REQUIRE(outcome.overtaken[1] == 0);
    }
    // ... and the stateful stage and the sink still saw every frame in order.
    REQUIRE(outcome.sink.frames == Range(0, frames));
    REQUIRE(outcome.recorded == Range(0, frames));
    REQUIRE(outcome.sink.drops.empty());
    REQUIRE(outcome.sink.timing_rows == static_cast<std::size_t>(frames) * 4);  // capture, overtake, recorder, sink
    REQUIRE(max_in_flight.load() <= GraphOptions{}.max_in_flight);
  }
}

// The reference the benchmark measures the graph's overhead against: the
// same stages in a plain loop produce the same tracks and simulation, frame for frame.
TEST_CASE("graph: the inline run tracks exactly as the graph does", "[pipeline][integration]") {
  struct TrackCounts final : GraphSink {
    void Consume(const FramePacket& packet) override {
      std::int64_t id_sum = 0;
      for (const stages::TrackedPoint& p : packet.tracks.points) id_sum += p.id;
      tracks.push_back({packet.index, static_cast<std::int64_t>(packet.tracks.points.size()), id_sum});
      if (packet.simulation) nodes.push_back(packet.simulation->nodes_S_m);
    }
    void RecordTimings(std::span<const StageTiming>) override {}
    void RecordDrop(std::int64_t, std::int64_t) override {}
    std::vector<std::array<std::int64_t, 3>> tracks;  // frame, points, sum of ids
    std::vector<Eigen::Matrix3Xd> nodes;              // per simulated frame
  } graph_sink, inline_sink;
  const io::Scene scene = TinyScene();
  REQUIRE(BuildSceneGraph(scene, {}).graph->Run(graph_sink).complete);
  REQUIRE(BuildSceneGraph(scene, {}).graph->RunInline(inline_sink).complete);
  REQUIRE(graph_sink.tracks.size() == static_cast<size_t>(scene.video.frames));
  REQUIRE(graph_sink.tracks[5][1] > 10);
  REQUIRE(inline_sink.tracks == graph_sink.tracks);
  // The simulation starts once the registration window is full, and is bitwise the same.
  REQUIRE(graph_sink.nodes.size() > 5);
  REQUIRE(inline_sink.nodes.size() == graph_sink.nodes.size());
  for (size_t k = 0; k < graph_sink.nodes.size(); ++k) REQUIRE((inline_sink.nodes[k].array() == graph_sink.nodes[k].array()).all());
}

TEST_CASE("graph: a frame range streams only those frames", "[pipeline][integration]") {
  GraphOptions options;
  options.first_frame = 5;
  options.end_frame = 12;
  const Outcome outcome = RunTestGraph(2, options);
  REQUIRE(outcome.result.complete);
  REQUIRE(outcome.sink.frames == Range(5, 12));
}

// A stage at 2.5 frame periods (on a simulated clock) cannot keep up with the
// video clock: frames are dropped at capture, every drop is reported once,
// every frame is either processed or dropped, and no more than the limit are
// ever in flight. Over the video's n frames the stage takes one frame in 2.5
// periods, n / 2.5, besides the frames the graph and the capture buffer hold
// at the end (2 + 3) and the first: at least n - (n / 2.5 + 6) are dropped
// (12 of the tiny phantom's 30). The pacer's waits may move the clock by up
// to a period more per frame: at most n - n / 3.5 are dropped (21 of 30).
// The tiny phantom drops 16 or 17.
TEST_CASE("graph: realtime drops when a stage is too slow, and logs every drop", "[pipeline][integration]") {
  const io::Scene scene = TinyScene();
  const int frames = scene.video.frames;
  GraphOptions options;
  options.policy = Policy::kRealtime;
  const auto period = std::chrono::nanoseconds(std::llround(1e9 / scene.video.fps));
  const Outcome outcome = RunTestGraph(2, options, period * 5 / 2);
  REQUIRE(outcome.result.complete);
  CAPTURE(outcome.result.frames_dropped, frames);
  REQUIRE(outcome.result.frames_dropped >= frames - (frames / 2.5 + 6));
  REQUIRE(outcome.result.frames_dropped <= frames - frames / 3.5);
  REQUIRE(outcome.sink.drops.size() == static_cast<std::size_t>(outcome.result.frames_dropped));
  std::set<std::int64_t> accounted(outcome.sink.frames.begin(), outcome.sink.frames.end());
  for (std::int64_t frame : outcome.sink.drops) REQUIRE(accounted.insert(frame).second);
  REQUIRE(std::vector<std::int64_t>(accounted.begin(), accounted.end()) == Range(0, frames));
  REQUIRE(std::is_sorted(outcome.sink.frames.begin(), outcome.sink.frames.end()));
  REQUIRE(max_in_flight.load() <= options.max_in_flight);
}

// A camera at 5 frames per second whose frame 1 takes 2.5 periods to
// process, as a first detection does.
class SlowCamera final : public PacketSource {
 public:
  static constexpr double kFps = 5;
  const std::string& name() const override { return name_; }
  bool Read(FramePacket& packet) override {
    if (next_ == kFrames) return false;
    packet.index = next_++;
    return true;
  }
  bool Skip() override { return next_ < kFrames ? (++next_, true) : false; }
  double fps() const override { return kFps; }
  int frame_count() const override { return kFrames; }
  static constexpr int kFrames = 6;

 private:
  std::string name_ = "capture";
  std::int64_t next_ = 0;
};

class SlowOnceStage final : public PacketStage {
 public:
  explicit SlowOnceStage(const testing::SimulatedClock& clock) : clock_(clock) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override {
    // From the frame's arrival (the run's clock and the simulated one both
    // start at zero), so that the end does not depend on when the pacer
    // moved the clock to the next frame's arrival.
    const auto work = std::chrono::nanoseconds(std::llround(2.5e9 / SlowCamera::kFps));
    if (packet.index == 1) clock_.AdvanceTo(RunClock::TimePoint(std::chrono::nanoseconds(packet.captured_ns)) + work);
  }

 private:
  std::string name_ = "slow once";
  const testing::SimulatedClock& clock_;
};

struct LatencySink final : GraphSink {
  void Consume(const FramePacket& packet) override { frames.push_back(packet.index); }
  void RecordTimings(std::span<const StageTiming> timings) override {
    latency_s[timings.front().frame] = (timings.back().end_ns - timings.front().start_ns) * 1e-9;
  }
  void RecordDrop(std::int64_t frame, std::int64_t) override { drops.push_back(frame); }
  std::vector<std::int64_t> frames, drops;
  std::map<std::int64_t, double> latency_s;
};

// One slow frame costs latency, not frames, while the capture buffer holds
// the frames that arrive behind it; with a buffer of one the frame that
// arrived during the slow one is lost. The latency counts from arrival.
TEST_CASE("graph: realtime's capture buffer absorbs one slow frame", "[pipeline][integration]") {
  const double period_s = 1 / SlowCamera::kFps;
  auto run = [](int buffer) {
    const testing::SimulatedClock clock;
    GraphOptions options;
    options.policy = Policy::kRealtime;
    options.max_in_flight = 1;
    options.capture_buffer_frames = buffer;
    options.clock = &clock;
    std::vector<std::unique_ptr<PacketStage>> stages;
    stages.push_back(std::make_unique<SlowOnceStage>(clock));
    StageGraph graph(std::make_unique<SlowCamera>(), std::move(stages), options);
    LatencySink sink;
    REQUIRE(graph.Run(sink).complete);
    return sink;
  };
  const LatencySink buffered = run(3);
  REQUIRE(buffered.drops.empty());
  REQUIRE(buffered.frames == Range(0, SlowCamera::kFrames));
  // On the simulated clock only frame 1's work takes time: it arrived at 1
  // period and was done at 3.5, and frame 2 arrived at 2 and waited until
  // then. Both are exact: no wait for a later arrival is pending while they
  // finish (frame 3's, at 3 periods, has passed). The frames after may end
  // at their successor's arrival, as the pacer moves the clock there.
  REQUIRE(buffered.latency_s.at(1) == Approx(2.5 * period_s).margin(1e-9));
  REQUIRE(buffered.latency_s.at(2) == Approx(1.5 * period_s).margin(1e-9));
  // Frame 1 ends at 3.5 periods, when frame 3 (3 periods) is the newest: frame 2 is gone.
  const LatencySink newest_only = run(1);
  REQUIRE(newest_only.drops == std::vector<std::int64_t>{2});
}

// The side branches' drains while the frames stream, in order; a stage
// waits on it for a drain.
struct DrainLog {
  std::mutex mutex;
  std::condition_variable drained;
  std::vector<std::string> order;  // the branch of each drain
  bool streaming = true;           // false: the drains after the last frame are not logged

  size_t size() {
    std::lock_guard lock(mutex);
    return order.size();
  }
  // Until more than `seen` drains are logged; false after 10 s, which only a
  // graph that stopped draining its branches takes.
  bool WaitBeyond(size_t seen) {
    std::unique_lock lock(mutex);
    return drained.wait_for(lock, std::chrono::seconds(10), [&] { return order.size() > seen; });
  }
};

class CountingBranch final : public SideBranch {
 public:
  CountingBranch(std::string name, DrainLog& log) : name_(std::move(name)), log_(log) {}
  const std::string& name() const override { return name_; }
  const std::string& fed_by() const override { return feeder_; }
  void Drain() override {
    {
      std::lock_guard lock(log_.mutex);
      if (!log_.streaming) return;
      log_.order.push_back(name_);
    }
    log_.drained.notify_all();
  }

 private:
  std::string name_, feeder_ = "waker";
  DrainLog& log_;
};

// Wakes both branches every frame (the FEM stage handing its geometry to two
// overlays), then waits for a drain, so that the chain never outruns the
// side node and a branch is always woken again while the other is pending.
class WakingStage final : public PacketStage {
 public:
  WakingStage(std::vector<std::shared_ptr<CountingBranch>> branches, DrainLog& log)
      : branches_(std::move(branches)), log_(log) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override {
    const size_t seen = log_.size();
    for (const auto& branch : branches_) branch->Wake();
    waits_timed_out += !log_.WaitBeyond(seen);
    if (packet.index == kLastFrame) {
      std::lock_guard lock(log_.mutex);
      log_.streaming = false;
    }
  }
  static constexpr int kLastFrame = 59;
  int waits_timed_out = 0;

 private:
  std::string name_ = "waker";
  std::vector<std::shared_ptr<CountingBranch>> branches_;
  DrainLog& log_;
};

class SixtyFrames final : public PacketSource {
 public:
  const std::string& name() const override { return name_; }
  bool Read(FramePacket& packet) override {
    if (next_ > WakingStage::kLastFrame) return false;
    packet.index = next_++;
    return true;
  }
  bool Skip() override { return false; }
  double fps() const override { return 30; }
  int frame_count() const override { return WakingStage::kLastFrame + 1; }

 private:
  std::string name_ = "capture";
  std::int64_t next_ = 0;
};

// Each frame wakes both branches, the first first. Were the pending branches
// drained in a fixed order, the first, woken again while the second waits,
// would be drained every time and the second only after the last frame. In
// turn, a branch drained is next passed over for the other if that one is
// pending, and the other is pending from the same frame's wake on, so no
// branch is drained more than twice in a row: each takes at least a third
// of the drains.
TEST_CASE("graph: side branches take turns while the frames stream", "[pipeline][integration]") {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, 2);
  DrainLog log;
  const auto first = std::make_shared<CountingBranch>("first", log);
  const auto second = std::make_shared<CountingBranch>("second", log);
  std::vector<std::unique_ptr<PacketStage>> stages;
  auto waking = std::make_unique<WakingStage>(std::vector<std::shared_ptr<CountingBranch>>{first, second}, log);
  const WakingStage& waker = *waking;
  stages.push_back(std::move(waking));
  StageGraph graph(std::make_unique<SixtyFrames>(), std::move(stages), {}, {first, second});
  RecordingSink sink;
  REQUIRE(graph.Run(sink).complete);
  REQUIRE(waker.waits_timed_out == 0);
  const std::vector<std::string>& order = log.order;
  REQUIRE(order.size() >= static_cast<size_t>(WakingStage::kLastFrame + 1));  // one drain a frame at least
  size_t run = 1, longest_run = 1;
  for (size_t k = 1; k < order.size(); ++k) {
    run = order[k] == order[k - 1] ? run + 1 : 1;
    longest_run = std::max(longest_run, run);
  }
  const auto drains_of = [&](const std::string& name) { return std::count(order.begin(), order.end(), name); };
  CAPTURE(order.size(), drains_of("first"), drains_of("second"));
  REQUIRE(longest_run <= 2);
  REQUIRE(3 * drains_of("first") >= static_cast<std::ptrdiff_t>(order.size()) - 2);
  REQUIRE(3 * drains_of("second") >= static_cast<std::ptrdiff_t>(order.size()) - 2);
}

TEST_CASE("graph: a failing stage stops the graph, naming stage and frame", "[pipeline][integration]") {
  for (int threads : {1, 2}) {
    CAPTURE(threads);
    const Outcome outcome = RunTestGraph(threads, {}, {}, 7);
    REQUIRE_FALSE(outcome.result.complete);
    REQUIRE_THAT(outcome.result.error, Catch::Contains("stage 'recorder' failed at frame 7") &&
                                           Catch::Contains("injected failure"));
    REQUIRE(outcome.sink.frames == Range(0, 7));
  }
}

}  // namespace dg::pipeline
