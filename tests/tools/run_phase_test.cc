// The live cardiac phase through the whole graph (docs/phase.md): a default
// phantom whose beat varies by 10% per cycle is run from its video, and the
// run log's /phase is checked against the phantom's truth. The true phase is
// recomputed here from the truth's /cycles and /phase_shift_s, independently
// of the run log's own true_phase column.
#include <cmath>
#include <filesystem>

#include <catch2/catch.hpp>

#include "io/h5_file.h"
#include "pipeline/run_scene.h"
#include "tests/support/temporary_folder.h"
#include "tools/phantom/phantom_generator.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;

double Wrapped(double phase) { return phase - std::floor(phase); }
double Apart(double a, double b) { return std::abs(Wrapped(a - b + 0.5) - 0.5); }

// The truth's phase at video time t: the cycle holding t + phase shift.
double TruePhase(const io::H5Reader& truth, double t_s) {
  const std::vector<double> starts = truth.Read<double>("/cycles/start_s");
  const std::vector<double> periods = truth.Read<double>("/cycles/period_s");
  const double tau = t_s + truth.ReadScalar("/phase_shift_s");
  size_t c = 0;
  while (c + 1 < starts.size() && starts[c + 1] <= tau) ++c;
  return Wrapped((tau - starts[c]) / periods[c]);
}

TEST_CASE("run: the live phase follows an irregular beat better than the constant shift", "[tools][integration]") {
  const testing::TemporaryFolder folder("dg_run_phase_test");
  const fs::path dir = folder.path();
  // The default preset: at the tiny preset's 160x120 pixels and 10 scan
  // phases the estimate is ten times coarser (docs/phase.md).
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  spec.seed = 7;
  spec.period_variation = 0.10;
  phantom::GeneratePhantom(spec, dir.string(), false);

  pipeline::RunOptions options;
  options.scene = (dir / "scene.yaml").string();
  options.out_dir = (dir / "run").string();
  options.threads = 2;
  options.progress = false;
  options.video = false;
  const pipeline::RunOutcome outcome = pipeline::RunScene(options);
  REQUIRE(outcome.statistics.complete);

  const io::H5Reader log(outcome.log_path), truth((dir / "truth.h5").string());
  const std::vector<double> t = log.Read<double>("/phase/t_s");
  const std::vector<double> live = log.Read<double>("/phase/phase");
  const std::vector<double> registered = log.Read<double>("/phase/registered_phase");
  const std::vector<double> logged_truth = log.Read<double>("/phase/true_phase");
  const std::vector<double> simulated = log.Read<double>("/sim/motion_phase");
  REQUIRE(t.size() >= 40);  // from the registration (two cycles) to the end
  REQUIRE(simulated.size() == t.size());
  const double period_ms = 1e3 * truth.ReadScalar("/period_s");
  double live_sum = 0, registered_sum = 0, live_max = 0, simulated_sum = 0;
  for (size_t k = 0; k < t.size(); ++k) {
    const double true_phase = TruePhase(truth, t[k]);
    CHECK(logged_truth[k] == Approx(true_phase).margin(1e-12));
    live_sum += Apart(live[k], true_phase) * period_ms;
    live_max = std::max(live_max, Apart(live[k], true_phase) * period_ms);
    registered_sum += Apart(registered[k], true_phase) * period_ms;
    simulated_sum += Apart(simulated[k], true_phase) * period_ms;
  }
  const double n = static_cast<double>(t.size());
  UNSCOPED_INFO("live phase error mean " << live_sum / n << " ms, max " << live_max << " ms; constant shift mean "
                                         << registered_sum / n << " ms; simulated motion mean " << simulated_sum / n
                                         << " ms");
  // Measured: live 2.30 ms mean, 5.6 ms max; constant shift 115 ms mean;
  // simulated motion 2.39 ms mean. Held to the product's 3 and 10 ms.
  CHECK(live_sum < registered_sum / 10);
  CHECK(live_sum / n <= 3.0);
  CHECK(live_max <= 10.0);
  // The simulation's motion runs at the estimate, steered over a frame period.
  CHECK(simulated_sum / n <= 1.5 * live_sum / n);
}

}  // namespace
}  // namespace dg::tools
