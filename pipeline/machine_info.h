#pragma once

#include <istream>
#include <string>

namespace dg::pipeline {

// What a run or a benchmark ran on, for its log and its saved figures.
struct MachineInfo {
  std::string cpu_model;  // CpuModel of /proc/cpuinfo
  int logical_cores = 0;
  std::string compiler;   // compiler and version this binary was built with
  std::string simd;       // widest vector extension compiled in
};

// The first processor's "model name" from /proc/cpuinfo, with its CPUID family
// and model, e.g. "AMD EPYC (family 25, model 17)": a hypervisor often shows
// only a generic name, and benchmark records from hosts of different CPU
// generations must still tell apart. The name alone where the two are absent.
std::string CpuModel(std::istream& cpuinfo);

MachineInfo ReadMachineInfo();

// One line for a run log: the machine, the threads used of its cores, the build.
std::string DescribeMachine(int threads_used);

}  // namespace dg::pipeline
