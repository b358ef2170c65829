#pragma once

namespace CLI {
class App;
}

namespace dg::pipeline {
struct OverlayQuality;
}

namespace dg::tools {

// --supersample, --volume-divisor and --volume-slice-mm into *quality, with
// its values as the defaults shown: `run` and `bench overlay` take the same
// options, so a benchmark times the drawings a run makes.
void AddOverlayQualityOptions(CLI::App* command, pipeline::OverlayQuality* quality);

}  // namespace dg::tools
