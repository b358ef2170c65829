#include "sim/progress.h"

#include <unistd.h>

#include <cstdio>

namespace dg {

Progress::Progress(std::string label, double total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      terminal_(isatty(fileno(stderr)) != 0),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

void Progress::Update(double done, const std::string& detail) {
  if (!enabled_ || total_ <= 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double fraction = done / total_;
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  const double eta_s = fraction > 0 ? elapsed_s * (1 - fraction) / fraction : 0;
  if (terminal_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && fraction < 1) return;
    last_draw_ = now;
    std::fprintf(stderr, "\r%s %5.1f%%  %s  ETA %.1f s   ", label_.c_str(), 100 * fraction, detail.c_str(), eta_s);
    std::fflush(stderr);
  } else {
    const int tenth = static_cast<int>(fraction * 10);
    if (tenth == last_tenth_) return;
    last_tenth_ = tenth;
    std::fprintf(stderr, "%s %3d%%  %s  ETA %.1f s\n", label_.c_str(), tenth * 10, detail.c_str(), eta_s);
  }
}

void Progress::Finish() {
  if (enabled_ && terminal_) std::fprintf(stderr, "\n");
}

}  // namespace dg
