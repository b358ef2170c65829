#include "pipeline/machine_info.h"

#include <fstream>
#include <string_view>
#include <thread>

namespace dg::pipeline {

namespace {

// Sets *value from a "key<TAB>: value" line of /proc/cpuinfo whose key is
// exactly `key` ("model" must not take the "model name" line).
void ReadField(const std::string& line, const std::string& key, std::string* value) {
  const std::size_t colon = line.find(':');
  if (colon == std::string::npos || colon == 0) return;
  const std::size_t key_end = line.find_last_not_of(" \t", colon - 1);
  if (key_end == std::string::npos || std::string_view(line).substr(0, key_end + 1) != key) return;
  const std::size_t start = line.find_first_not_of(' ', colon + 1);
  *value = start == std::string::npos ? std::string() : line.substr(start);
}

}  // namespace

std::string CpuModel(std::istream& cpuinfo) {
  std::string name, family, model;
  // The first processor's block ends at the first blank line.
  for (std::string line; std::getline(cpuinfo, line) && !line.empty();) {
    ReadField(line, "model name", &name);
    ReadField(line, "cpu family", &family);
    ReadField(line, "model", &model);
  }
  if (family.empty() || model.empty()) return name;
  return name + " (family " + family + ", model " + model + ")";
}

MachineInfo ReadMachineInfo() {
  MachineInfo info;
  std::ifstream cpuinfo("/proc/cpuinfo");
  info.cpu_model = CpuModel(cpuinfo);
  info.logical_cores = static_cast<int>(std::thread::hardware_concurrency());
#if defined(__clang__)
  info.compiler = __VERSION__;  // e.g. "Debian Clang 14.0.6"
#else
  info.compiler = "gcc " __VERSION__;
#endif
#if defined(__AVX512F__)
  info.simd = "AVX-512";
#elif defined(__AVX2__)
  info.simd = "AVX2";
#else
  info.simd = "SSE2";
#endif
  return info;
}

std::string DescribeMachine(int threads_used) {
  const MachineInfo machine = ReadMachineInfo();
  return machine.cpu_model + ", " + std::to_string(machine.logical_cores) + " logical cores (" +
         std::to_string(threads_used) + " used), " + machine.simd + ", " + machine.compiler;
}

}  // namespace dg::pipeline
