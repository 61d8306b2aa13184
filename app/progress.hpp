#pragma once
// A progress bar on a terminal (stderr), plain lines every 10% otherwise.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace weft::app {

class Progress {
 public:
  explicit Progress(std::string label, bool enabled = true)
      : label_(std::move(label)), enabled_(enabled), tty_(isatty(2)), start_(std::chrono::steady_clock::now()) {}
  /// Shown only once `seconds` have passed since the start (for work that is usually short).
  Progress& quiet_for(double seconds) {
    quiet_for_ = seconds;
    return *this;
  }
  /// `note` says what is being done now (a set-up stage); shown after the bar.
  void update(double fraction, const std::string& note = "") {
    if (!enabled_) return;
    const int pct = static_cast<int>(fraction * 100 + 1e-9);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    if (elapsed < quiet_for_) return;
    if (!note.empty()) {
      if (tty_) {
        std::fprintf(stderr, "\r%s %3d%%  %.1fs elapsed: %s\033[K", label_.c_str(), pct, elapsed, note.c_str());
        if (fraction >= 1) std::fprintf(stderr, "\n");
        std::fflush(stderr);
      } else {
        std::fprintf(stderr, "%s: %d%% (%.1fs) %s\n", label_.c_str(), pct, elapsed, note.c_str());
      }
      last_ = pct;
      return;
    }
    if (tty_) {
      const int width = 30, filled = static_cast<int>(fraction * width);
      std::string bar(filled, '#');
      bar.resize(width, '.');
      const double eta = fraction > 0 ? elapsed * (1 - fraction) / fraction : 0;
      std::fprintf(stderr, "\r%s [%s] %3d%%  %.1fs elapsed, %.1fs left ", label_.c_str(), bar.c_str(), pct, elapsed, eta);
      if (fraction >= 1) std::fprintf(stderr, "\n");
      std::fflush(stderr);
    } else if (pct / 10 != last_ / 10 || (fraction >= 1 && last_ < 100)) {
      std::fprintf(stderr, "%s: %d%% (%.1fs)\n", label_.c_str(), pct, elapsed);
    }
    last_ = pct;
  }
  void finish() {
    if (enabled_ && tty_ && last_ < 100) std::fprintf(stderr, "\n");
  }

 private:
  std::string label_;
  bool enabled_, tty_;
  int last_ = -1;
  double quiet_for_ = 0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace weft::app
