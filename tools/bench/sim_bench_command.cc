// `dynaguide bench sim`: the solver's throughput. It runs in the `dynaguide`
// program itself (tools/programs.h), so its process maps only the solver's
// libraries.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "sim/precision.h"
#include "tools/bench/bench_json.h"
#include "tools/bench/sim_bench.h"
#include "tools/commands.h"

namespace dg::tools {

void AddSimBench(CLI::App& bench) {
  auto options = std::make_shared<SimBenchOptions>();
  auto json_path = std::make_shared<std::string>();
  CLI::App* sim = bench.add_subcommand("sim", "TLED tetrahedron-steps per second on Gmsh boxes (forward) or the phantom (inverse + forward)");
  sim->add_option("--mode", options->modes,
                  "forward (solver on boxes) and/or combined, volume, surface (inverse + forward on the phantom)")
      ->delimiter(',')
      ->check(CLI::IsMember({"forward", "combined", "volume", "surface"}))
      ->capture_default_str();
  CLI::Option* tets =
      sim->add_option("--tets", options->tets,
                      "Target mesh sizes (phantom modes: 8000, the default phantom's); with --mesh, generated "
                      "boxes timed in the same rounds as the file")
          ->delimiter(',')
          ->capture_default_str();
  sim->add_option("--threads", options->threads, "Thread counts")->delimiter(',')->capture_default_str();
  sim->add_option("--mesh", options->mesh_path,
                  "forward: a Gmsh .msh file (metres) instead of the boxes, in its own node order; its lowest z "
                  "face fixed, its highest pressed down")
      ->check(CLI::ExistingFile);
  sim->add_flag("--shuffled", options->shuffled_too, "forward: also each mesh with its nodes in a random order");
  auto precisions = std::make_shared<std::vector<std::string>>(std::vector<std::string>{"float", "double"});
  sim->add_option("--precision", *precisions, "float and/or double")->delimiter(',')->capture_default_str();
  sim->add_option("--inverse-interval", options->inverse_intervals,
                  "combined, volume: forward steps per level of recovered forces, each measured with its error")
      ->delimiter(',')
      ->check(CLI::Range(1, sim::kMaxInverseIntervalSteps))
      ->capture_default_str();
  sim->add_option("--repeats", options->repeats, "Timed repeats; the median is reported")->capture_default_str();
  sim->add_option("--seconds", options->simulated_per_repeat_s, "Simulated seconds per repeat")->capture_default_str();
  sim->add_option("--json", *json_path, "Save the records to this JSON file");
  sim->callback([options, precisions, json_path, tets] {
    options->precisions.clear();
    for (const std::string& name : *precisions) options->precisions.push_back(sim::ParsePrecision(name, "--precision"));
    const bool forward = std::find(options->modes.begin(), options->modes.end(), "forward") != options->modes.end();
    if (tets->count() == 0 && !forward) options->tets = {8000};
    options->boxes_beside_file = !options->mesh_path.empty() && tets->count() > 0;
    PrintMachine();
    const std::vector<SimBenchRecord> records = RunSimBench(*options, true);
    PrintAndSave(SimBenchTable(records), *json_path, records, WriteSimBenchJson);
  });
}

}  // namespace dg::tools
