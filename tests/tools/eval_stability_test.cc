// `dynaguide eval stability` on a coarse phantom mesh: each cell's
// outcome against an independent truth (the limit bisected with the guard
// off, a run at half the step, a motion that folds the mesh), the guard's
// estimates against the bisected limit, and the CSV against the results.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <catch2/catch.hpp>

#include "sim/stability.h"
#include "tests/support/temporary_folder.h"
#include "tools/eval/stability_report.h"
#include "tools/eval/stability_study.h"

namespace dg::tools {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::Contains;

// A coarse mesh keeps every run here well under a second.
constexpr int kTestTets = 400;

const StudyMesh& TestMesh() {
  static const StudyMesh mesh = MakeStudyMesh(kTestTets);
  return mesh;
}

// The paper's tissue, bisected once for the tests that need its true limit.
const BisectionResult& PaperTissueLimit() {
  static const BisectionResult limit = BisectStabilityLimit(TestMesh(), {3e3, 0.45, "default"});
  return limit;
}

}  // namespace

// A cell's name is its file and job name: it must read back to the same cell.
TEST_CASE("eval stability: cell and bisection names round-trip", "[unit]") {
  for (const CellSpec& spec : {CellSpec{3e3, 0.45, 2e-4, "default", Guard::kRefuse},
                               CellSpec{1e6, 0.499, 5e-5, "crush", Guard::kOff},
                               CellSpec{3e5, 0.3, 3e-4, "extreme", Guard::kSubstep}}) {
    const CellSpec back = CellSpec::Parse(spec.Name());
    CHECK(back.Name() == spec.Name());
    CHECK(back.youngs_modulus_pa == Approx(spec.youngs_modulus_pa));
    CHECK(back.poissons_ratio == Approx(spec.poissons_ratio));
    CHECK(back.dt_s == Approx(spec.dt_s));
    CHECK(back.motion == spec.motion);
    CHECK(back.guard == spec.guard);
  }
  CHECK(CellSpec{3e3, 0.45, 2e-4, "default", Guard::kRefuse}.Name() == "E3k_nu0.45_dt0.2ms_default_refuse");
  CHECK(BisectionCase::Parse("E100k_nu0.49_default").youngs_modulus_pa == Approx(1e5));
  CHECK_THROWS_WITH(CellSpec::Parse("E3k_nu0.45_default_refuse"), Contains("E<modulus>_nu<ratio>"));
  CHECK_THROWS_WITH(CellSpec::Parse("E3x_nu0.45_dt0.2ms_default_refuse"), Contains("modulus"));
  CHECK_THROWS_WITH(CellSpec::Parse("E3k_nu0.45_dt0.2ms_wobble_refuse"), Contains("unknown motion"));
}


// The guard's assembled estimate against the true limit, bisected with the
// guard off on the paper's tissue: Lanczos finds omega_max from below, so the
// estimate can only be high, and by no more than the stiffening of the
// motion's deformation (measured 0.996 on this mesh, 0.975 on the study's); the per-element
// bound must be conservative (at most the true limit; in theory about half).
TEST_CASE("eval stability: the bisected limit against the guard's estimates", "[integration]") {
  const BisectionResult& limit = PaperTissueLimit();
  INFO("bracket " << limit.dt_stable_s << " to " << limit.dt_unstable_s << " s, dt_cr " << limit.dt_critical_s);
  CHECK(limit.dt_unstable_s - limit.dt_stable_s <= 0.005 * limit.dt_stable_s);
  CHECK(limit.ratio_to_estimate() >= 0.9);
  CHECK(limit.ratio_to_estimate() <= 1.02);
  CHECK(limit.dt_element_bound_s <= limit.dt_stable_s);
  CHECK(limit.ratio_to_element_bound() >= 1.5);
  // The trials agree with the bracket: stable below it, unstable above.
  for (size_t k = 0; k < limit.trial_dt_s.size(); ++k) {
    CHECK(limit.trial_stable[k] == (limit.trial_dt_s[k] <= limit.dt_stable_s ? 1 : 0));
  }
}

