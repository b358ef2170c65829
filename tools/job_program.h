#pragma once

#include <string>

namespace dg::tools {

// The absolute path of the dynaguide command beside the running program
// (tools/programs.h). The job lines of --emit-jobs start with it, so that a
// job runs this very build whether or not it is on PATH, from any working
// directory.
// @throws dg::Error when /proc/self/exe cannot be read.
std::string JobProgramPath();

// `word` as one word of a POSIX shell command line: unchanged when it holds
// only characters the shell takes literally, else single-quoted.
std::string ShellWord(const std::string& word);

}  // namespace dg::tools
