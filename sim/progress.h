#pragma once

#include <chrono>
#include <string>

namespace dg {

// Progress of a long job on stderr: a line rewritten in place on a terminal,
// otherwise a plain line at every tenth of the work (so CI logs stay short).
class Progress {
 public:
  Progress(std::string label, double total, bool enabled);
  // done: in the units of total; detail: appended to the line (e.g. a rate).
  void Update(double done, const std::string& detail);
  void Finish();

 private:
  std::string label_;
  double total_;
  bool enabled_, terminal_;
  int last_tenth_ = -1;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace dg
