#include <CLI/CLI.hpp>

#include "tools/commands.h"

namespace dg::tools {

void AddMeshCommand(CLI::App& app) { app.add_subcommand("mesh", "(in progress)"); }

}  // namespace dg::tools
