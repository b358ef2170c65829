#include "tools/bench/bench_json.h"

#include <cstdio>
#include <fstream>

#include <nlohmann/json.hpp>

#include "pipeline/machine_info.h"
#include "sim/error.h"
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
  std::ofstream out(path);
  if (!out) throw Error("cannot write benchmark results", path, "check the directory exists and is writable");
  const pipeline::MachineInfo machine = pipeline::ReadMachineInfo();
  const RunProvenance run = ReadRunProvenance();
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
    array.push_back(std::move(record));
  }
  out << JsonText(array);
  if (!out) throw Error("writing benchmark results failed", path, "check the disk has space");
}

}  // namespace dg::tools
