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

}  // namespace dg::tools
