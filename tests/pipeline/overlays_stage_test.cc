// The overlays in the frame's own path: every frame after the simulation
// starts is composed with layers drawn from that frame's geometry (age 0), in
// the graph on two threads as inline, with the stages that work on all cores
// admitting one frame at a time. A stereo run draws each eye through its own
// lens into its own composite, in the pooled packets' own images; a
// left-only one draws the left eye alone.
#include <algorithm>
#include <atomic>
#include <map>
#include <mutex>
#include <numeric>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>

#include "io/registration_file.h"
#include "pipeline/overlay_stages.h"
#include "pipeline/stage_graph.h"
#include "stages/fem_stage.h"
#include "tests/stages/overlay/overlay_fixtures.h"

namespace dg::pipeline {
namespace {

constexpr int kFrames = 40;
constexpr int kFirstSimulated = 5;  // the frames before it have no geometry, as before a registration
const cv::Size kSize(160, 120);

class BlankSource final : public PacketSource {
 public:
  const std::string& name() const override { return name_; }
  bool Read(FramePacket& packet) override {
    if (next_ == kFrames) return false;
    packet.index = next_++;
    packet.t_s = packet.index / fps();
    packet.raw.left.create(kSize, CV_8UC3);
    packet.raw.left.setTo(cv::Scalar(40, 60, 180));
    packet.raw.right.create(kSize, CV_8UC3);
    packet.raw.right.setTo(cv::Scalar(90, 30, 20));
    return true;
  }
  bool Skip() override { return next_ < kFrames && ++next_; }
  double fps() const override { return 30; }
  int frame_count() const override { return kFrames; }

 private:
  std::string name_ = "blank";
  int next_ = 0;
};

// Stands in for the FEM stage: from kFirstSimulated on, a geometry per frame
// whose one node's x is the frame index; it works on all cores as the FEM
// stage does, and counts the frames inside it and the overlays stage at once.
std::atomic<int> inside_span{0}, most_inside_span{0};

void Enter() {
  const int now = ++inside_span;
  int most = most_inside_span.load();
  while (now > most && !most_inside_span.compare_exchange_weak(most, now)) {
  }
}

class GeometryStage final : public PacketStage {
 public:
  explicit GeometryStage(const Eigen::Isometry3d& T_C_S = Eigen::Isometry3d::Identity()) {
    auto registration = std::make_shared<io::Registration>();
    registration->T_C_S = T_C_S.matrix();
    registration_ = std::move(registration);
  }
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  bool parallel_inside() const override { return true; }
  void Process(FramePacket& packet) override {
    Enter();
    if (packet.index >= kFirstSimulated) {
      auto output = std::make_shared<stages::FemFrameOutput>();
      output->nodes_S_m = Eigen::Matrix3Xd::Constant(3, 1, static_cast<double>(packet.index));
      packet.simulation = std::move(output);
      packet.registration = registration_;
    }
    --inside_span;
  }

