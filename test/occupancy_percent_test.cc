// The table gives lround(100 * probability(l)) for every float: checked on every float near each
// step of the percent and near each bucket edge, on a stride through all floats in [-9, 9], and at
// the ends.
#include "core/internal/occupancy_percent.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

using namespace octo_slice_mapper;

namespace {

float nextUp(float f, int n) {
  for (int i = 0; i < n; ++i) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}
float nextDown(float f, int n) {
  for (int i = 0; i < n; ++i) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
// Every float within `ulps` of x.
template <typename Fn>
void around(float x, int ulps, Fn fn) {
  for (float f = nextDown(x, ulps), end = nextUp(x, ulps); f <= end; f = std::nextafter(f, end + 1.0f)) {
    fn(f);
    if (f == end) break;
  }
}

}  // namespace

TEST(OccupancyPercent, EveryFloatNearEachStepAndBucketEdgeGivesTheExactPercent) {
  long checked = 0, wrong = 0;
  const auto check = [&](float l) {
    ++checked;
    if (OccupancyPercent::of(l) != OccupancyPercent::exact(l)) {
      if (++wrong < 5) ADD_FAILURE() << "log-odds " << l << ": " << int(OccupancyPercent::of(l)) << " against "
                                     << int(OccupancyPercent::exact(l));
    }
  };
  // The steps: the percent changes at p = (k - 0.5) / 100, near l = log(p / (1 - p)) (a few floats
  // off at most, by rounding): 300 floats either side of each.
  for (int k = 1; k <= 100; ++k) {
    const double p = (k - 0.5) / 100.0;
    around(static_cast<float>(std::log(p / (1.0 - p))), 300, check);
  }
  // The bucket edges (64 per unit of log-odds from -8) and the range's ends.
  for (int b = 0; b <= 1024; ++b) around(-8.0f + b / 64.0f, 50, check);
  around(0.0f, 1000, check);
  EXPECT_EQ(wrong, 0) << "of " << checked;
  EXPECT_GT(checked, 150000);
}

TEST(OccupancyPercent, AStrideThroughAllFloatsFromMinus9To9GivesTheExactPercent) {
  long checked = 0, wrong = 0;
  std::uint32_t lo_bits, hi_bits;
  const float lo = -9.0f, hi = 9.0f;
  std::memcpy(&lo_bits, &lo, 4);
  std::memcpy(&hi_bits, &hi, 4);
  // Negative floats: bits from 0x80000000 (-0) up to -9's; positive from 0 up to 9's.
  for (std::uint32_t bits = 0x80000000u; bits <= lo_bits; bits += 211) {
    float l;
    std::memcpy(&l, &bits, 4);
    ++checked;
    if (OccupancyPercent::of(l) != OccupancyPercent::exact(l)) ++wrong;
  }
  for (std::uint32_t bits = 0; bits <= hi_bits; bits += 211) {
    float l;
    std::memcpy(&l, &bits, 4);
    ++checked;
    if (OccupancyPercent::of(l) != OccupancyPercent::exact(l)) ++wrong;
  }
  EXPECT_EQ(wrong, 0) << "of " << checked;
  EXPECT_GT(checked, 10000000);
}

TEST(OccupancyPercent, TheEndsAndTheMiddle) {
  EXPECT_EQ(OccupancyPercent::of(0.0f), 50);
  EXPECT_EQ(OccupancyPercent::of(-0.0f), 50);
  EXPECT_EQ(OccupancyPercent::of(-100.0f), 0);
  EXPECT_EQ(OccupancyPercent::of(100.0f), 100);
  EXPECT_EQ(OccupancyPercent::of(-5.806f), OccupancyPercent::exact(-5.806f));  // the free clamp
  EXPECT_EQ(OccupancyPercent::of(5.806f), OccupancyPercent::exact(5.806f));
  EXPECT_EQ(OccupancyPercent::of(std::log(0.75f / 0.25f)), 75);
}