// dt at 1.2 x the bisected limit: unchecked it blows up; the refusing guard
// refuses it naming dt_cr; the substepping guard splits it into the fewest
// safe substeps and the run is stable and agrees with a run at a fine step.
TEST_CASE("eval stability: 1.2 x the true limit under each guard", "[integration]") {
  const BisectionResult& limit = PaperTissueLimit();
  const double dt = 1.2 * limit.limit_s();
  const CellResult off = RunCell(TestMesh(), {3e3, 0.45, dt, "default", Guard::kOff});
  CHECK(OutcomeName(off.outcome) == "blow-up");
  CHECK_FALSE(off.message.empty());

  const CellResult refused = RunCell(TestMesh(), {3e3, 0.45, dt, "default", Guard::kRefuse});
  CHECK(OutcomeName(refused.outcome) == "refused");
  CHECK(refused.dt_critical_s == Approx(limit.dt_critical_s));
  char dt_cr_ms[32];
  std::snprintf(dt_cr_ms, sizeof dt_cr_ms, "%.4g ms", limit.dt_critical_s * 1e3);
  CHECK_THAT(refused.message, Contains(dt_cr_ms));
  CHECK(refused.internal_steps == 0);

  const CellResult substepped = RunCell(TestMesh(), {3e3, 0.45, dt, "default", Guard::kSubstep});
  REQUIRE(OutcomeName(substepped.outcome) == "substepped");
  CHECK(substepped.substeps == static_cast<int>(std::ceil(dt / (0.9 * limit.dt_critical_s))));
  REQUIRE(substepped.u_peak_m.allFinite());
  const CellResult fine = RunCell(TestMesh(), {3e3, 0.45, 1e-4, "default", Guard::kRefuse});
  REQUIRE(OutcomeName(fine.outcome) == "stable");
  const double difference_mm = (substepped.u_peak_m - fine.u_peak_m).cwiseAbs().maxCoeff() * 1e3;
  CHECK(difference_mm <= 0.01 * fine.max_prescribed_mm);
}

// Central differences converge as dt^2: a stable cell's state at peak
// contraction and at the cycle's end match a run at half the step.
TEST_CASE("eval stability: a stable cell matches a run at half the step", "[integration]") {
  const CellResult coarse = RunCell(TestMesh(), {3e3, 0.45, 4e-4, "extreme", Guard::kRefuse});
  const CellResult half = RunCell(TestMesh(), {3e3, 0.45, 2e-4, "extreme", Guard::kRefuse});
  REQUIRE(OutcomeName(coarse.outcome) == "stable");
  REQUIRE(OutcomeName(half.outcome) == "stable");
  REQUIRE(coarse.u_peak_m.allFinite());
  const double peak_mm = half.u_peak_m.colwise().norm().maxCoeff() * 1e3;
  CHECK(peak_mm > 1.0);  // the motion really moved it
  CHECK((coarse.u_peak_m - half.u_peak_m).cwiseAbs().maxCoeff() * 1e3 <= 0.01 * peak_mm);
  CHECK((coarse.u_final_m - half.u_final_m).cwiseAbs().maxCoeff() * 1e3 <= 0.01 * peak_mm);
}

// The crushing motion (the map folds over near the top) crushes the cap of a
// stiff tissue: reported as an inversion, by the solver's detector, naming
// element and step, with the state up to it a physical response (free nodes
// near the motion), not a blow-up's.
TEST_CASE("eval stability: an extreme compression reports the inversion", "[integration]") {
  const CellResult crushed = RunCell(TestMesh(), {1e6, 0.45, 5e-5, "crush", Guard::kRefuse});
  REQUIRE(OutcomeName(crushed.outcome) == "inversion");
  CHECK(crushed.detector == "solver");
  CHECK(crushed.substeps == 1);
  CHECK_THAT(crushed.message, Contains("inverted element") && Contains("at element") && Contains("step"));
  CHECK(crushed.simulated_s < 60.0 / 90);  // before the end of the cycle (90 bpm)
  CHECK(crushed.map_deviation_ratio < kMaxMapDeviationRatio);
  CHECK(crushed.u_final_m.size() == 0);  // it never reached the end
}

namespace {

// stability.csv's rows by cell name, split by hand (the message, last, is quoted).
std::map<std::string, std::vector<std::string>> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in);
  std::string line;
  std::getline(in, line);
  CHECK(line.rfind("cell,motion,guard,youngs_modulus_pa,poissons_ratio,dt_ms,outcome,detector,dt_critical_ms,", 0) == 0);
  std::map<std::string, std::vector<std::string>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream stream(line);
    for (std::string field; fields.size() < 20 && std::getline(stream, field, ',');) fields.push_back(field);
    rows[fields.at(0)] = fields;
  }
  return rows;
}

}  // namespace

