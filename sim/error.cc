#include "sim/error.h"

#include <cstdio>
#include <cstdlib>

namespace dg::internal {

void CheckFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "internal check failed: %s at %s:%d (a bug in dynaguide; please report it)\n",
               condition, file, line);
  std::abort();
}

}  // namespace dg::internal