 private:
  std::string name_ = "simulate";
  std::shared_ptr<const io::Registration> registration_;
};

// A 160 x 120 stereo pair: the right camera of another focal length, turned
// and 5 mm to the side.
io::StereoCalibration StereoPair() {
  io::StereoCalibration stereo;
  stereo.left = stages::overlay::testing::PinholeCalibration(kSize.width, kSize.height, 100);
  stereo.right = stages::overlay::testing::PinholeCalibration(kSize.width, kSize.height, 110);
  stereo.R = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  stereo.T_m = Eigen::Vector3d(-0.005, 0, 0);
  return stereo;
}

// An overlay whose layer's blue is the frame its geometry says (x of node
// 0) over 255, and which records the frame it was asked to draw.
OverlayFactory FrameCodedOverlay(std::shared_ptr<std::vector<std::int64_t>> asked) {
  return [asked](const stages::overlay::LensView&, int, const OverlayQuality&) {
    return [asked](const Eigen::Matrix3Xd& nodes_S, std::int64_t frame) {
      Enter();
      asked->push_back(frame);
      const float blue = static_cast<float>(nodes_S(0, 0) / 255.0);
      stages::overlay::OverlayLayer layer{cv::Mat(kSize, CV_32FC4, cv::Scalar(blue, 0, 0, 1)), frame};
      --inside_span;
      return layer;
    };
  };
}

OverlaysAdapter::Options LeftEyeAt(const Eigen::Isometry3d& T_C_S) {
  OverlaysAdapter::Options options;
  options.calibration = StereoPair();
  options.T_C_S = T_C_S;
  return options;
}

// Per frame: the composite's blue at one pixel and the layer's age.
class CodeSink final : public GraphSink {
 public:
  void Consume(const FramePacket& packet) override {
    frames.push_back(packet.index);
    blue.push_back(packet.composite.at<cv::Vec3b>(60, 80)[0]);
    ages.push_back(packet.layer_age_frames.at(0));
  }
  void RecordTimings(std::span<const StageTiming>) override {}
  void RecordDrop(std::int64_t, std::int64_t) override {}
  std::vector<std::int64_t> frames, ages;
  std::vector<int> blue;
};

}  // namespace

TEST_CASE("overlays stage: every simulated frame is composed with layers drawn from its own geometry",
          "[pipeline][integration]") {
  const int threads = GENERATE(1, 2);
  CAPTURE(threads);
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  stages::overlay::CompositorOptions compositor;
  compositor.layers = {{"coded", stages::overlay::BlendMode::kAlpha}};
  auto asked = std::make_shared<std::vector<std::int64_t>>();
  std::vector<std::unique_ptr<PacketStage>> stages;
  stages.push_back(std::make_unique<GeometryStage>());
  stages.push_back(std::make_unique<OverlaysAdapter>(LeftEyeAt(Eigen::Isometry3d::Identity()),
                                                     std::vector<std::string>{"coded"},
                                                     std::vector<OverlayFactory>{FrameCodedOverlay(asked)}));
  stages.push_back(
      std::make_unique<CompositeAdapter>(std::make_shared<stages::overlay::Compositor>(compositor), false));
  GraphOptions options;
  options.max_in_flight = 3;
  StageGraph graph(std::make_unique<BlankSource>(), std::move(stages), options);
  inside_span = 0;
  most_inside_span = 0;
  CodeSink sink;
  REQUIRE(graph.Run(sink).complete);
  REQUIRE(sink.frames.size() == static_cast<size_t>(kFrames));
  // One draw per simulated frame, for that frame, in order.
  std::vector<std::int64_t> simulated(kFrames - kFirstSimulated);
  std::iota(simulated.begin(), simulated.end(), kFirstSimulated);
  REQUIRE(*asked == simulated);
  for (int f = 0; f < kFrames; ++f) {
    CAPTURE(f);
    // The video's blue is 40; the opaque layer's is the frame's own index.
    REQUIRE(sink.ages[f] == (f < kFirstSimulated ? -1 : 0));
    REQUIRE(sink.blue[f] == (f < kFirstSimulated ? 40 : f));
  }
  // Three packets in flight, yet never two frames in the stages that work on all cores.
  REQUIRE(most_inside_span.load() == 1);
}

TEST_CASE("overlays stage: a run of stages that work on all cores begins with a stateful one", "[pipeline][unit]") {
  class Stateless final : public PacketStage {
   public:
    const std::string& name() const override { return name_; }
    bool stateful() const override { return false; }
    bool parallel_inside() const override { return true; }
    void Process(FramePacket&) override {}

   private:
    std::string name_ = "tiles";
  };
  std::vector<std::unique_ptr<PacketStage>> stages;
  stages.push_back(std::make_unique<Stateless>());
  REQUIRE_THROWS_WITH(StageGraph(std::make_unique<BlankSource>(), std::move(stages), GraphOptions{}),
                      Catch::Contains("stage 'tiles' begins a run of stages that work on all cores but is stateless"));
}

namespace {

// Every lens an overlay was built with; each drawing an opaque layer in its
// camera's colour: blue through the left camera (f = 100), red through the right.
struct LensLog {
  std::mutex mutex;
  std::vector<stages::overlay::LensView> views;
  std::vector<int> layers_alive;
};

OverlayFactory EyeColouredOverlay(std::shared_ptr<LensLog> log) {
  return [log](const stages::overlay::LensView& view, int layers_alive, const OverlayQuality&) {
    {
      std::lock_guard lock(log->mutex);
      log->views.push_back(view);
      log->layers_alive.push_back(layers_alive);
    }
    const cv::Scalar bgra = view.camera().fx() == 100 ? cv::Scalar(1, 0, 0, 1) : cv::Scalar(0, 0, 1, 1);
    return [bgra](const Eigen::Matrix3Xd&, std::int64_t frame) {
      return stages::overlay::OverlayLayer{cv::Mat(kSize, CV_32FC4, bgra), frame};
    };
  };
}

// Per packet (the pool's objects, by address): the composites' buffers, which must never change.
class BufferSink final : public GraphSink {
 public:
  using Buffers = std::pair<const std::uint8_t*, const std::uint8_t*>;  // left, right composite
  void Consume(const FramePacket& packet) override {
    ++frames;
    const Buffers now(packet.composite.data, packet.composite_right.data);
    const auto [at, first] = buffers.try_emplace(&packet, now);
    moved += !first && at->second != now;
    if (!packet.composite_right.empty()) {
      left_pixels.push_back(packet.composite.at<cv::Vec3b>(60, 80));
      right_pixels.push_back(packet.composite_right.at<cv::Vec3b>(60, 80));
    }
  }
  void RecordTimings(std::span<const StageTiming>) override {}
  void RecordDrop(std::int64_t, std::int64_t) override {}
  int frames = 0, moved = 0;
  std::map<const FramePacket*, Buffers> buffers;
  std::vector<cv::Vec3b> left_pixels, right_pixels;
};

struct EyeGraph {
  std::unique_ptr<StageGraph> graph;
  std::shared_ptr<LensLog> lenses = std::make_shared<LensLog>();
};

// The geometry feeder, the overlays stage and the composite stage, as BuildSceneGraph joins them.
EyeGraph MakeEyeGraph(bool stereo, const Eigen::Isometry3d& T_C_S) {
  stages::overlay::CompositorOptions compositor;
  compositor.layers = {{"eye", stages::overlay::BlendMode::kAlpha}};
  EyeGraph built;
  OverlaysAdapter::Options drawing;
  drawing.calibration = StereoPair();
  drawing.right_eye = stereo;
  std::vector<std::unique_ptr<PacketStage>> stages;
  stages.push_back(std::make_unique<GeometryStage>(T_C_S));
  stages.push_back(std::make_unique<OverlaysAdapter>(drawing, std::vector<std::string>{"eye"},
                                                     std::vector<OverlayFactory>{EyeColouredOverlay(built.lenses)}));
  stages.push_back(
      std::make_unique<CompositeAdapter>(std::make_shared<stages::overlay::Compositor>(compositor), stereo));
  built.graph = std::make_unique<StageGraph>(std::make_unique<BlankSource>(), std::move(stages), GraphOptions{});
  return built;
}

}  // namespace

TEST_CASE("overlays stage: a stereo run draws each eye through its own lens, into the packets' own images",
          "[pipeline][integration]") {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, 2);
  const Eigen::Isometry3d T_C_S = Eigen::Translation3d(0.002, -0.001, 0.06) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX());
  const io::StereoCalibration stereo = StereoPair();

  SECTION("inline, frame by frame: each eye's composite shows its own eye's layer once there is geometry") {
    EyeGraph stereo_graph = MakeEyeGraph(true, T_C_S);
    BufferSink sink;
    REQUIRE(stereo_graph.graph->RunInline(sink).complete);
    REQUIRE(sink.frames == kFrames);
    REQUIRE(sink.moved == 0);  // the one packet's images, reused every frame
    // Built once per eye: the left camera at T_C_S, the right camera at T_R_S = [R | T] T_C_S.
    const std::vector<stages::overlay::LensView>& views = stereo_graph.lenses->views;
    REQUIRE(views.size() == 2);
    REQUIRE(views[0].camera().fx() == 100);
    REQUIRE(views[0].T_C_S().isApprox(T_C_S, 1e-15));
    REQUIRE(views[1].camera().fx() == 110);
    const Eigen::Vector3d X_S(0.01, 0.02, -0.03);
    const Eigen::Vector3d X_R = stereo.R * (T_C_S * X_S) + stereo.T_m;
    REQUIRE((views[1].T_C_S() * X_S - X_R).norm() < 1e-15);
    REQUIRE(sink.right_pixels.size() == static_cast<size_t>(kFrames));
    for (int j = kFirstSimulated; j < kFrames; ++j) {
      REQUIRE(sink.left_pixels[j] == cv::Vec3b(255, 0, 0));
      REQUIRE(sink.right_pixels[j] == cv::Vec3b(0, 0, 255));
    }
  }
  SECTION("in the graph: every pooled packet keeps its composites' buffers") {
    EyeGraph stereo_graph = MakeEyeGraph(true, T_C_S);
    BufferSink sink;
    REQUIRE(stereo_graph.graph->Run(sink).complete);
    REQUIRE(sink.frames == kFrames);
    REQUIRE(sink.buffers.size() < static_cast<size_t>(kFrames));  // packets were reused
    REQUIRE(sink.moved == 0);
    for (const auto& [packet, buffers] : sink.buffers) REQUIRE(buffers.second != nullptr);
  }
  SECTION("left only: the right eye is neither drawn nor composed") {
    EyeGraph left_graph = MakeEyeGraph(false, T_C_S);
    BufferSink sink;
    REQUIRE(left_graph.graph->RunInline(sink).complete);
    REQUIRE(left_graph.lenses->views.size() == 1);
    REQUIRE(left_graph.lenses->views[0].camera().fx() == 100);
    REQUIRE(sink.right_pixels.empty());
    for (const auto& [packet, buffers] : sink.buffers) REQUIRE(buffers.second == nullptr);
  }
}

