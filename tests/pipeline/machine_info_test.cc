// The CPU named in run logs and benchmark records: /proc/cpuinfo's model name
// with the CPUID family and model, read from the first processor's block, in
// the kernel's own layout (tab-padded keys, "model" beside "model name").
#include "pipeline/machine_info.h"

#include <sstream>

#include <catch2/catch.hpp>

namespace dg::pipeline {
namespace {

std::string CpuModelOf(const std::string& text) {
  std::istringstream cpuinfo(text);
  return CpuModel(cpuinfo);
}

TEST_CASE("machine info: a KVM guest's generic name gets its family and model", "[pipeline][unit]") {
  // The start of /proc/cpuinfo on the project's two-core EPYC guest; the second
  // block is altered so that reading past the first would show.
  const std::string cpuinfo =
      "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 17\n"
      "model name\t: AMD EPYC\nstepping\t: 1\ncpu MHz\t\t: 2596.132\n\n"
      "processor\t: 1\nvendor_id\t: AuthenticAMD\ncpu family\t: 26\nmodel\t\t: 2\n"
      "model name\t: Other\n\n";
  CHECK(CpuModelOf(cpuinfo) == "AMD EPYC (family 25, model 17)");
}

TEST_CASE("machine info: a full model name keeps its spaces", "[pipeline][unit]") {
  const std::string cpuinfo =
      "processor\t: 0\nvendor_id\t: GenuineIntel\ncpu family\t: 6\nmodel\t\t: 106\n"
      "model name\t: Intel(R) Xeon(R) Platinum 8375C CPU @ 2.90GHz\nstepping\t: 6\n";
  CHECK(CpuModelOf(cpuinfo) == "Intel(R) Xeon(R) Platinum 8375C CPU @ 2.90GHz (family 6, model 106)");
}

TEST_CASE("machine info: without a family and model, the name alone", "[pipeline][unit]") {
  CHECK(CpuModelOf("processor\t: 0\nmodel name\t: ARMv8 Processor rev 0 (v8l)\nBogoMIPS\t: 50.00\n") ==
        "ARMv8 Processor rev 0 (v8l)");
  CHECK(CpuModelOf("").empty());
}

}  // namespace
}  // namespace dg::pipeline
