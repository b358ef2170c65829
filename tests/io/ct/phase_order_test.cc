// The rule that orders a 4D CT's series into a cycle and finds a missing phase,
// on tags written here by hand.
#include "io/ct/phase_order.h"

#include <cmath>

#include <catch2/catch.hpp>

namespace dg::io {
namespace {

using Catch::Matchers::Contains;
using Catch::Matchers::WithinAbs;

std::vector<PhaseTags> ByPercentage(const std::vector<double>& percentages) {
  std::vector<PhaseTags> phases;
  for (double p : percentages) {
    PhaseTags tags;
    tags.where = "series at " + std::to_string(p);
    tags.series_uid = "1.2." + std::to_string(phases.size() + 1);
    tags.nominal_percentage = p;
    phases.push_back(tags);
  }
  return phases;
}

TEST_CASE("phase order: series are sorted by their cardiac percentage, which gives the cycle fraction", "[unit]") {
  const PhaseOrder order = OrderPhases(ByPercentage({40, 0, 80, 20, 60}), false, true, "folder");
  REQUIRE(order.key == PhaseKey::kNominalPercentage);
  REQUIRE(order.order == std::vector<int>{1, 3, 0, 4, 2});
  REQUIRE_THAT(order.cycle_fraction[2], WithinAbs(0.4, 1e-12));
}

TEST_CASE("phase order: the first tag every series carries wins; temporal positions give (t - 1) / N", "[unit]") {
  std::vector<PhaseTags> phases(3);
  for (int i = 0; i < 3; ++i) {
    phases[i].temporal_position = 3 - i;
    phases[i].temporal_positions = 3;
    phases[i].trigger_time_ms = 100.0 * i;  // disagrees: must not be used
  }
  phases[0].description = "CT 66%";
  phases[1].nominal_percentage = 33;  // only one carries it: not common
  for (PhaseTags& p : phases) p.description_percentage = DescriptionPercentage(p.description);
  const PhaseOrder order = OrderPhases(phases, false, true, "folder");
  REQUIRE(order.key == PhaseKey::kTemporalPosition);
  REQUIRE(order.order == std::vector<int>{2, 1, 0});
  REQUIRE_THAT(order.cycle_fraction[1], WithinAbs(1.0 / 3, 1e-12));
  REQUIRE_THAT(DescriptionPercentage("Cardiac 72.5 % phase"), WithinAbs(72.5, 0));
  REQUIRE(std::isnan(DescriptionPercentage("no percentage")));
}

TEST_CASE("phase order: a missing phase is named, inside the cycle or where it wraps round", "[unit]") {
  std::vector<PhaseTags> positions;
  for (int t : {1, 2, 3, 4, 5, 6, 8, 9, 10}) {
    PhaseTags tags;
    tags.temporal_position = t;
    positions.push_back(tags);
  }
  REQUIRE_THROWS_WITH(OrderPhases(positions, false, true, "folder"),
                      Contains("temporal position 7 of 1..10 is absent") && Contains("folder"));
  for (PhaseTags& tags : positions) tags.temporal_positions = 11;
  positions.erase(positions.begin() + 6);  // 8 absent too
  REQUIRE_THROWS_WITH(OrderPhases(positions, false, true, "folder"), Contains("temporal position 7, 8, 11 of 1..11"));

  REQUIRE_THROWS_WITH(OrderPhases(ByPercentage({0, 10, 20, 30, 50, 60, 70, 80, 90}), false, true, "f"), Contains("but for 40%"));
  REQUIRE_THROWS_WITH(OrderPhases(ByPercentage({0, 10, 20, 30, 40, 50, 60, 70, 80}), false, true, "f"), Contains("but for 90%"));
  // Rounded percentages are even steps; unevenly spaced ones are taken as they are.
  REQUIRE_NOTHROW(OrderPhases(ByPercentage({0, 33, 67}), false, true, "f"));
  REQUIRE_NOTHROW(OrderPhases(ByPercentage({0, 35, 45, 70}), false, true, "f"));
}

TEST_CASE("phase order: two series at one phase, untagged series and an order given against the tags are errors",
          "[unit]") {
  REQUIRE_THROWS_WITH(OrderPhases(ByPercentage({0, 50, 50}), false, true, "f"),
                      Contains("two series are at the same phase (50%)") && Contains("1.2.2") && Contains("1.2.3"));
  std::vector<PhaseTags> untagged = ByPercentage({0, 50});
  untagged[1].nominal_percentage = PhaseTags::kNone;
  REQUIRE_THROWS_WITH(OrderPhases(untagged, false, true, "f"),
                      Contains("cannot be ordered") && Contains("1.2.1") && Contains("no phase tag"));
  // Given in order (folders or files), untagged phases keep it.
  REQUIRE(OrderPhases(untagged, true, true, "f").order == std::vector<int>{0, 1});
  REQUIRE_THROWS_WITH(OrderPhases(ByPercentage({0, 50, 25, 75}), true, true, "f"),
                      Contains("out of cycle order") && Contains("(50%) comes before") && Contains("(25%)"));
}

}  // namespace
}  // namespace dg::io
