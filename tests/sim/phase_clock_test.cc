// The motion's phase clock (sim/phase_clock.h): the unsteered line, and
// steering that keeps every earlier step's phase, stays continuous, meets
// its target and runs on at the new rate.
#include "sim/phase_clock.h"

#include <catch2/catch.hpp>

namespace dg::sim {
namespace {

TEST_CASE("phase clock: steering keeps the past and meets the target", "[unit]") {
  const double rate = 2e-4 / 0.667;  // one 0.667 s cycle at 0.2 ms steps
  PhaseClock clock(0.3, rate);
  CHECK(clock.PhaseAt(1000) == Approx(0.3 + 1000 * rate).epsilon(1e-15));
  CHECK(clock.PhaseAt(-1) == Approx(0.3 - rate).epsilon(1e-15));

  const double before = clock.PhaseAt(1200);
  // The estimate: phase 0.05 (wrapped) at step 2000 and a rate 10% faster.
  clock.Steer(1200, 2000, 0.05, 1.1 * rate);
  CHECK(clock.PhaseAt(1200) == before);                            // the past is kept
  CHECK(clock.PhaseAt(1100) == Approx(0.3 + 1100 * rate).epsilon(1e-15));
  CHECK(clock.PhaseAt(2000) == Approx(1.05).epsilon(1e-15));        // the cycle nearest the unsteered 0.9
  CHECK(clock.PhaseAt(2500) == Approx(1.05 + 500 * 1.1 * rate).epsilon(1e-15));
  CHECK(clock.PhaseAt(1600) == Approx((before + 1.05) / 2).epsilon(1e-12));  // linear in between

  // Steering again before the last target replaces what was not reached.
  const double at_1500 = clock.PhaseAt(1500);
  clock.Steer(1500, 1800, 0.0, rate);
  CHECK(clock.PhaseAt(1500) == at_1500);
  CHECK(clock.PhaseAt(1800) == Approx(1.0).epsilon(1e-15));
  CHECK(clock.PhaseAt(1200) == before);
  // Many steerings: old knots drop out and the recent past stays.
  for (long long step = 1800; step < 20000; step += 167) {
    const double kept = clock.PhaseAt(step);
    clock.Steer(step, step + 167, clock.PhaseAt(step + 167) + 1e-3, rate);
    CHECK(clock.PhaseAt(step) == kept);
  }
}

}  // namespace
}  // namespace dg::sim
