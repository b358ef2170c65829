#pragma once

#include <string>

#include "sim/error.h"

namespace dg::pipeline {

// A stop asked for by SIGINT or SIGTERM, for the long-running commands (`run`,
// `sim`) to end early with their outputs finished rather than lost
// (docs/interrupts.md). The first signal only records itself: the command
// polls StopSignal() where it takes its next unit of work (the graph's source
// before reading a frame, the simulation between output steps), finishes what
// is under way, closes its outputs marked incomplete and throws Interrupted.
// A second signal ends the process at once, by the signal's default action.
//
// Threading: the handler writes one lock-free atomic; StopSignal() may be read
// from any thread. The request is process-wide, as a signal is; a process that
// never calls InstallStopOnSignals() always reads 0.

// Installs the handlers (sigaction) for SIGINT and SIGTERM.
void InstallStopOnSignals();

// The signal that asked the process to stop, or 0 when none has.
int StopSignal();

// "SIGINT", "SIGTERM", or "signal N".
std::string SignalName(int signal);

// A command stopped by a signal after finishing its outputs: main() prints the
// message once and exits with 128 + signal, as a shell reports a process the
// signal ended.
class Interrupted : public Error {
 public:
  // what: e.g. "interrupted by SIGINT at frame 23 (...)"; where: the outputs.
  Interrupted(int signal, std::string what, std::string where, std::string fix)
      : Error(std::move(what), std::move(where), std::move(fix)), signal_(signal) {}
  int signal() const { return signal_; }
  int exit_code() const { return 128 + signal_; }

 private:
  int signal_;
};

}  // namespace dg::pipeline
