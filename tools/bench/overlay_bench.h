#pragma once

#include <string>
#include <vector>

#include "pipeline/overlay_stages.h"

namespace dg::tools {

struct OverlayBenchOptions {
  std::vector<int> threads{1, 2};
  int frames = 30;           // timed Process/Compose calls per overlay and thread count
  double duration_s = 0.5;   // of the generated phantom (its frames are cycled)
  pipeline::OverlayQuality quality;  // the run's defaults unless set
};

// One line of the saved table: per overlay and thread count, the
// time per frame of its Process() (for "composite": Compositor::Compose() of
// texture, volume and meshes with Inverse Realism, saliency included).
struct OverlayBenchRecord {
  std::string overlay;  // mesh, texture, volume or composite
  int threads = 0;
  int width = 0, height = 0;
  int frames = 0;
  double ms_median = 0, ms_p95 = 0;
  double fps = 0;  // 1000 / ms_median
};

// The overlays of a default-preset phantom (generated into a temporary folder
// and removed afterwards) under its true motion, per thread count.
std::vector<OverlayBenchRecord> RunOverlayBench(const OverlayBenchOptions& options, bool progress);

// Writes the records as a JSON list, each with the machine it ran on.
void WriteOverlayBenchJson(const std::string& path, const std::vector<OverlayBenchRecord>& records);

// A plain-text (Markdown) table of the records.
std::string OverlayBenchTable(const std::vector<OverlayBenchRecord>& records);

}  // namespace dg::tools
