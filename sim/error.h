#pragma once

#include <stdexcept>
#include <string>

namespace dg {

// Bad input or configuration, reported at the boundary where it is found.
// Every error says what is wrong, where (file:line, key, element id, step),
// and how to fix it; the command prints it on one line and exits non-zero.
// Broken internal invariants are not Errors: they abort (DG_CHECK).
class Error : public std::runtime_error {
 public:
  Error(std::string what, std::string where, std::string fix)
      : std::runtime_error(Compose(what, where, fix)),
        what_(std::move(what)),
        where_(std::move(where)),
        fix_(std::move(fix)) {}

  const std::string& problem() const { return what_; }
  const std::string& where() const { return where_; }
  const std::string& fix() const { return fix_; }

 private:
  static std::string Compose(const std::string& what, const std::string& where,
                             const std::string& fix) {
    std::string message = what;
    if (!where.empty()) message += " [at " + where + "]";
    if (!fix.empty()) message += "; fix: " + fix;
    return message;
  }

  std::string what_;
  std::string where_;
  std::string fix_;
};

}  // namespace dg

// Aborts with file:line when an internal invariant is broken (a bug, not bad input).
#define DG_CHECK(condition)                                                        \
  do {                                                                             \
    if (!(condition)) ::dg::internal::CheckFailed(#condition, __FILE__, __LINE__); \
  } while (false)

namespace dg::internal {
[[noreturn]] void CheckFailed(const char* condition, const char* file, int line);
}  // namespace dg::internal