// A pose the scene gives builds both eyes' drawings with the stage, before
// any frame, each holding as many layers as packets are in flight.
TEST_CASE("overlays stage: a given pose builds the drawings up front, sized to the layers alive at once",
          "[pipeline][unit]") {
  const Eigen::Isometry3d T_C_S(Eigen::Translation3d(0, 0, 0.05));
  auto lenses = std::make_shared<LensLog>();
  OverlaysAdapter::Options options;
  options.calibration = StereoPair();
  options.right_eye = true;
  options.layers_alive = 3;
  const OverlaysAdapter unposed(options, {"eye"}, {EyeColouredOverlay(lenses)});
  REQUIRE(lenses->views.empty());  // built at the first registered frame, once it gives the pose
  options.T_C_S = T_C_S;
  const OverlaysAdapter posed(options, {"eye"}, {EyeColouredOverlay(lenses)});
  REQUIRE(lenses->views.size() == 2);
  REQUIRE(lenses->views[0].T_C_S().isApprox(T_C_S, 1e-15));
  REQUIRE(lenses->layers_alive == std::vector<int>{3, 3});
  options.layers_alive = 0;
  REQUIRE_THROWS_WITH(OverlaysAdapter(options, {"eye"}, {EyeColouredOverlay(lenses)}),
                      Catch::Contains("layers alive 0"));
  REQUIRE_THROWS_WITH(OverlaysAdapter(LeftEyeAt(T_C_S), {"eye", "two"}, {EyeColouredOverlay(lenses)}),
                      Catch::Contains("2 overlay names for 1 drawings"));
}

}  // namespace dg::pipeline

