// The `bench` group alone: `dynaguide` adds only `bench sim` to it, so that
// linking it pulls in no other benchmark (tools/programs.h).
#include <CLI/CLI.hpp>

#include "tools/commands.h"

namespace dg::tools {

CLI::App* AddBenchGroup(CLI::App& app) {
  CLI::App* bench = app.add_subcommand("bench", "Measure throughput; figures are printed and saved as JSON");
  bench->require_subcommand(1);
  return bench;
}

}  // namespace dg::tools
