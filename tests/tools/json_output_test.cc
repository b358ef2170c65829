// The JSON files the commands write are valid JSON whatever the figures and
// names: a NaN or infinite figure is written as null (docs/benchmarks.md), a
// name that is not UTF-8 is still written, and the records carry the build's
// commit and the date.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <thread>

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include "tests/support/temporary_folder.h"
#include "tools/bench/overlay_bench.h"
#include "tools/eval/runtime_report.h"
#include "tools/eval/runtime_sweep.h"

namespace dg::tools {
namespace {

using Json = nlohmann::ordered_json;

Json ReadJson(const std::string& path) {
  std::ifstream file(path);
  REQUIRE(file);
  return Json::parse(file);  // throws on anything that is not JSON, a bare NaN included
}

TEST_CASE("bench JSON: NaN and infinite figures are null, names stay, provenance is there", "[tools][unit]") {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  OverlayBenchRecord timed;
  timed.overlay = "mesh";
  timed.threads = 2;
  timed.frames = 30;
  timed.ms_median = 3.14159;
  timed.ms_p95 = kNaN;
  timed.fps = std::numeric_limits<double>::infinity();
  OverlayBenchRecord odd = timed;
  odd.overlay = "bad \xff byte \"quoted\"";
  const dg::testing::TemporaryFolder folder("dg_json_output_bench");
  const std::string path = folder.File("bench.json");
  WriteOverlayBenchJson(path, {timed, odd});

  const Json records = ReadJson(path);
  REQUIRE(records.is_array());
  REQUIRE(records.size() == 2);
  const Json& r = records[0];
  CHECK(r.begin().key() == "overlay");  // the record's own fields first, in their order
  CHECK(r["overlay"] == "mesh");
  CHECK(r["threads"] == 2);
  CHECK(r["ms_median"].get<double>() == 3.142);  // 4 significant digits
  CHECK(r["ms_p95"].is_null());
  CHECK(r["fps"].is_null());
  CHECK(r["commit"].is_string());
  CHECK(r["date"].get<std::string>().size() == 20);  // 2026-12-03T07:00:00Z
  CHECK(r["load_average_before"].size() == 3);
  CHECK(r["load_average_after"].size() == 3);
  CHECK(r["host_fma_fp32_gflops"].size() == r["host_triad_gb_s"].size());
  CHECK(r["host_fma_fp32_gflops"][0].get<double>() > 0);
  CHECK(r["host_core_load_store_gb_s"].size() == std::max(1u, std::thread::hardware_concurrency()));
  CHECK(records[1]["overlay"] == "bad \xEF\xBF\xBD byte \"quoted\"");  // the byte replaced by U+FFFD

  // Python's reader, as tools/benchmark_table.py reads the records: null is None.
  const std::string check = "/usr/bin/python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); "
                            "sys.exit(0 if r[0][\"ms_p95\"] is None and r[0][\"commit\"] else 1)' " + path;
  CHECK(std::system(check.c_str()) == 0);
}

TEST_CASE("eval runtime JSON: a NaN error is null; the file names its commit and date", "[tools][unit]") {
  RuntimeResult result;
  result.scene_name = "phantom";
  result.window_frames = 60;
  PointResult point;
  point.ran = true;
  point.errors.internal_rms_mm = std::nan("");
  point.errors.surface_rms_mm = 0.125;
  result.points = {point};
  const dg::testing::TemporaryFolder folder("dg_json_output_runtime");
  const std::string path = folder.File("runtime.json");
  WriteRuntimeJson(result, path);

  const Json json = ReadJson(path);
  CHECK(json["scene"] == "phantom");
  CHECK(json["window_frames"] == 60);
  CHECK(json["commit"].is_string());
  CHECK(json["date"].get<std::string>().size() == 20);
  REQUIRE(json["points"].size() == 1);
  CHECK(json["points"][0]["internal_rms_mm"].is_null());
  CHECK(json["points"][0]["surface_rms_mm"].get<double>() == 0.125);
  CHECK(json["points"][0]["status"] == "ran");
  CHECK(json["points"][0]["recommended"] == false);
}

}  // namespace
}  // namespace dg::tools
