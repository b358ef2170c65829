#pragma once

#include <memory>
#include <string>

#include <spdlog/logger.h>

namespace dg {

// The named logger of one folder ("sim", "io", "stages", "pipeline", "tools"),
// created on first use and shared after; thread-safe. Per-frame or per-step
// data never goes here: it goes to HDF5.
spdlog::logger& Logger(const std::string& folder);

}  // namespace dg