// The quick grid end to end: every cell ends in exactly one outcome, the one
// the guard's rule and the bisected limit predict, and stability.csv (re-read
// here) says what the results say.
TEST_CASE("eval stability: the quick grid's outcomes and its CSV", "[integration]") {
  const testing::TemporaryFolder folder("dg_eval_stability_quick");
  StabilityOptions options;
  options.quick = true;
  options.tets = kTestTets;
  options.threads = 2;
  options.progress = false;
  options.out_dir = folder.path();
  const StabilityResult result = RunStabilityStudy(options);
  REQUIRE(result.cells.size() == DefaultStabilityGrid(true).Cells().size());
  REQUIRE(result.bisections.size() == 2);
  WriteStabilityReport(result, options.out_dir);

  std::map<std::string, const CellResult*> by_name;
  for (const CellResult& c : result.cells) by_name[c.spec.Name()] = &c;
  for (const CellResult& c : result.cells) {
    INFO(c.spec.Name() << ": " << OutcomeName(c.outcome) << " " << c.message);
    const double safe = sim::DefaultStabilitySafety(c.spec.poissons_ratio) * c.dt_critical_s;
    const bool ran_to_end = c.outcome == CellOutcome::kStable || c.outcome == CellOutcome::kSubstepped;
    CHECK(ran_to_end == c.message.empty());
    if (ran_to_end) {
      CHECK(c.u_final_m.allFinite());
      CHECK(c.final_ratio <= kMaxFinalRatio);
    }
    switch (c.spec.guard) {
      case Guard::kRefuse:  // refused exactly when above the safe step
        CHECK((c.outcome == CellOutcome::kRefused) == (c.spec.dt_s > safe));
        break;
      case Guard::kSubstep:  // the fewest safe substeps; never refused
        CHECK(c.outcome != CellOutcome::kRefused);
        CHECK(c.substeps == std::max(1, static_cast<int>(std::ceil(c.spec.dt_s / safe))));
        CHECK((c.outcome == CellOutcome::kSubstepped) == (ran_to_end && c.substeps > 1));
        break;
      case Guard::kOff:  // well above the (bisected, about dt_cr) limit: a blow-up, reported as one
        if (c.spec.dt_s > 1.1 * c.dt_critical_s) CHECK(c.outcome == CellOutcome::kBlowUp);
        CHECK(c.outcome != CellOutcome::kRefused);
        CHECK(c.outcome != CellOutcome::kSubstepped);
        break;
    }
    // Below the safe step every guard lets the same run through.
    if (c.spec.dt_s <= safe && c.spec.guard != Guard::kRefuse) {
      CellSpec refuse = c.spec;
      refuse.guard = Guard::kRefuse;
      CHECK(by_name.at(refuse.Name())->outcome == c.outcome);
    }
  }

  const auto rows = ReadCsv(options.out_dir + "/stability.csv");
  REQUIRE(rows.size() == result.cells.size());
  for (const CellResult& c : result.cells) {
    const std::vector<std::string>& row = rows.at(c.spec.Name());
    CHECK(row[6] == OutcomeName(c.outcome));
    CHECK(std::stod(row[3]) == Approx(c.spec.youngs_modulus_pa));
    CHECK(std::stod(row[4]) == Approx(c.spec.poissons_ratio));
    CHECK(std::stod(row[5]) == Approx(c.spec.dt_s * 1e3));
    CHECK(std::stod(row[8]) == Approx(c.dt_critical_s * 1e3));
    CHECK(std::stoi(row[10]) == c.substeps);
    CHECK(std::stoll(row[11]) == c.internal_steps);
  }
  CHECK(fs::file_size(options.out_dir + "/stability_heatmap.png") > 1000);

  // --from-logs: the same results from the logs alone.
  const StabilityResult reread = ReadStabilityLogs(options.out_dir);
  REQUIRE(reread.cells.size() == result.cells.size());
  for (size_t k = 0; k < reread.cells.size(); ++k) {
    CHECK(reread.cells[k].spec.Name() == result.cells[k].spec.Name());
    CHECK(reread.cells[k].outcome == result.cells[k].outcome);
  }
}

}  // namespace dg::tools
