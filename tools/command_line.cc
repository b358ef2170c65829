#include "tools/command_line.h"

#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "pipeline/stop_request.h"
#include "sim/error.h"

namespace dg::tools {

int RunCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const pipeline::Interrupted& e) {
    // The exit status a shell gives a process the signal ended.
    std::fprintf(stderr, "dynaguide: %s\n", e.what());
    return e.exit_code();
  } catch (const Error& e) {
    std::fprintf(stderr, "dynaguide: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynaguide: unexpected error: %s\n", e.what());
    return 2;
  } catch (...) {
    // Some libraries throw what is not a std::exception (Gmsh's API throws
    // strings); the process still ends with a message, not an abort.
    std::fprintf(stderr, "dynaguide: unexpected error of a type that is not an exception class (from a library)\n");
    return 2;
  }
  return 0;
}

}  // namespace dg::tools
