// `dynaguide bench vision` end to end on a short phantom: the record is the
// median of its repeats and says their spread, and the saved JSON holds the
// same figures. No time is asserted, only how the runs are summarised.
#include <fstream>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "tests/support/temporary_folder.h"
#include "tools/bench/vision_bench.h"

namespace dg::tools {
namespace {

TEST_CASE("bench vision: the record is the median of its repeats, with their spread, and is saved as run",
          "[tools][integration]") {
  VisionBenchOptions options;
  options.threads = {1};
  options.codecs = {"raw"};
  options.repeats = 3;
  options.duration_s = 0.5;  // the default preset records at 30 frames/s: 15 frames
  const std::vector<VisionBenchRecord> records = RunVisionBench(options, false);
  REQUIRE(records.size() == 1);
  const VisionBenchRecord& r = records.front();
  CHECK(r.codec == "raw");
  CHECK(r.threads == 1);
  CHECK(r.frames == 15);
  CHECK(r.repeats == 3);
  CHECK(r.features > 0);
  CHECK(r.fps_min <= r.fps);
  CHECK(r.fps <= r.fps_max);
  CHECK(r.fps_min > 0);
  CHECK(r.interval_ms_median > 0);

  const testing::TemporaryFolder folder("dg_vision_bench_test");
  const std::string path = folder.File("vision.json");
  WriteVisionBenchJson(path, records);
  std::ifstream file(path);
  REQUIRE(file);
  const nlohmann::json saved = nlohmann::json::parse(file);
  REQUIRE(saved.size() == 1);
  CHECK(saved[0]["repeats"] == 3);
  CHECK(saved[0]["frames"] == 15);
  // Four significant digits, as every record is written.
  CHECK(saved[0]["fps"].get<double>() == Approx(r.fps).epsilon(1e-3));
  CHECK(saved[0]["fps_min"].get<double>() == Approx(r.fps_min).epsilon(1e-3));
  CHECK(saved[0]["fps_max"].get<double>() == Approx(r.fps_max).epsilon(1e-3));
  CHECK(saved[0]["interval_ms_median"].get<double>() == Approx(r.interval_ms_median).epsilon(1e-3));
  CHECK(saved[0].contains("commit"));
  CHECK(saved[0].contains("date"));
}

}  // namespace
}  // namespace dg::tools
