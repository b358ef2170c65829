#include "tools/job_program.h"

#include <string_view>

#include "tools/programs.h"

namespace dg::tools {

std::string JobProgramPath() { return ProgramBesideThis(kCommandProgram); }

std::string ShellWord(const std::string& word) {
  const auto literal = [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           std::string_view("_-+./:,=@%").find(c) != std::string_view::npos;
  };
  bool plain = !word.empty();
  for (char c : word) plain = plain && literal(c);
  if (plain) return word;
  // Inside single quotes every character is literal but the quote itself,
  // which closes the quotes, is written escaped, and opens them again.
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace dg::tools
