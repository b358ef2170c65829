#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "io/h5_file.h"
#include "io/h5_table.h"

namespace dg::io {

// What a run log says about the run as a whole (root attributes).
struct RunAttributes {
  std::string version;  // dynaguide's
  std::string policy;   // offline or realtime
  std::string machine;  // CPU, cores, compiler
  int threads = 0;
  double fps = 0;       // the recording's
};

// The HDF5 log of one `dynaguide run`: the scene text
// verbatim in /scene, the root attributes, and appendable tables:
//   /timings  frame, stage, thread, start_ns, end_ns (attribute stage_names:
//             the stage indices' names, comma-separated)
//   /drops    frame, at_ns (frames the realtime policy dropped)
// and any further table a stage's sink adds (/tracks, /sim, ...). The root
// attribute `complete` is 0 until Finish(true): a run that stops early, by an
// error or a kill, leaves a readable file marked incomplete, holding every row
// up to the last Flush(). Not thread-safe: the pipeline's sink writes it.
class RunLog {
 public:
  // Creates the file (replacing one of that name).
  // @throws dg::Error naming the path when it cannot be created.
  RunLog(const std::string& path, const std::string& scene_text, const RunAttributes& attributes,
         const std::vector<std::string>& stage_names);
  // Flushes; a log not finished is left marked incomplete.
  ~RunLog();
  RunLog(const RunLog&) = delete;
  RunLog& operator=(const RunLog&) = delete;

  void AppendTiming(std::int64_t frame, std::int32_t stage, std::int32_t thread, std::int64_t start_ns,
                    std::int64_t end_ns);
  void AppendDrop(std::int64_t frame, std::int64_t at_ns);

  // A further table in the log, owned by it (the reference stays valid).
  H5Table& AddTable(const std::string& group, std::vector<H5Column> columns);

  // Writes buffered rows and flushes the file.
  void Flush();
  // Records how the run ended (attribute complete, and the error if any) and flushes.
  void Finish(bool complete, const std::string& error = {});

  H5Writer& file() { return file_; }
  const std::string& path() const { return file_.path(); }

 private:
  H5Writer file_;
  H5Table timings_, drops_;
  std::deque<H5Table> tables_;
  bool finished_ = false;
};

}  // namespace dg::io
