#include <CLI/CLI.hpp>

#include "tools/commands.h"

namespace dg::tools {

void AddBenchCommand(CLI::App& app) { app.add_subcommand("bench", "(in progress)"); }

}  // namespace dg::tools
