#include "pipeline/machine_info.h"

#include <fstream>
#include <thread>

namespace dg::pipeline {

MachineInfo ReadMachineInfo() {
  MachineInfo info;
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("model name", 0) == 0) {
      info.cpu_model = line.substr(line.find(':') + 2);
      break;
    }
  }
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
