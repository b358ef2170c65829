#include "tools/job_program.h"

#include <filesystem>
#include <string_view>
#include <system_error>

#include "sim/error.h"

namespace dg::tools {

std::string RunningExecutablePath() {
  std::error_code error;
  const std::filesystem::path path = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) {
    throw Error("cannot find the running executable's path: " + error.message(), "/proc/self/exe",
                "mount /proc (Linux), or run the commands without --emit-jobs");
  }
  return path.string();
}

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
