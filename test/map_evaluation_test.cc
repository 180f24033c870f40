#include "core/internal/map_evaluation.h"

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