namespace dg::pipeline {

// Realtime, a drawing over its share of the frame period coarsens the CT
// volume step by step, and one within it keeps the quality: shares of 1 ns
// and of an hour make the outcome independent of the machine's pace.
TEST_CASE("overlays stage: realtime fits the volume's quality to the drawings' share", "[pipeline][unit]") {
  const auto run = [](double budget_ms) {
    auto qualities = std::make_shared<std::vector<int>>();  // the divisor of every drawing built
    OverlayFactory factory = [qualities](const stages::overlay::LensView&, int, const OverlayQuality& quality) {
      qualities->push_back(quality.volume_resolution_divisor);
      return [](const Eigen::Matrix3Xd&, std::int64_t frame) {
        return stages::overlay::OverlayLayer{cv::Mat(kSize, CV_32FC4, cv::Scalar::all(0)), frame};
      };
    };
    OverlaysAdapter::Options options = LeftEyeAt(Eigen::Isometry3d::Identity());
    options.draw_budget_ms = budget_ms;
    OverlaysAdapter stage(options, {"volume"}, {factory});
    GeometryStage simulate;
    BlankSource source;
    FramePacket packet;
    while (source.Read(packet)) {
      simulate.Process(packet);
      stage.Process(packet);
    }
    return std::pair(*qualities, stage.quality());
  };
  const auto [within, kept] = run(3.6e6);
  CHECK(within == std::vector<int>{2});
  CHECK(kept.volume_resolution_divisor == 2);
  const auto [over, coarsest] = run(1e-6);
  // 2 -> 4 -> 8 (spacing 2 -> 3 -> 4.5 mm), three frames apart after the first, then no coarser.
  CHECK(over == std::vector<int>{2, 4, 8});
  CHECK(coarsest.volume_resolution_divisor == 8);
  CHECK(coarsest.volume_slice_spacing_m == Approx(4.5e-3));
}

}  // namespace dg::pipeline
