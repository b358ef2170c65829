// The whole scene graph (capture, rectify, track, constraints, FEM, overlays,
// composite) on a two-second tiny phantom, counting every allocation: image
// memory through a counting cv::MatAllocator, everything else through this
// executable's own global operator new. Once the first frames have sized
// every pooled buffer, a frame allocates no frame-sized image (buffers come
// from pools).
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <new>

#include <catch2/catch.hpp>
#include <tbb/global_control.h>
#include <yaml-cpp/yaml.h>

#include "io/h5_file.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/scene_graph.h"
#include "tests/support/counting_mat_allocator.h"
#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"

namespace {

std::atomic<long long> heap_allocations{0};

void* CountedAllocation(std::size_t bytes, std::size_t alignment) {
  heap_allocations.fetch_add(1, std::memory_order_relaxed);
  void* p = alignment > alignof(std::max_align_t)
                ? std::aligned_alloc(alignment, (bytes + alignment - 1) / alignment * alignment)
                : std::malloc(bytes ? bytes : 1);
  if (!p) throw std::bad_alloc();
  return p;
}

}  // namespace

void* operator new(std::size_t bytes) { return CountedAllocation(bytes, 0); }
void* operator new[](std::size_t bytes) { return CountedAllocation(bytes, 0); }
void* operator new(std::size_t bytes, std::align_val_t a) { return CountedAllocation(bytes, std::size_t(a)); }
void* operator new[](std::size_t bytes, std::align_val_t a) { return CountedAllocation(bytes, std::size_t(a)); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace dg::pipeline {
namespace {

namespace fs = std::filesystem;
using testing::CountingMatAllocator;

// The counters as each frame reaches the sink, in frame order.
class CountingSink final : public GraphSink {
 public:
  explicit CountingSink(const CountingMatAllocator& mats) : mats_(mats) {}
  void Consume(const FramePacket& packet) override {
    frame_images.push_back(mats_.frame_images.load());
    scratch_images.push_back(mats_.scratch_images.load());
    heap.push_back(heap_allocations.load());
    simulated.push_back(packet.simulation != nullptr);
    composed.push_back(!packet.composite.empty());
    detected.push_back(packet.tracks.detected);
  }
  void RecordTimings(std::span<const StageTiming>) override {}
  void RecordDrop(std::int64_t, std::int64_t) override {}

  std::vector<long long> frame_images, scratch_images, heap;
  std::vector<bool> simulated, composed;
  std::vector<int> detected;

 private:
  const CountingMatAllocator& mats_;
};

// A tiny phantom two seconds long, generated into `dir`, with the truth's
// registration, so the simulation and the overlays run from the first frame.
std::string SceneRegisteredByTruth(const fs::path& dir) {
  tools::phantom::PhantomSpec spec = tools::phantom::PresetSpec("tiny");
  spec.duration_s = 2;
  tools::phantom::GeneratePhantom(spec, dir.string(), false);
  const io::Scene scene = io::ReadScene((dir / "scene.yaml").string());
  const io::H5Reader truth(scene.truth);
  io::Registration registration;
  registration.T_C_S = truth.ReadMatrix("/T_C_S");
  registration.phase_shift_s = truth.ReadScalar("/phase_shift_s");
  registration.period_s = truth.ReadScalar("/period_s");
  io::WriteRegistrationYaml((dir / "registration.yaml").string(), registration);
  YAML::Node root = YAML::Load(scene.text);
  root.remove("registration");
  root["registration"]["file"] = "registration.yaml";
  const fs::path path = dir / "registered.yaml";
  std::ofstream(path) << YAML::Dump(root) << "\n";
  return path.string();
}

struct WindowCounts {
  size_t frames = 0;
  double frame_images = 0, scratch_images = 0, heap = 0;  // per frame
  int detections = 0;                                     // frames that ran the detector
};

// Frames from `from` to the last, per frame.
WindowCounts CountWindow(const CountingSink& sink, size_t from) {
  WindowCounts counts;
  const size_t last = sink.frame_images.size() - 1;
  counts.frames = last - from;
  counts.frame_images = double(sink.frame_images[last] - sink.frame_images[from]) / counts.frames;
  counts.scratch_images = double(sink.scratch_images[last] - sink.scratch_images[from]) / counts.frames;
  counts.heap = double(sink.heap[last] - sink.heap[from]) / counts.frames;
  for (size_t j = from + 1; j <= last; ++j) counts.detections += sink.detected[j] > 0;
  return counts;
}

TEST_CASE("steady state: a frame allocates no frame-sized image in the whole graph", "[integration]") {
  const testing::TemporaryFolder folder("dg_allocation_phantom");
  const io::Scene scene = io::ReadScene(SceneRegisteredByTruth(folder.path()));
  FrontEndSettings front_end;
  // The default target scaled to the tiny image's area (160x120 against
  // 640x480): a target the image cannot hold would detect in every frame,
  // and OpenCV's corner detector allocates its response images.
  front_end.target_features = 500 * (160 * 120) / (640 * 480);
  CountingMatAllocator mats;
  cv::Mat::setDefaultAllocator(&mats);
  for (const bool inline_run : {true, false}) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, inline_run ? 1 : 2);
    SceneGraph built = BuildSceneGraph(scene, GraphOptions{}, front_end);
    mats.frame_pixels = static_cast<long long>(built.calibration.left.width) * built.calibration.left.height;
    CountingSink sink(mats);
    if (inline_run) {
      built.graph->RunInline(sink);
    } else {
      built.graph->Run(sink);
    }
    REQUIRE(sink.frame_images.size() == 60);
    CHECK(sink.simulated.front());  // the simulation and the overlays ran in every frame counted
    CHECK(sink.composed.front());
    // Frames 0-19 size the pools (packets in flight, the overlays' layers)
    // and the stages' own buffers.
    const WindowCounts counts = CountWindow(sink, 20);
    std::printf("%s run, steady state over %zu frames, per frame: %.2f frame-sized images, %.2f smaller images "
                "(kernels' scratch), %.1f other heap allocations; %d frames detected features\n",
                inline_run ? "inline" : "graph (2 threads)", counts.frames, counts.frame_images,
                counts.scratch_images, counts.heap, counts.detections);
    CHECK(counts.detections == 0);
    // The overlays are built with the graph (the scene gives the pose), each
    // with as many layers as are ever alive at once, so neither run's timing
    // can make a pool grow.
    CHECK(counts.frame_images == 0);
  }
  cv::Mat::setDefaultAllocator(nullptr);
}

}  // namespace
}  // namespace dg::pipeline
