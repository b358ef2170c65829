#include "tools/bench/bench_json.h"

#include <fstream>

#include "sim/error.h"
#include "tools/json_text.h"
#include "tools/machine_info.h"

namespace dg::tools {

void WriteBenchJson(const std::string& path, const std::vector<std::string>& record_fields) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write benchmark results", path, "check the directory exists and is writable");
  const MachineInfo machine = ReadMachineInfo();
  const std::string machine_fields =
      Printed("\"cpu\": %s, \"logical_cores\": %d, \"simd\": %s, \"compiler\": %s", JsonQuoted(machine.cpu_model).c_str(),
              machine.logical_cores, JsonQuoted(machine.simd).c_str(), JsonQuoted(machine.compiler).c_str());
  out << "[\n";
  for (size_t i = 0; i < record_fields.size(); ++i) {
    out << "  {" << record_fields[i] << ", " << machine_fields << "}" << (i + 1 < record_fields.size() ? "," : "")
        << "\n";
  }
  out << "]\n";
  if (!out) throw Error("writing benchmark results failed", path, "check the disk has space");
}

}  // namespace dg::tools
