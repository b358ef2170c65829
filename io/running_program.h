#pragma once

#include <filesystem>

namespace dg::io {

// The folder of the running executable (from /proc/self/exe, symlinks
// resolved): where the command's other programs and, relative to it, its
// installed Gmsh module are.
// @throws dg::Error when /proc/self/exe cannot be read.
std::filesystem::path RunningProgramFolder();

}  // namespace dg::io
