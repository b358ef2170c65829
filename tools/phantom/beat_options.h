#pragma once

#include <string>

#include "tools/phantom/phantom_spec.h"

namespace CLI {
class App;
}

namespace dg::tools::phantom {

// The phantom's beat as command-line knobs (`dynaguide phantom`, and
// `dynaguide eval protocol` for the phantoms it makes from seeds): each one
// left unset keeps the preset's value.
struct BeatOptions {
  double period_variation = -1;     // SD of each cycle's period factor
  double amplitude_variation = -1;  // SD of each cycle's amplitude factor
  int premature_beat_every = -1;    // an early beat every N cycles, 0 for none

  bool any() const { return period_variation >= 0 || amplitude_variation >= 0 || premature_beat_every >= 0; }
  // Sets the fields given; the spec's Validate() judges their values.
  void ApplyTo(PhantomSpec* spec) const;
  // A name part that tells phantoms of different beats apart ("" when none is set).
  std::string Tag() const;
};

// --period-variation, --amplitude-variation and --premature-beat-every.
void AddBeatOptions(CLI::App* command, BeatOptions* beat);

}  // namespace dg::tools::phantom
