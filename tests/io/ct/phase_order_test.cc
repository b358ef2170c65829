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

TEST_CASE("phase order: respiratory percentages, trigger delays and percentages in names order the phases",
          "[unit]") {
  std::vector<PhaseTags> phases(4);
  for (int i = 0; i < 4; ++i) {
    phases[i].where = "/data/4dct/ct_" + std::to_string(25 * ((i + 2) % 4)) + "%.nii.gz";
    phases[i].name_percentage = NamePercentage(phases[i].where);
    phases[i].respiratory_delay_ms = 1000.0 * ((i + 1) % 4);  // 1000, 2000, 3000, 0
    phases[i].respiratory_interval_ms = 4000;
  }
  // The delays (with the breath's interval) before the names.
  PhaseOrder order = OrderPhases(phases, false, true, "f");
  REQUIRE(order.key == PhaseKey::kRespiratoryDelay);
  REQUIRE(order.order == std::vector<int>{3, 0, 1, 2});
  REQUIRE_THAT(order.cycle_fraction[1], WithinAbs(0.25, 1e-12));
  // The names alone: 50, 75, 0, 25%.
  for (PhaseTags& p : phases) p.respiratory_delay_ms = PhaseTags::kNone;
  order = OrderPhases(phases, false, true, "f");
  REQUIRE(order.key == PhaseKey::kNamePercentage);
  REQUIRE(order.order == std::vector<int>{2, 3, 0, 1});
  REQUIRE_THAT(order.cycle_fraction[3], WithinAbs(0.75, 1e-12));
  // NominalPercentageOfRespiratoryPhase before the description's percentage and the temporal position.
  for (int i = 0; i < 4; ++i) {
    phases[i].respiratory_percentage = 25.0 * (3 - i);
    phases[i].description_percentage = 10.0 * i;
    phases[i].temporal_position = i + 1;
  }
  order = OrderPhases(phases, false, true, "f");
  REQUIRE(order.key == PhaseKey::kRespiratoryPercentage);
  REQUIRE(order.order == std::vector<int>{3, 2, 1, 0});
  REQUIRE_THAT(phases[0].Describe(), Contains("respiratory 75%"));
  // A missing breathing phase is named as a cardiac one is.
  phases.erase(phases.begin() + 1);
  REQUIRE_THROWS_WITH(OrderPhases(phases, false, true, "f"), Contains("but for 50%"));
}

TEST_CASE("phase order: percentages as 4D CT exports write them in descriptions and names", "[unit]") {
  REQUIRE_THAT(DescriptionPercentage("Gated 50%"), WithinAbs(50, 0));
  REQUIRE_THAT(DescriptionPercentage("4DCT T=30%"), WithinAbs(30, 0));
  REQUIRE_THAT(DescriptionPercentage("Resp 12.5 %"), WithinAbs(12.5, 0));
  REQUIRE_THAT(NamePercentage("/scans/phase 40%/"), WithinAbs(40, 0));
  REQUIRE_THAT(NamePercentage("/scans/50%/ct_T=70%.nii.gz"), WithinAbs(70, 0));
  REQUIRE(std::isnan(NamePercentage("/scans/50%/ct_70.nii.gz")));  // the folder's name is not the file's
}

}  // namespace
}  // namespace dg::io
