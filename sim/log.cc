#include "sim/log.h"

#include <mutex>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace dg {

spdlog::logger& Logger(const std::string& folder) {
  static std::mutex mutex;
  std::lock_guard<std::mutex> lock(mutex);
  std::shared_ptr<spdlog::logger> logger = spdlog::get(folder);
  // Logs go to stderr so that a command's stdout stays machine-readable.
  if (!logger) logger = spdlog::stderr_color_mt(folder);
  return *logger;
}

}  // namespace dg
