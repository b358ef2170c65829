#pragma once

#include <cstdint>
#include <deque>
#include <memory>
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
// and any further table a stage's sink adds (/tracks, /sim, ...).
//
// Life cycle (docs/formats/run_log.md): while open, the file is PATH.part; Close()
// renames it to PATH, so a reader never takes a log being written, or half of
// two runs, for a finished one. The root attribute `complete` is 0 until
// Finish(true); a run that stops early by an error is marked complete=0 with
// the cause in the attribute `error`, and keeps every row up to the last
// Flush(). A full disk fails a write before it touches the file (see
// H5Writer), so the rows flushed before stay readable. After a kill -9 only
// PATH.part is left, readable up to its last flush. Not thread-safe: the
// pipeline's sink writes it.
class RunLog {
 public:
  // Creates PATH.part (replacing one of that name).
  // @throws dg::Error naming the path when it cannot be created.
  RunLog(const std::string& path, const std::string& scene_text, const RunAttributes& attributes,
         const std::vector<std::string>& stage_names);
  // Close(); an error is logged, not thrown.
  ~RunLog();
  RunLog(const RunLog&) = delete;
  RunLog& operator=(const RunLog&) = delete;

  // @pre the log is open (before Close()), as for every call below but path().
  void AppendTiming(std::int64_t frame, std::int32_t stage, std::int32_t thread, std::int64_t start_ns,
                    std::int64_t end_ns);
  void AppendDrop(std::int64_t frame, std::int64_t at_ns);

  // A further table in the log, owned by it (the reference stays valid until Close()).
  H5Table& AddTable(const std::string& group, std::vector<H5Column> columns);

  // Writes buffered rows and flushes the file.
  // @throws dg::Error when a write fails (e.g. the disk is full); the first
  // such error is kept as the log's `error` unless Finish() gives another.
  void Flush();
  // Whether a Flush() failed: the log then takes no more rows.
  bool write_failed() const { return !write_error_.empty(); }
  // Records how the run ended and flushes: complete=1, or complete=0 with
  // `error` (the cause first, so that it is on disk even when the rows
  // buffered since the last flush no longer fit).
  // @throws dg::Error when a complete run's rows cannot be written (the log is
  // then marked incomplete with that error); an incomplete run's Finish
  // logs a failure to write the mark rather than replace the run's error.
  void Finish(bool complete, const std::string& error = {});
  // Finishes an unfinished log as incomplete, closes the file and renames it
  // from PATH.part to PATH. Later calls do nothing.
  // @throws dg::Error when the file cannot be renamed.
  void Close();

  H5Writer& file();
  // The final name (PATH); the file is at PATH.part until Close().
  const std::string& path() const { return path_; }

 private:
  struct Open {
    Open(const std::string& part_path);
    H5Writer file;  // first, so that it closes after the tables that reopened it
    H5Table timings, drops;
    std::deque<H5Table> tables;
  };

  void MarkIncomplete(const std::string& error);

  std::string path_;
  std::unique_ptr<Open> open_;
  bool finished_ = false;
  std::string write_error_;
};

}  // namespace dg::io
