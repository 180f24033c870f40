// A voxel's log-odds as the slice shows it, in percent: lround(100 * octomap::probability(l)),
// without the exp() (with the lround, a large share of a tilted scan's slice update).
//
// The percent steps up at 100 log-odds, never closer than 0.04 apart; a table of 1 025 buckets of
// 1/64 each holds each bucket's percent at its lower end and the float at which it steps up (if
// it does inside the bucket). Both are found once, by bisection over the floats themselves
// with the exact function, so the table gives the exact function's answer for every float (it
// relies on the exact function being monotonic, as the slice's comparing log-odds already does;
// occupancy_percent_test checks every float near every step and bucket edge, and a sample of all).
#pragma once

#include <cstdint>

namespace octo_slice_mapper {

class OccupancyPercent {
 public:
  // For a finite log-odds (a known voxel's).
  static std::int8_t of(float log_odds) { return table().lookup(log_odds); }
  // The function the table stands for.
  static std::int8_t exact(float log_odds);
  // The table itself, for loops that look up many values (of() finds it per call).
  static const OccupancyPercent& table();
  std::int8_t lookup(float log_odds) const {
    if (!(log_odds > -kRange)) return below_;
    if (!(log_odds < kRange)) return above_;
    const int b = bucketOf(log_odds);
    return static_cast<std::int8_t>(base_[b] + (log_odds >= step_[b]));
  }

 private:
  static constexpr float kRange = 8.0f;       // beyond +-8 the percent is 0 or 100
  static constexpr float kPerUnit = 64.0f;    // buckets per unit of log-odds (steps are >= 0.04 apart)
  static constexpr int kBuckets = 1025;       // 16 * 64, and one for l + 8 rounding up to 16
  OccupancyPercent();
  static int bucketOf(float log_odds) { return static_cast<int>((log_odds + kRange) * kPerUnit); }
  std::int8_t below_, above_;
  std::int8_t base_[kBuckets];
  float step_[kBuckets];  // where the bucket's percent becomes base_ + 1 (+inf: not in it)
};

}  // namespace octo_slice_mapper
