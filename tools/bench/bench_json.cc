#include "tools/bench/bench_json.h"

#include <fstream>

#include "pipeline/machine_info.h"
#include "sim/error.h"
#include "tools/json_text.h"
#include "tools/provenance.h"

namespace dg::tools {

void WriteBenchJson(const std::string& path, const std::vector<std::string>& record_fields) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write benchmark results", path, "check the directory exists and is writable");
  const pipeline::MachineInfo machine = pipeline::ReadMachineInfo();
  const RunProvenance run = ReadRunProvenance();
  const std::string machine_fields =
      Printed("\"cpu\": %s, \"logical_cores\": %d, \"simd\": %s, \"compiler\": %s, \"commit\": %s, \"date\": %s, "
              "\"load_average_before\": [%.2f, %.2f, %.2f], \"load_average_after\": [%.2f, %.2f, %.2f]",
              JsonQuoted(machine.cpu_model).c_str(), machine.logical_cores, JsonQuoted(machine.simd).c_str(),
              JsonQuoted(machine.compiler).c_str(), JsonQuoted(run.commit).c_str(), JsonQuoted(run.date).c_str(),
              run.load_at_start[0], run.load_at_start[1], run.load_at_start[2], run.load_now[0], run.load_now[1],
              run.load_now[2]);
  out << "[\n";
  for (size_t i = 0; i < record_fields.size(); ++i) {
    out << "  {" << record_fields[i] << ", " << machine_fields << "}" << (i + 1 < record_fields.size() ? "," : "")
        << "\n";
  }
  out << "]\n";
  if (!out) throw Error("writing benchmark results failed", path, "check the disk has space");
}

}  // namespace dg::tools
