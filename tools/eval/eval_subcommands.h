#pragma once

namespace CLI {
class App;
}

namespace dg::tools {

// The `dynaguide eval` subcommands beside `protocol`, each in its own file.
void AddStabilityCommand(CLI::App& eval);  // eval/stability_command.cc
void AddRuntimeCommand(CLI::App& eval);    // eval/runtime_command.cc

}  // namespace dg::tools
