#include "tools/programs.h"

#include "io/running_program.h"

namespace dg::tools {

std::string ProgramBesideThis(const std::string& program) { return (io::RunningProgramFolder() / program).string(); }

}  // namespace dg::tools
