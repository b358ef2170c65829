// An overlay four times slower than the video, as a side branch of a graph
// paced to the video clock: the frames and the geometry producer keep their
// pace (every frame reaches the sink, composed with an ever older layer), what the overlay skips is
// counted, and the geometry held at once stays bounded by the ring.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include "io/registration_file.h"
#include "pipeline/overlay_stages.h"
#include "pipeline/stage_graph.h"
#include "stages/fem_stage.h"

namespace dg::pipeline {
namespace {

constexpr int kFrames = 40;
const cv::Size kSize(160, 120);

// Geometries alive at once, and the most ever.
std::atomic<int> live_geometries{0}, most_live_geometries{0};

class BlankSource final : public PacketSource {
 public:
  const std::string& name() const override { return name_; }
  bool Read(FramePacket& packet) override {
    if (next_ == kFrames) return false;
    packet.index = next_++;
    packet.t_s = packet.index / fps();
    packet.raw.left.create(kSize, CV_8UC3);
    packet.raw.left.setTo(cv::Scalar(40, 60, 180));
    return true;
  }
  bool Skip() override { return next_ < kFrames && ++next_; }
  double fps() const override { return 30; }
  int frame_count() const override { return kFrames; }

 private:
  std::string name_ = "blank";
  int next_ = 0;
};

// Stands in for the FEM stage: a new geometry per frame, handed to the overlay.
class GeometryStage final : public PacketStage {
 public:
  explicit GeometryStage(std::shared_ptr<OverlayBranch> overlay) : overlay_(std::move(overlay)) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override {
    const int now = ++live_geometries;
    int most = most_live_geometries.load();
    while (now > most && !most_live_geometries.compare_exchange_weak(most, now)) {
    }
    packet.simulation = std::shared_ptr<const stages::FemFrameOutput>(new stages::FemFrameOutput{},
                                                                      [](const stages::FemFrameOutput* output) {
                                                                        --live_geometries;
                                                                        delete output;
                                                                      });
    packet.registration = registration_;
    overlay_->Publish(packet);
  }

 private:
  std::string name_ = "simulate";
  std::shared_ptr<OverlayBranch> overlay_;
  std::shared_ptr<const io::Registration> registration_ = std::make_shared<io::Registration>();
};

// An overlay that takes four frame periods per layer.
OverlayFactory SlowOverlay() {
  return [](const Eigen::Isometry3d&) {
    return [](const Eigen::Matrix3Xd&, std::int64_t frame) {
      std::this_thread::sleep_for(std::chrono::milliseconds(133));
      stages::overlay::OverlayLayer layer;
      layer.bgra = cv::Mat(kSize, CV_32FC4, cv::Scalar(0.5f, 0.5f, 0.5f, 0.5f));
      layer.frame = frame;
      return layer;
    };
  };
}

class AgeSink final : public GraphSink {
 public:
  void Consume(const FramePacket& packet) override {
    frames.push_back(packet.index);
    ages.push_back(packet.layer_age_frames.at(0));
  }
  void RecordTimings(std::span<const StageTiming>) override {}
  void RecordDrop(std::int64_t, std::int64_t) override {}
  std::vector<std::int64_t> frames, ages;
};

}  // namespace

TEST_CASE("overlay branch: a slow overlay holds back neither the frames nor the geometry", "[pipeline][integration]") {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, 2);
  stages::overlay::CompositorOptions options;
  options.layers = {{"slow", stages::overlay::BlendMode::kAlpha}};
  auto compositor = std::make_shared<stages::overlay::Compositor>(options);
  const std::size_t ring_capacity = 2;
  auto overlay = std::make_shared<OverlayBranch>("slow", 0, SlowOverlay(), compositor, ring_capacity);
  std::vector<std::unique_ptr<PacketStage>> stages;
  stages.push_back(std::make_unique<GeometryStage>(overlay));
  stages.push_back(std::make_unique<CompositeAdapter>(compositor));
  GraphOptions paced;  // at the video's clock, so the overlay's slowness shows against it
  paced.policy = Policy::kRealtime;
  StageGraph graph(std::make_unique<BlankSource>(), std::move(stages), paced, {overlay});
  REQUIRE(graph.Describe().find("simulate -> slow") != std::string::npos);

  AgeSink sink;
  const GraphRunResult result = graph.Run(sink);
  REQUIRE(result.complete);
  // Every frame was composed and reached the sink, in order (a frame the
  // clock dropped at capture would be a stall of the whole graph: there is
  // nothing slow in the chain, so on a machine not overloaded there is none).
  const auto composed = static_cast<std::int64_t>(sink.frames.size());
  REQUIRE(composed + result.frames_dropped == kFrames);
  REQUIRE(composed >= kFrames - 2);
  REQUIRE(std::is_sorted(sink.frames.begin(), sink.frames.end()));
  // The overlay drew a fraction of the geometries; the rest were dropped and counted.
  REQUIRE(overlay->published() == composed);
  REQUIRE(overlay->drawn() < composed / 2);
  REQUIRE(overlay->drawn() + static_cast<std::int64_t>(overlay->dropped()) == composed);
  // Frames went on while the overlay drew: they were composed with older and older layers.
  REQUIRE(*std::max_element(sink.ages.begin(), sink.ages.end()) >= 3);
  // Geometry held at once: the packets in flight, the ring's slots and the one being drawn.
  REQUIRE(most_live_geometries.load() <= GraphOptions{}.max_in_flight + static_cast<int>(ring_capacity) + 1);
  REQUIRE(live_geometries.load() == 0);  // all let go after the run
}

}  // namespace dg::pipeline
