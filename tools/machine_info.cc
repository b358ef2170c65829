#include "tools/machine_info.h"

#include <cstdlib>
#include <ctime>
#include <fstream>
#include <thread>

#include "build_commit.h"

namespace dg::tools {
namespace {

struct LoadAverage {
  double value[3] = {0, 0, 0};
  LoadAverage() { getloadavg(value, 3); }
};

// Taken when the process starts, before any benchmark loads the machine.
const LoadAverage kLoadAtStart;

}  // namespace

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

RunProvenance ReadRunProvenance() {
  RunProvenance provenance;
  provenance.commit = DG_BUILD_COMMIT;
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  provenance.date = date;
  const LoadAverage load_now;
  for (int i = 0; i < 3; ++i) {
    provenance.load_at_start[i] = kLoadAtStart.value[i];
    provenance.load_now[i] = load_now.value[i];
  }
  return provenance;
}

}  // namespace dg::tools
