#include "io/run_log.h"

#include <exception>
#include <filesystem>
#include <system_error>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

// The error of a log closed without Finish(): after a kill -9 the .part file
// keeps the one written at creation.
constexpr char kNotFinished[] = "the run stopped before it closed its log (killed, or an error before the end)";

std::string Joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ",") + name;
  return text;
}

}  // namespace

RunLog::Open::Open(const std::string& part_path)
    : file(part_path),
      timings(file, "/timings",
              {{"frame", H5Type::kInt64}, {"stage", H5Type::kInt32}, {"thread", H5Type::kInt32},
               {"start_ns", H5Type::kInt64}, {"end_ns", H5Type::kInt64}}),
      drops(file, "/drops", {{"frame", H5Type::kInt64}, {"at_ns", H5Type::kInt64}}) {}

RunLog::RunLog(const std::string& path, const std::string& scene_text, const RunAttributes& attributes,
               const std::vector<std::string>& stage_names)
    : path_(path), open_(std::make_unique<Open>(path + ".part")) {
  H5Writer& file = open_->file;
  file.WriteAttribute("/", "complete", std::int64_t{0});
  file.WriteAttribute("/", "error", std::string(kNotFinished));
  file.WriteAttribute("/", "version", attributes.version);
  file.WriteAttribute("/", "policy", attributes.policy);
  file.WriteAttribute("/", "machine", attributes.machine);
  file.WriteAttribute("/", "threads", std::int64_t{attributes.threads});
  file.WriteAttribute("/", "fps", attributes.fps);
  file.WriteString("/scene", scene_text);
  file.WriteAttribute("/timings", "stage_names", Joined(stage_names));
  file.Flush();
}

RunLog::~RunLog() {
  try {
    Close();
  } catch (const std::exception& e) {
    Logger("io").error("closing {}: {}", path_, e.what());
  }
}

H5Writer& RunLog::file() {
  DG_CHECK(open_);
  return open_->file;
}

void RunLog::AppendTiming(std::int64_t frame, std::int32_t stage, std::int32_t thread, std::int64_t start_ns,
                          std::int64_t end_ns) {
  DG_CHECK(open_);
  open_->timings.AppendRow({frame, stage, thread, start_ns, end_ns});
}

void RunLog::AppendDrop(std::int64_t frame, std::int64_t at_ns) {
  DG_CHECK(open_);
  open_->drops.AppendRow({frame, at_ns});
}

H5Table& RunLog::AddTable(const std::string& group, std::vector<H5Column> columns) {
  DG_CHECK(open_);
  return open_->tables.emplace_back(open_->file, group, std::move(columns));
}

void RunLog::Flush() {
  DG_CHECK(open_);
  std::vector<H5Table*> tables = {&open_->timings, &open_->drops};
  for (H5Table& table : open_->tables) tables.push_back(&table);
  try {
    H5Table::FlushTogether(tables);
  } catch (const Error& e) {
    if (write_error_.empty()) write_error_ = e.what();
    throw;
  }
}

void RunLog::Finish(bool complete, const std::string& error) {
  DG_CHECK(open_);
  finished_ = true;
  if (!complete) return MarkIncomplete(error);
  try {
    Flush();
    open_->file.WriteAttribute("/", "error", std::string());
    open_->file.WriteAttribute("/", "complete", std::int64_t{1});
    open_->file.Flush();
  } catch (const Error& e) {
    MarkIncomplete(e.what());
    throw;
  }
}

void RunLog::MarkIncomplete(const std::string& error) {
  H5Writer& file = open_->file;
  const std::string cause = !error.empty() ? error : !write_error_.empty() ? write_error_ : kNotFinished;
  bool marked = true;
  try {
    file.WriteAttribute("/", "complete", std::int64_t{0});
    file.WriteAttribute("/", "error", cause);
    file.Flush();
  } catch (const Error& e) {
    // The file still says complete=0, with the error written at its creation;
    // the run's own error, which the caller reports, is not replaced by this one.
    Logger("io").warn("{} could not record why the run stopped: {}", path_, e.what());
    marked = false;
  }
  // Then the rows since the last flush, unless a write already failed (a
  // full disk): then they are dropped, and the error says why.
  if (marked && !write_failed()) {
    try {
      Flush();
    } catch (const Error& e) {
      Logger("io").warn("the rows since the last flush are lost: {}", e.what());
    }
  }
  open_->timings.StopWriting();
  open_->drops.StopWriting();
  for (H5Table& table : open_->tables) table.StopWriting();
}

void RunLog::Close() {
  if (!open_) return;
  if (!finished_) Finish(false);
  open_.reset();
  std::error_code error;
  std::filesystem::rename(path_ + ".part", path_, error);
  if (error) {
    throw Error("cannot rename the finished run log: " + error.message(), path_ + ".part",
                "check that the output directory is writable; the log is under its .part name");
  }
}

}  // namespace dg::io
