// An overlay four times slower than the video, as a side branch: the frames
// and the geometry producer keep their pace (every frame is composed, with an
// ever older layer), what the overlay skips is counted, and the geometry held
// at once stays bounded by the ring. A stereo branch draws each eye through
// its own lens into its own composite, in the pooled packets' own images; a
// left-only one draws the left eye alone.
#include <algorithm>
#include <atomic>
#include <map>
#include <mutex>

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

// Stands in for the FEM stage: a new geometry per frame, handed to the overlay.
class GeometryStage final : public PacketStage {
 public:
  GeometryStage(std::shared_ptr<OverlayBranch> overlay, const Eigen::Isometry3d& T_C_S = Eigen::Isometry3d::Identity())
      : overlay_(std::move(overlay)) {
    auto registration = std::make_shared<io::Registration>();
    registration->T_C_S = T_C_S.matrix();
    registration_ = std::move(registration);
  }
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

// An overlay whose layers are grey, of the frame of the geometry drawn.
OverlayFactory GreyOverlay() {
  return [](const stages::overlay::LensView&, int) {
    return [](const Eigen::Matrix3Xd&, std::int64_t frame) {
      return stages::overlay::OverlayLayer{cv::Mat(kSize, CV_32FC4, cv::Scalar(0.5f, 0.5f, 0.5f, 0.5f)), frame};
    };
  };
}

}  // namespace

// The overlay four times slower than the video, as the graph interleaves it
// at worst: the FEM stage publishes every frame and the composite stage
// composes every frame, while the overlay drains its ring only after every
// fourth frame. Nothing in the chain waits for the overlay (Publish never
// blocks), so the interleaving is fixed and every count is exact: with a ring
// of 2, frames 4m and 4m+1 fill it, 4m+2 and 4m+3 are dropped at the push,
// and the drain after 4m+3 draws 4m+1, dropping 4m. Frame f is then composed
// with the layer of 4m+1 for the last drain at or before f.
TEST_CASE("overlay branch: a slow overlay holds back neither the frames nor the geometry", "[pipeline][unit]") {
  stages::overlay::CompositorOptions options;
  options.layers = {{"slow", stages::overlay::BlendMode::kAlpha}};
  const std::size_t ring_capacity = 2;
  const OverlayEyes eyes{StereoPair(), std::make_shared<LatestLayers>(1), nullptr};
  OverlayBranchOptions branch;
  branch.ring_capacity = ring_capacity;
  auto overlay = std::make_shared<OverlayBranch>("slow", 0, GreyOverlay(), eyes, branch);
  GeometryStage simulate(overlay);
  CompositeAdapter composite(std::make_shared<stages::overlay::Compositor>(options), eyes.left);
  live_geometries = 0;
  most_live_geometries = 0;
  BlankSource source;
  FramePacket packet;
  std::vector<std::int64_t> ages;
  for (std::int64_t f = 0; f < kFrames; ++f) {
    REQUIRE(source.Read(packet));
    simulate.Process(packet);
    if (f % 4 == 3) overlay->Drain();
    composite.Process(packet);
    ages.push_back(packet.layer_age_frames.at(0));
    packet.simulation.reset();  // the packet goes back to the pool
  }
  REQUIRE(overlay->published() == kFrames);
  REQUIRE(overlay->drawn() == kFrames / 4);
  REQUIRE(overlay->drawn() + static_cast<std::int64_t>(overlay->dropped()) == kFrames);
  for (std::int64_t f = 0; f < kFrames; ++f) {
    CAPTURE(f);
    REQUIRE(ages[f] == (f < 3 ? -1 : f - (4 * ((f - 3) / 4) + 1)));
  }
  REQUIRE(*std::max_element(ages.begin(), ages.end()) == 5);
  REQUIRE(eyes.left->held() == 1);
  // Geometry held at once: the packet's and the ring's (the one drawn is let
  // go before the next frame here; in the graph it adds one, as do the other
  // packets in flight).
  REQUIRE(most_live_geometries.load() == 1 + static_cast<int>(ring_capacity));
  REQUIRE(live_geometries.load() == 0);  // the last drain emptied the ring
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
  return [log](const stages::overlay::LensView& view, int layers_alive) {
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

// The branch, its geometry feeder and the composite stage, as BuildSceneGraph joins them.
EyeGraph MakeEyeGraph(bool stereo, const Eigen::Isometry3d& T_C_S) {
  stages::overlay::CompositorOptions options;
  options.layers = {{"eye", stages::overlay::BlendMode::kAlpha}};
  OverlayEyes eyes{StereoPair(), std::make_shared<LatestLayers>(1), nullptr};
  if (stereo) eyes.right = std::make_shared<LatestLayers>(1);
  EyeGraph built;
  auto overlay = std::make_shared<OverlayBranch>("eye", 0, EyeColouredOverlay(built.lenses), eyes);
  std::vector<std::unique_ptr<PacketStage>> stages;
  stages.push_back(std::make_unique<GeometryStage>(overlay, T_C_S));
  stages.push_back(
      std::make_unique<CompositeAdapter>(std::make_shared<stages::overlay::Compositor>(options), eyes.left, eyes.right));
  built.graph = std::make_unique<StageGraph>(std::make_unique<BlankSource>(), std::move(stages), GraphOptions{},
                                             std::vector<std::shared_ptr<SideBranch>>{overlay});
  return built;
}

}  // namespace

TEST_CASE("overlay branch: a stereo run draws each eye through its own lens, into the packets' own images",
          "[pipeline][integration]") {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, 2);
  const Eigen::Isometry3d T_C_S = Eigen::Translation3d(0.002, -0.001, 0.06) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX());
  const io::StereoCalibration stereo = StereoPair();

  SECTION("inline, frame by frame: each eye's composite shows its own eye's layer from the first frame on") {
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
    for (int j = 0; j < kFrames; ++j) {
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

// A pose the scene gives builds both eyes' drawings with the branch, before
// any frame, each holding as many layers as are ever alive at once: the one
// being drawn, the mailbox's, and one per frame composing.
TEST_CASE("overlay branch: a given pose builds the drawings up front, sized to the layers alive at once",
          "[pipeline][unit]") {
  const Eigen::Isometry3d T_C_S(Eigen::Translation3d(0, 0, 0.05));
  auto lenses = std::make_shared<LensLog>();
  const OverlayEyes eyes{StereoPair(), std::make_shared<LatestLayers>(1), std::make_shared<LatestLayers>(1)};
  OverlayBranchOptions options;
  options.composites_in_flight = 3;
  const OverlayBranch unposed("eye", 0, EyeColouredOverlay(lenses), eyes, options);
  REQUIRE(lenses->views.empty());  // built at the first draw, once a registration gives the pose
  options.T_C_S = T_C_S;
  const OverlayBranch posed("eye", 0, EyeColouredOverlay(lenses), eyes, options);
  REQUIRE(lenses->views.size() == 2);
  REQUIRE(lenses->views[0].T_C_S().isApprox(T_C_S, 1e-15));
  REQUIRE(lenses->layers_alive == std::vector<int>{5, 5});
  options.composites_in_flight = 0;
  REQUIRE_THROWS_WITH(OverlayBranch("eye", 0, EyeColouredOverlay(lenses), eyes, options),
                      Catch::Contains("composites in flight 0"));
}

}  // namespace dg::pipeline
