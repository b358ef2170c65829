// `dynaguide eval stability` (issue 9): being written.
#include <CLI/CLI.hpp>

#include "tools/eval/eval_subcommands.h"

namespace dg::tools {

void AddStabilityCommand(CLI::App& /*eval*/) {}

}  // namespace dg::tools
