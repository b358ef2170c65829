#pragma once

#include <string>

#include "tools/preop/preop_job.h"

namespace dg::tools::preop {

// `dynaguide bench preop`: the preoperative job on the default phantom's 4D CT
// (its DICOM series), timed, and its motion checked against the phantom's
// exact displacement fields (truth/dvf_phase_NN.mha) at the mesh's nodes and
// at the fiducials (the paper's Table 2, first row: the deformed phase-0
// fiducials against the phantom's true per-phase fiducials).
// A preop scene's motion against a phantom's truth.
struct PreopMotionErrors {
  double node_error_mean_mm = 0, node_error_max_mm = 0;   // over every node of every phase the truth covers
  int nodes_outside_truth = 0;                              // beyond the truth fields' grid points: not measured
  double fiducial_deformed_mean_mm = 0;                     // deformed phase-0 fiducials against the truth's
  double fiducial_found_mean_mm = 0;                        // beads found in the CT against the truth's
};

// Reads out_dir/scan.h5 (as RunPreop writes it) and the phantom's
// truth/dvf_phase_NN.mha and scan.h5; the fiducial errors are NaN when
// either scan has no fiducials (a phantom warped from a real CT has none).
// @throws dg::Error for a missing file.
PreopMotionErrors EvaluatePreopMotion(const std::string& out_dir, const std::string& phantom_dir);

struct PreopBenchRecord {
  PreopSummary summary;
  int threads = 0;
  PreopMotionErrors errors;
  std::string out_dir;
};

// out_dir: where the scene goes (kept, with scene.yaml for `eval protocol`).
PreopBenchRecord RunPreopBench(const std::string& out_dir, int threads, bool progress);
void WritePreopBenchJson(const std::string& path, const PreopBenchRecord& record);
std::string PreopBenchTable(const PreopBenchRecord& record);

}  // namespace dg::tools::preop
