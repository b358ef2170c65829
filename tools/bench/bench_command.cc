// `dynaguide bench sim`: throughput figures that the README quotes.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "tools/bench/sim_bench.h"
#include "tools/commands.h"
#include "tools/machine_info.h"

namespace dg::tools {

void AddBenchCommand(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Measure throughput; figures are printed and saved as JSON");
  bench->require_subcommand(1);

  auto options = std::make_shared<SimBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* sim = bench->add_subcommand("sim", "TLED tetrahedron-steps per second on Gmsh boxes");
  sim->add_option("--mode", options->mode, "forward (combined arrives with inverse simulation)")
      ->check(CLI::IsMember({"forward", "combined"}))
      ->capture_default_str();
  sim->add_option("--tets", options->tets, "Target mesh sizes")->delimiter(',')->capture_default_str();
  sim->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  sim->add_option("--precision", options->precisions, "float and/or double")
      ->delimiter(',')
      ->check(CLI::IsMember({"float", "double"}))
      ->capture_default_str();
  sim->add_option("--repeats", options->repeats, "Timed repeats; the median is reported")->capture_default_str();
  sim->add_option("--seconds", options->simulated_per_repeat_s, "Simulated seconds per repeat")->capture_default_str();
  sim->add_option("--json", *json_path, "Save the records to this JSON file");
  sim->callback([options, json_path] {
    const MachineInfo machine = ReadMachineInfo();
    std::printf("machine: %s, %d logical cores, %s, %s\n", machine.cpu_model.c_str(), machine.logical_cores,
                machine.simd.c_str(), machine.compiler.c_str());
    const std::vector<SimBenchRecord> records = RunSimBench(*options, true);
    std::fputs(SimBenchTable(records).c_str(), stdout);
    if (!json_path->empty()) {
      WriteSimBenchJson(*json_path, records);
      std::printf("saved %s\n", json_path->c_str());
    }
  });
}

}  // namespace dg::tools
