#pragma once

namespace CLI {
class App;
}

namespace dg::tools {

// What `dynaguide --help` says the command is; both programs show it.
inline constexpr char kCommandDescription[] =
    "dynaguide: image-constrained soft-tissue simulation for surgical guidance";

// Parses argv into `app` and runs the subcommand's callback. Errors are
// printed as "dynaguide: error: ..." and become the exit status returned:
// CLI11's for a bad command line, 1 for dg::Error (bad input), 2 for anything
// unexpected, and the signal's status for a run or sim stopped by SIGINT or
// SIGTERM (its outputs finished and marked incomplete).
int RunCommandLine(CLI::App& app, int argc, char** argv);

}  // namespace dg::tools
