// A one-line progress bar on stderr for long tool runs; silent when stderr is not a terminal
// (logs and pipes get no carriage-return clutter).
#pragma once

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

namespace octo_slice_mapper {
namespace tools {

class ProgressBar {
 public:
  explicit ProgressBar(bool enabled = ::isatty(STDERR_FILENO) != 0) : enabled_(enabled) {}
  ~ProgressBar() { finish(); }

  // Redraws at most every 100 ms, or at once when the stage changes.
  void update(const std::string& stage, double fraction) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    if (stage == stage_ && now - last_ < std::chrono::milliseconds(100)) return;
    if (stage != stage_ && !stage_.empty()) draw(1.0);  // close the previous stage at 100 %
    if (stage != stage_ && !stage_.empty()) std::fputc('\n', stderr);
    if (stage != stage_) started_ = now;
    stage_ = stage;
    last_ = now;
    draw(fraction);
  }
  void finish() {
    if (!enabled_ || stage_.empty()) return;
    draw(1.0);
    std::fputc('\n', stderr);
    stage_.clear();
  }

 private:
  void draw(double fraction) {
    fraction = fraction < 0 ? 0 : fraction > 1 ? 1 : fraction;
    const int width = 30, filled = static_cast<int>(fraction * width + 0.5);
    const double seconds = std::chrono::duration<double>(last_ - started_).count();
    std::fprintf(stderr, "\r%-24.24s [%s%s] %5.1f%% %6.1fs", stage_.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), 100.0 * fraction, seconds);
    std::fflush(stderr);
  }

  bool enabled_;
  std::string stage_;
  std::chrono::steady_clock::time_point started_{}, last_{};
};

}  // namespace tools
}  // namespace octo_slice_mapper
