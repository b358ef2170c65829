#include "tools/phantom/beat_options.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

namespace dg::tools::phantom {

void BeatOptions::ApplyTo(PhantomSpec* spec) const {
  if (period_variation >= 0) spec->period_variation = period_variation;
  if (amplitude_variation >= 0) spec->amplitude_variation = amplitude_variation;
  if (premature_beat_every >= 0) spec->premature_beat_every = premature_beat_every;
}

std::string BeatOptions::Tag() const {
  std::string tag;
  if (period_variation >= 0) tag += fmt::format("-pv{:g}", period_variation);
  if (amplitude_variation >= 0) tag += fmt::format("-av{:g}", amplitude_variation);
  if (premature_beat_every >= 0) tag += fmt::format("-pb{}", premature_beat_every);
  return tag;
}

void AddBeatOptions(CLI::App* command, BeatOptions* beat) {
  command
      ->add_option("--period-variation", beat->period_variation,
                   "Standard deviation of each cycle's period, a fraction of the period (preset: 0.04)")
      ->check(CLI::Range(0.0, 0.3));
  command
      ->add_option("--amplitude-variation", beat->amplitude_variation,
                   "Standard deviation of each cycle's amplitude, a fraction (preset: 0.06)")
      ->check(CLI::Range(0.0, 0.3));
  command->add_option("--premature-beat-every", beat->premature_beat_every,
                      "An early beat (65% of the period, then a compensatory pause) every N cycles; 0: none "
                      "(preset: 0)")
      ->check(CLI::NonNegativeNumber);
}

}  // namespace dg::tools::phantom
