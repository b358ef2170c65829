#pragma once

#include <string>

namespace dg::tools {

// What a benchmark ran on, for its saved figures.
struct MachineInfo {
  std::string cpu_model;  // /proc/cpuinfo "model name"
  int logical_cores = 0;
  std::string compiler;   // compiler and version this binary was built with
  std::string simd;       // widest vector extension compiled in
};

MachineInfo ReadMachineInfo();

// When and from what a benchmark's figures came.
struct RunProvenance {
  std::string commit;                  // `git describe --always --dirty` of the source built
  std::string date;                    // now, UTC, ISO 8601
  double load_at_start[3] = {0, 0, 0};  // 1, 5, 15 minute load averages when the process started
  double load_now[3] = {0, 0, 0};      // and now
};

RunProvenance ReadRunProvenance();

}  // namespace dg::tools
