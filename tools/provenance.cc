#include "tools/provenance.h"

#include <cstdlib>
#include <ctime>

#include "build_commit.h"

namespace dg::tools {
namespace {

struct LoadAverage {
  double value[3] = {0, 0, 0};
  LoadAverage() { getloadavg(value, 3); }
};

// Taken when the process starts, before any benchmark loads the machine.
const LoadAverage kLoadAtStart;

}  // namespace

RunProvenance ReadRunProvenance() {
  RunProvenance provenance;
  provenance.commit = DG_BUILD_COMMIT;
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  provenance.date = date;
  const LoadAverage load_now;
  for (int i = 0; i < 3; ++i) {
    provenance.load_at_start[i] = kLoadAtStart.value[i];
    provenance.load_now[i] = load_now.value[i];
  }
  return provenance;
}

}  // namespace dg::tools
