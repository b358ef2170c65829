#pragma once

#include <chrono>

namespace dg::io {

// Wall milliseconds from `start` to now, on the monotonic clock the timings use.
inline double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace dg::io
