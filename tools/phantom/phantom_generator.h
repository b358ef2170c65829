#pragma once

#include <string>

#include "tools/phantom/phantom_spec.h"

namespace dg::tools::phantom {

// What a generated scene holds, for the command's summary.
struct PhantomSummary {
  int nodes = 0, tets = 0;
  double min_radius_ratio = 0;
  int frames = 0, phases = 0, chessboard_pairs = 0, fiducials = 0;
  double phase_shift_s = 0, period_s = 0;
  double wall_s = 0;
  std::string out_dir;
  std::string Describe() const;
};

// Writes the complete scene (docs/commands/phantom.md) into out_dir,
// which is created. Deterministic: the same spec writes the same bytes.
// @throws dg::Error for an invalid spec or a file that cannot be written.
PhantomSummary GeneratePhantom(const PhantomSpec& spec, const std::string& out_dir, bool progress);

}  // namespace dg::tools::phantom
