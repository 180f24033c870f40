#include "core/internal/occupancy_percent.h"

#include <octomap/octomap_utils.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace octo_slice_mapper {
namespace {

// Floats in their order as integers, for bisection over every float between two.
std::int64_t orderOf(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return (u & 0x80000000u) ? -std::int64_t(u & 0x7FFFFFFFu) : std::int64_t(u);
}
float floatAt(std::int64_t order) {
  const std::uint32_t u = order >= 0 ? std::uint32_t(order) : (std::uint32_t(-order) | 0x80000000u);
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

// The first float of [lo, hi] where `yes` holds (yes is false up to some float, true after it), or
// the float after hi when it holds nowhere.
template <typename Yes>
std::int64_t firstWhere(std::int64_t lo, std::int64_t hi, Yes yes) {
  ++hi;  // "nowhere"
  while (lo < hi) {
    const std::int64_t mid = lo + (hi - lo) / 2;
    if (yes(floatAt(mid))) hi = mid;
    else lo = mid + 1;
  }
  return lo;
}

}  // namespace

std::int8_t OccupancyPercent::exact(float log_odds) {
  return static_cast<std::int8_t>(std::lround(octomap::probability(log_odds) * 100.0));
}

OccupancyPercent::OccupancyPercent() {
  const std::int64_t first = orderOf(-kRange) + 1, last = orderOf(kRange) - 1;  // the floats inside (-8, 8)
  below_ = exact(-kRange);
  above_ = exact(kRange);
  // Bucket b's floats: from lo, the first that maps to it, to the one before the next bucket's first.
  std::int64_t lo = first;
  for (int b = 0; b < kBuckets; ++b) {
    const std::int64_t next = firstWhere(lo, last, [b](float l) { return bucketOf(l) >= b + 1; });
    const std::int64_t hi = next - 1;
    step_[b] = std::numeric_limits<float>::infinity();
    base_[b] = 0;
    if (lo <= hi) {  // else no float lands here
      base_[b] = exact(floatAt(lo));
      const int top = exact(floatAt(hi));
      if (top > base_[b] + 1) throw std::logic_error("occupancy percent: a bucket holds two steps");
      if (top == base_[b] + 1) {
        step_[b] = floatAt(firstWhere(lo, hi, [this, b](float l) { return exact(l) > base_[b]; }));
      }
    }
    lo = next;
  }
}

const OccupancyPercent& OccupancyPercent::table() {
  static const OccupancyPercent instance;
  return instance;
}

}  // namespace octo_slice_mapper
