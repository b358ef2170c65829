#include "sim/statistics.h"

#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include "sim/error.h"

namespace dg::sim {
namespace {

// Expected values worked by hand from p = q (n - 1) on the sorted values
// (NumPy's np.quantile gives the same).
TEST_CASE("quantile: odd count, sorted {1, 1, 3, 4, 5}", "[sim][unit]") {
  const std::vector<double> values{3, 1, 4, 1, 5};
  CHECK(Quantile(values, 0) == 1);
  CHECK(Quantile(values, 0.5) == 3);     // p = 2: the middle value
  CHECK(Quantile(values, 0.95) == Approx(4.8).epsilon(1e-15));  // p = 3.8: 4 + 0.8 (5 - 4)
  CHECK(Quantile(values, 1) == 5);
  CHECK(Median(values) == 3);
  CHECK(values == std::vector<double>{3, 1, 4, 1, 5});  // not reordered
}

TEST_CASE("quantile: even count, sorted {2, 4, 7, 10}", "[sim][unit]") {
  const std::vector<double> values{7, 2, 10, 4};
  CHECK(Quantile(values, 0) == 2);
  CHECK(Quantile(values, 0.5) == 5.5);   // p = 1.5: the mean of the two middle values
  CHECK(Quantile(values, 0.95) == Approx(9.55).epsilon(1e-15));  // p = 2.85: 7 + 0.85 (10 - 7)
  CHECK(Quantile(values, 1) == 10);
  CHECK(Median(values) == 5.5);
}

TEST_CASE("quantile: one value is every quantile, none gives 0", "[sim][unit]") {
  const std::vector<double> one{2.5};
  for (double q : {0.0, 0.5, 0.95, 1.0}) CHECK(Quantile(one, q) == 2.5);
  CHECK(Quantile({}, 0.5) == 0);
  CHECK(Median({}) == 0);
}

TEST_CASE("quantile: q outside [0, 1] is an error", "[sim][unit]") {
  const std::vector<double> values{1, 2};
  CHECK_THROWS_AS(Quantile(values, -0.1), Error);
  CHECK_THROWS_AS(Quantile(values, 1.5), Error);
  CHECK_THROWS_AS(Quantile(values, std::nan("")), Error);
}

}  // namespace
}  // namespace dg::sim
