#pragma once

#include <string>

#include "tools/preop/preop_job.h"

namespace dg::tools::preop {

// preop.json: the inputs, each step's time, the segmentation's and the mesh's
// figures, per phase the registration's similarity before and after and the
// deformation's Jacobian range, and per fiducial the deformed-against-found
// error (the paper's Table 2, first row). Written marked incomplete when the
// job starts, and rewritten when it completes or fails (then with the error),
// so a stopped job never leaves a report that looks whole.
class PreopReportFile {
 public:
  // @throws dg::Error when the file cannot be written.
  PreopReportFile(std::string path, const PreopOptions& options);
  void Complete(const PreopSummary& summary) { Write(summary, true, {}); }
  void Fail(const PreopSummary& summary, const std::string& error) { Write(summary, false, error); }

 private:
  void Write(const PreopSummary& summary, bool complete, const std::string& error);

  std::string path_;
  std::string inputs_json_;  // the "inputs" object's JSON text
};

}  // namespace dg::tools::preop
