#include "tools/bench/register_bench.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <unistd.h>

#include <nlohmann/json.hpp>
#include <opencv2/core/utility.hpp>
#include <tbb/global_control.h>

#include "io/calibration.h"
#include "io/elapsed_time.h"
#include "io/scene.h"
#include "sim/error.h"
#include "stages/register/fiducial_motion.h"
#include "stages/register/registration.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/phantom/phantom_generator.h"
#include "tools/phantom/phantom_spec.h"
#include "tools/register/register_run.h"
#include "tools/register/truth_tracks.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

struct BenchInput {
  stages::FiducialMotion motion;
  io::StereoCalibration calibration;
  RegistrationTruth truth;
  stages::FiducialTracks tracks;
};

RegisterBenchRecord Measure(const BenchInput& input, int threads, const RegisterBenchOptions& options) {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  const int opencv_threads = cv::getNumThreads();
  cv::setNumThreads(threads);
  std::vector<double> ms;
  stages::RegistrationResult result;
  for (int k = 0; k < options.repeats; ++k) {
    const auto start = std::chrono::steady_clock::now();
    result = stages::RegisterScanToVideo(input.motion, input.calibration, input.truth.period_s, input.tracks, {});
    ms.push_back(io::MsSince(start));
  }
  cv::setNumThreads(opencv_threads);
  std::sort(ms.begin(), ms.end());
  RegisterBenchRecord r;
  r.threads = threads;
  r.fiducials = input.motion.num_fiducials();
  r.frames = static_cast<int>(input.tracks.t_s.size());
  const io::Registration& reg = result.registration;
  r.observations = reg.left.observations + reg.left.outliers + reg.right.observations + reg.right.outliers;
  r.cycles = reg.cycles;
  r.ms_median = ms[ms.size() / 2];
  r.ms_max = ms.back();
  const RegistrationError error = CompareWithTruth(reg, input.truth.T_C_S, input.truth.phase_shift_s);
  r.rotation_error_deg = error.rotation_deg;
  r.translation_error_mm = error.translation_mm;
  r.phase_shift_error_ms = error.phase_shift_ms;
  r.residual_mm_left = reg.left.mean_mm;
  r.residual_mm_right = reg.right.mean_mm;
  return r;
}

}  // namespace

std::vector<RegisterBenchRecord> RunRegisterBench(const RegisterBenchOptions& options, bool progress) {
  if (options.repeats < 1 || !(options.cycles >= 1)) {
    throw Error("repeats must be at least 1 and cycles at least 1", "dynaguide bench register", "give e.g. --repeats 5");
  }
  const fs::path dir = fs::temp_directory_path() / ("dg_bench_register_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  spec.fiducials = options.fiducials;
  // The window and a frame to spare: the phantom's own cycles vary in length.
  spec.duration_s = options.cycles * spec.period_s() + 2 / spec.fps;
  if (progress) std::fprintf(stderr, "bench register: generating a %.2f s default phantom in %s\n", spec.duration_s, dir.c_str());
  phantom::GeneratePhantom(spec, dir.string(), false);
  const io::Scene scene = io::ReadScene((dir / "scene.yaml").string());
  BenchInput input{stages::ReadFiducialMotion(scene.preoperative->motion), io::ReadStereoCalibration(scene.calibration),
                   ReadRegistrationTruth(scene.truth), {}};
  fs::remove_all(dir);
  input.tracks = FirstFrames(input.truth.tracks, static_cast<int>(std::ceil(options.cycles * input.truth.period_s * input.truth.fps - 1e-9)));
  CorruptTracks(&input.tracks, options.sigma_px, 0.0, 0.0, spec.seed);

  std::vector<RegisterBenchRecord> records;
  for (int threads : options.threads) {
    records.push_back(Measure(input, threads, options));
    if (progress) {
      const RegisterBenchRecord& r = records.back();
      std::fprintf(stderr, "bench register: %d thread%s: %.1f ms median over %d repeats\n", r.threads,
                   r.threads > 1 ? "s" : "", r.ms_median, options.repeats);
    }
  }
  return records;
}

void WriteRegisterBenchJson(const std::string& path, const std::vector<RegisterBenchRecord>& records) {
  std::vector<std::string> texts;
  for (const RegisterBenchRecord& r : records) {
    const nlohmann::ordered_json record = {{"threads", r.threads},
                                           {"fiducials", r.fiducials},
                                           {"frames", r.frames},
                                           {"observations", r.observations},
                                           {"cycles", Significant(r.cycles, 4)},
                                           {"ms_median", Significant(r.ms_median, 4)},
                                           {"ms_max", Significant(r.ms_max, 4)},
                                           {"rotation_error_deg", Significant(r.rotation_error_deg, 4)},
                                           {"translation_error_mm", Significant(r.translation_error_mm, 4)},
                                           {"phase_shift_error_ms", Significant(r.phase_shift_error_ms, 4)},
                                           {"residual_mm_left", Significant(r.residual_mm_left, 4)},
                                           {"residual_mm_right", Significant(r.residual_mm_right, 4)}};
    texts.push_back(JsonText(record, -1));
  }
  WriteBenchJson(path, texts);
}

std::string RegisterBenchTable(const std::vector<RegisterBenchRecord>& records) {
  std::string table =
      "| threads | fiducials | frames | observations | ms median | ms max | rotation error deg | translation error mm "
      "| shift error ms | residual mm L/R |\n"
      "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const RegisterBenchRecord& r : records) {
    char line[320];
    std::snprintf(line, sizeof line, "| %d | %d | %d | %d | %.1f | %.1f | %.3f | %.3f | %+.2f | %.3f / %.3f |\n",
                  r.threads, r.fiducials, r.frames, r.observations, r.ms_median, r.ms_max, r.rotation_error_deg,
                  r.translation_error_mm, r.phase_shift_error_ms, r.residual_mm_left, r.residual_mm_right);
    table += line;
  }
  return table;
}

}  // namespace dg::tools
