#pragma once

#include <string>

namespace dg::pipeline {

// What a run or a benchmark ran on, for its log and its saved figures.
struct MachineInfo {
  std::string cpu_model;  // /proc/cpuinfo "model name"
  int logical_cores = 0;
  std::string compiler;   // compiler and version this binary was built with
  std::string simd;       // widest vector extension compiled in
};

MachineInfo ReadMachineInfo();

// One line for a run log: the machine, the threads used of its cores, the build.
std::string DescribeMachine(int threads_used);

}  // namespace dg::pipeline
