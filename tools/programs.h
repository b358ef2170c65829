#pragma once

#include <string>

namespace dg::tools {

// The dynaguide command is two programs in one directory. `dynaguide` runs
// the solver's commands (sim, mesh, bench sim) itself and hands every other
// command line, unchanged, to `dynaguide-full`, which holds every command and
// loads the video, CT and surface libraries they need. So a solver's process
// maps only the libraries stepping and meshing use (docs/install.md, "The
// command's two programs").
inline constexpr char kCommandProgram[] = "dynaguide";
inline constexpr char kFullProgram[] = "dynaguide-full";

// The absolute path of `program` in the running executable's directory
// (from /proc/self/exe), whether or not it exists.
// @throws dg::Error when /proc/self/exe cannot be read.
std::string ProgramBesideThis(const std::string& program);

}  // namespace dg::tools
