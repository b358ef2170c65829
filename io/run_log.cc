#include "io/run_log.h"

#include <exception>

#include "sim/error.h"
#include "sim/log.h"

namespace dg::io {
namespace {

std::string Joined(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ",") + name;
  return text;
}

}  // namespace

RunLog::RunLog(const std::string& path, const std::string& scene_text, const RunAttributes& attributes,
               const std::vector<std::string>& stage_names)
    : file_(path),
      timings_(file_, "/timings",
               {{"frame", H5Type::kInt64}, {"stage", H5Type::kInt32}, {"thread", H5Type::kInt32},
                {"start_ns", H5Type::kInt64}, {"end_ns", H5Type::kInt64}}),
      drops_(file_, "/drops", {{"frame", H5Type::kInt64}, {"at_ns", H5Type::kInt64}}) {
  file_.WriteAttribute("/", "complete", std::int64_t{0});
  file_.WriteAttribute("/", "version", attributes.version);
  file_.WriteAttribute("/", "policy", attributes.policy);
  file_.WriteAttribute("/", "machine", attributes.machine);
  file_.WriteAttribute("/", "threads", std::int64_t{attributes.threads});
  file_.WriteAttribute("/", "fps", attributes.fps);
  file_.WriteString("/scene", scene_text);
  file_.WriteAttribute("/timings", "stage_names", Joined(stage_names));
  file_.Flush();
}

RunLog::~RunLog() {
  if (finished_) return;
  try {
    Finish(false, "the run log was closed before the run finished");
  } catch (const std::exception& e) {
    Logger("io").error("closing {}: {}", path(), e.what());
  }
}

void RunLog::AppendTiming(std::int64_t frame, std::int32_t stage, std::int32_t thread, std::int64_t start_ns,
                          std::int64_t end_ns) {
  timings_.AppendRow({frame, stage, thread, start_ns, end_ns});
}

void RunLog::AppendDrop(std::int64_t frame, std::int64_t at_ns) { drops_.AppendRow({frame, at_ns}); }

H5Table& RunLog::AddTable(const std::string& group, std::vector<H5Column> columns) {
  return tables_.emplace_back(file_, group, std::move(columns));
}

void RunLog::Flush() {
  timings_.Flush();
  drops_.Flush();
  for (H5Table& table : tables_) table.Flush();
}

void RunLog::Finish(bool complete, const std::string& error) {
  finished_ = true;
  if (!error.empty()) file_.WriteAttribute("/", "error", error);
  Flush();
  file_.WriteAttribute("/", "complete", std::int64_t{complete ? 1 : 0});
  file_.Flush();
}

}  // namespace dg::io
