#include "pipeline/stop_request.h"

#include <unistd.h>

#include <atomic>
#include <csignal>

namespace dg::pipeline {
namespace {

// Written only by the handler; a lock-free atomic is async-signal-safe (C++17 [support.signal]).
std::atomic<int> stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);

constexpr char kStopping[] = "dynaguide: stopping after the work in flight (signal again to quit at once)\n";

// Async-signal-safe: an atomic exchange, write(2), sigaction(2) and raise(3) only.
extern "C" void OnStopSignal(int signal) {
  if (stop_signal.exchange(signal) == 0) {
    const ssize_t ignored = ::write(STDERR_FILENO, kStopping, sizeof kStopping - 1);
    (void)ignored;  // nothing to do if stderr is gone
    return;
  }
  // The second signal: the default action (terminate), so the process ends by that signal. It is
  // blocked while its handler runs: the raised one is delivered as this handler returns.
  struct sigaction default_action {};
  default_action.sa_handler = SIG_DFL;
  sigemptyset(&default_action.sa_mask);
  ::sigaction(signal, &default_action, nullptr);
  ::raise(signal);
}

}  // namespace

void InstallStopOnSignals() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  // One handler at a time: a SIGTERM during the SIGINT handler waits for it to return.
  sigemptyset(&action.sa_mask);
  sigaddset(&action.sa_mask, SIGINT);
  sigaddset(&action.sa_mask, SIGTERM);
  // Restart interrupted reads and writes: the work goes on after the first signal.
  action.sa_flags = SA_RESTART;
  // sigaction fails only for an invalid signal or handler: a bug, not bad input.
  for (const int signal : {SIGINT, SIGTERM}) DG_CHECK(::sigaction(signal, &action, nullptr) == 0);
}

int StopSignal() { return stop_signal.load(std::memory_order_relaxed); }

std::string SignalName(int signal) {
  if (signal == SIGINT) return "SIGINT";
  if (signal == SIGTERM) return "SIGTERM";
  return "signal " + std::to_string(signal);
}

}  // namespace dg::pipeline
