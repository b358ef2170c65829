#include "tools/machine_info.h"

#include <fstream>
#include <thread>

namespace dg::tools {

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
  info.compiler = "gcc " __VERSION__;
#if defined(__AVX512F__)
  info.simd = "AVX-512";
#elif defined(__AVX2__)
  info.simd = "AVX2";
#else
  info.simd = "SSE2";
#endif
  return info;
}

}  // namespace dg::tools
