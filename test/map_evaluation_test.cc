#include "octo_slice_mapper/map_evaluation.h"

#include <gtest/gtest.h>

using namespace octo_slice_mapper;

namespace {
GridImage blank(int w, int h, std::int8_t value) {
  GridImage g;
  g.width = w;
  g.height = h;
  g.resolution = 0.1;
  g.cells.assign(std::size_t(w) * h, value);
  return g;
}
void set(GridImage* g, int i, int j, std::int8_t v) { g->cells[std::size_t(j) * g->width + i] = v; }
}  // namespace

TEST(ScoreOccupancy, PerfectAndShiftedMaps) {
  GridImage truth = blank(20, 20, 0);
  for (int i = 0; i < 20; ++i) set(&truth, i, 10, 100);
  GridImage map = blank(20, 20, 0);
  for (int i = 0; i < 20; ++i) set(&map, i, 11, 100);  // one cell off: within tolerance
  auto s = scoreOccupancy(map, truth, 1);
  EXPECT_DOUBLE_EQ(s.precision, 1.0);
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
  s = scoreOccupancy(map, truth, 0);
  EXPECT_DOUBLE_EQ(s.precision, 0.0);
  EXPECT_DOUBLE_EQ(s.recall, 0.0);
}

TEST(ScoreOccupancy, FalsePositivesAndMissesCount) {
  GridImage truth = blank(20, 20, 0);
  for (int i = 0; i < 20; ++i) set(&truth, i, 10, 100);
  GridImage map = blank(20, 20, -1);
  for (int i = 0; i < 10; ++i) set(&map, i, 10, 100);  // half the wall seen occupied
  for (int i = 10; i < 20; ++i) set(&map, i, 10, 0);   // other half seen free (a miss)
  for (int i = 0; i < 10; ++i) set(&map, i, 2, 100);   // 10 false positives
  const auto s = scoreOccupancy(map, truth, 0);
  EXPECT_DOUBLE_EQ(s.precision, 0.5);
  EXPECT_DOUBLE_EQ(s.recall, 0.5);
  EXPECT_EQ(s.truth_observed, 20u);
}

TEST(ScoreOccupancy, UnobservedWallsAreNotHeldAgainstTheMap) {
  GridImage truth = blank(20, 20, 0);
  for (int i = 0; i < 20; ++i) set(&truth, i, 10, 100);
  GridImage map = blank(20, 20, -1);
  for (int i = 0; i < 5; ++i) set(&map, i, 10, 100);
  const auto s = scoreOccupancy(map, truth, 0);
  EXPECT_EQ(s.truth_observed, 5u);
  EXPECT_DOUBLE_EQ(s.recall, 1.0);
}

TEST(PredictRanges, CastsToTheFirstOccupiedCell) {
  GridImage map = blank(40, 40, 0);  // 4 m x 4 m of free space, 0.1 m cells
  for (int j = 0; j < 40; ++j) set(&map, 20, j, 100);  // a wall filling x in [2.0, 2.1)
  Scan scan;
  scan.sensor_pose.translation() = Eigen::Vector3d(0.55, 0.55, 0.26);
  scan.angle_min = 0.0f;
  scan.angle_increment = static_cast<float>(M_PI / 2);
  scan.range_min = 0.02f;
  scan.range_max = 3.0f;
  // Beam 0 (+x) reads the wall exactly (1.45 m); beam 1 (+y) sees nothing in the map but reads 1.0;
  // beam 2 (-x) is a no-return and is not scored.
  scan.ranges = {1.45f, 1.0f, 3.0f};
  RangePredictionError e = predictRanges(map, {scan});
  ASSERT_EQ(e.beams, 2u);
  EXPECT_EQ(e.nothing_hit, 1u);
  EXPECT_NEAR(e.mean_abs_error, 0.5 * (0.0 + (3.0 - 1.0)), 1e-5) << "nothing hit: the cast limit is expected";
  EXPECT_DOUBLE_EQ(e.within_10cm, 0.5);
  // A 0.15 m error along +x is outside 10 cm; a cast limit of 2 m caps the other beam's expectation.
  scan.ranges = {1.60f, 1.0f, 3.0f};
  e = predictRanges(map, {scan}, 2.0);
  EXPECT_NEAR(e.mean_abs_error, 0.5 * (0.15 + 1.0), 1e-5);
  EXPECT_DOUBLE_EQ(e.within_10cm, 0.0);
  // Diagonal: from (0.55, 0.55) at 45 deg the wall starts at x = 2.0: 1.45 * sqrt(2).
  scan.angle_min = static_cast<float>(M_PI / 4);
  scan.ranges = {static_cast<float>(1.45 * std::sqrt(2.0))};
  e = predictRanges(map, {scan});
  EXPECT_LT(e.mean_abs_error, 1e-5);
}
