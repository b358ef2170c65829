#include "tools/bench/bench_json.h"

#include <cstdio>
#include <fstream>

#include <nlohmann/json.hpp>

#include "pipeline/machine_info.h"
#include "sim/error.h"
#include "tools/bench/machine_peaks.h"
#include "tools/json_text.h"
#include "tools/provenance.h"

namespace dg::tools {

void PrintMachine() {
  const pipeline::MachineInfo machine = pipeline::ReadMachineInfo();
  std::printf("machine: %s, %d logical cores, %s, %s\n", machine.cpu_model.c_str(), machine.logical_cores,
              machine.simd.c_str(), machine.compiler.c_str());
}

void WriteBenchJson(const std::string& path, const std::vector<std::string>& records) {
  using Json = nlohmann::ordered_json;
  const pipeline::MachineInfo machine = pipeline::ReadMachineInfo();
  const RunProvenance run = ReadRunProvenance();  // the load before the probe's own
  MachinePeaks peaks = MeasureMachinePeaks();
  peaks.fma_fp32_gflops = SignificantEach(peaks.fma_fp32_gflops, 4);
  peaks.triad_gb_s = SignificantEach(peaks.triad_gb_s, 3);
  peaks.core_load_store_gb_s = SignificantEach(peaks.core_load_store_gb_s, 3);
  std::printf("host peaks now: FMA fp32");
  for (const double gflops : peaks.fma_fp32_gflops) std::printf(" %.1f", gflops);
  std::printf(" GFLOP/s, triad");
  for (const double gb_s : peaks.triad_gb_s) std::printf(" %.1f", gb_s);
  std::printf(" GB/s on 1..%zu threads; L1 load/store", peaks.triad_gb_s.size());
  for (const double gb_s : peaks.core_load_store_gb_s) std::printf(" %.0f", gb_s);
  std::printf(" GB/s on each core alone\n");
  // Opened after the probe's second, so that an interruption leaves the old file whole.
  std::ofstream out(path);
  if (!out) throw Error("cannot write benchmark results", path, "check the directory exists and is writable");
  Json array = Json::array();
  for (const std::string& text : records) {
    Json record = Json::parse(text);
    record["cpu"] = machine.cpu_model;
    record["logical_cores"] = machine.logical_cores;
    record["simd"] = machine.simd;
    record["compiler"] = machine.compiler;
    record["commit"] = run.commit;
    record["date"] = run.date;
    record["load_average_before"] = LoadAverageJson<Json>(run.load_at_start);
    record["load_average_after"] = LoadAverageJson<Json>(run.load_now);
    record["host_fma_fp32_gflops"] = peaks.fma_fp32_gflops;
    record["host_triad_gb_s"] = peaks.triad_gb_s;
    record["host_core_load_store_gb_s"] = peaks.core_load_store_gb_s;
    array.push_back(std::move(record));
  }
  out << JsonText(array);
  if (!out) throw Error("writing benchmark results failed", path, "check the disk has space");
}

}  // namespace dg::tools
