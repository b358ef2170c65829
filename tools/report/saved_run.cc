#include "tools/report/saved_run.h"

#include <algorithm>
#include <sstream>

#include "io/h5_file.h"
#include "sim/error.h"

namespace dg::tools {
namespace {

std::vector<std::string> Split(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream stream(text);
  for (std::string part; std::getline(stream, part, ',');) parts.push_back(part);
  return parts;
}

template <typename T>
T AttributeOr(const io::H5Reader& file, const std::string& name, T fallback) {
  return file.HasAttribute("/", name) ? file.ReadAttribute<T>("/", name) : fallback;
}

}  // namespace

SavedRun ReadSavedRun(const std::string& path) {
  const io::H5Reader file(path);
  if (!file.Has("/timings") || !file.HasAttribute("/timings", "stage_names")) {
    throw Error("not a run log: no /timings table", path, "give the run.h5 that dynaguide run wrote");
  }
  SavedRun run;
  run.path = path;
  run.stage_names = Split(file.ReadAttribute<std::string>("/timings", "stage_names"));
  const auto frame = file.Read<std::int64_t>("/timings/frame");
  const auto stage = file.Read<std::int32_t>("/timings/stage");
  const auto thread = file.Read<std::int32_t>("/timings/thread");
  const auto start = file.Read<std::int64_t>("/timings/start_ns");
  const auto end = file.Read<std::int64_t>("/timings/end_ns");
  // A run killed inside a flush may leave columns of unequal length: the rows all columns have.
  const size_t rows = std::min({frame.size(), stage.size(), thread.size(), start.size(), end.size()});
  for (size_t i = 0; i < rows; ++i) run.timings.push_back({frame[i], stage[i], thread[i], start[i], end[i]});

  const std::int64_t dropped = file.Has("/drops/frame") ? file.Shape("/drops/frame").at(0) : 0;
  const bool complete = AttributeOr<std::int64_t>(file, "complete", 0) == 1;
  run.statistics = pipeline::Summarize(run.timings, run.stage_names, dropped, AttributeOr(file, "wall_s", 0.0),
                                       AttributeOr(file, "fps", 0.0), complete);
  run.policy = AttributeOr<std::string>(file, "policy", "");
  run.error = AttributeOr<std::string>(file, "error", "");
  run.threads = static_cast<int>(AttributeOr<std::int64_t>(file, "threads", 0));
  if (file.Has("/composite/layer_age_frames") && file.HasAttribute("/composite", "overlay_names")) {
    run.overlay_names = Split(file.ReadAttribute<std::string>("/composite", "overlay_names"));
    run.composite_frame = file.Read<std::int64_t>("/composite/frame");
    run.layer_age_frames = file.Read<std::int64_t>("/composite/layer_age_frames");
    // As /timings: the rows both columns have.
    const size_t composed = std::min(run.composite_frame.size(),
                                     run.layer_age_frames.size() / std::max<size_t>(1, run.overlay_names.size()));
    run.composite_frame.resize(composed);
    run.layer_age_frames.resize(composed * run.overlay_names.size());
  }
  return run;
}

}  // namespace dg::tools
