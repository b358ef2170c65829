#pragma once

#include <string>

namespace dg::tools {

// When and from what a benchmark's figures came.
struct RunProvenance {
  std::string commit;                  // `git describe --always --dirty` of the source built
  std::string date;                    // now, UTC, ISO 8601
  double load_at_start[3] = {0, 0, 0};  // 1, 5, 15 minute load averages when the process started
  double load_now[3] = {0, 0, 0};      // and now
};

RunProvenance ReadRunProvenance();

}  // namespace dg::tools
