#include <CLI/CLI.hpp>

#include "tools/commands.h"

namespace dg::tools {

void AddSimCommand(CLI::App& app) { app.add_subcommand("sim", "(in progress)"); }

}  // namespace dg::tools
