#include "octo_slice_mapper/held_out_score.h"

#include <gtest/gtest.h>

namespace octo_slice_mapper {
namespace {

// A 40 x 20 grid of 0.05 m cells from (0, 0), all free, with one column of cells `wall_value` at x index 20.
GridImage corridor(std::int8_t wall_value, std::int8_t floor_value = 0) {
  GridImage g;
  g.width = 40, g.height = 20, g.resolution = 0.05;
  g.cells.assign(std::size_t(g.width) * g.height, floor_value);
  for (int j = 0; j < g.height; ++j) g.cells[std::size_t(j) * g.width + 20] = wall_value;
  return g;
}

Scan oneBeam(double x, double y, double yaw, float range) {
  Scan s;
  s.sensor_pose = Eigen::Translation3d(x, y, 0.26) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ());
  s.angle_min = 0.0f;
  s.angle_increment = 0.01f;
  s.range_min = 0.0f;
  s.range_max = 80.0f;
  s.ranges = {range};
  return s;
}

TEST(TrinaryOf, AppliesMapServersThresholdsToTheWrittenPixels) {
  GridImage g;
  g.width = 6, g.height = 1;
  g.cells = {-1, 19, 20, 65, 66, 100};
  const GridImage t = trinaryOf(g);
  const std::vector<std::int8_t> expected = {-1, 0, -1, -1, 100, 100};
  EXPECT_EQ(t.cells, expected);
}

TEST(ScoreHeldOut, ExpectsTheMiddleOfTheFirstOccupiedCellsChord) {
  // Laser at x = 0.125 (middle of cell 2), wall cell 20 spans x = 1.00 .. 1.05: expected 0.9 m.
  const GridImage map = corridor(100);
  const HeldOutScore exact = scoreHeldOut(map, {oneBeam(0.125, 0.5, 0.0, 0.9f)});
  EXPECT_EQ(exact.beams, 1u);
  EXPECT_NEAR(exact.mean_abs_error, 0.0, 1e-6);  // 0.9f
  EXPECT_DOUBLE_EQ(exact.within_10cm, 1.0);
  const HeldOutScore off = scoreHeldOut(map, {oneBeam(0.125, 0.5, 0.0, 1.2f)});
  EXPECT_NEAR(off.mean_abs_error, 0.3, 1e-6);
  EXPECT_DOUBLE_EQ(off.within_10cm, 0.0);
  EXPECT_DOUBLE_EQ(off.too_short, 1.0);
}

TEST(ScoreHeldOut, UnknownCellsDoNotStopARayAndLeavingTheMapIsTheRangeLimit) {
  // The wall is unknown: the ray leaves the 2 m wide map, which counts as the 30 m limit.
  const HeldOutScore s = scoreHeldOut(corridor(-1), {oneBeam(0.125, 0.5, 0.0, 0.9f)});
  EXPECT_NEAR(s.mean_abs_error, 30.0 - 0.9, 1e-6);
  EXPECT_DOUBLE_EQ(s.too_long, 1.0);
  EXPECT_DOUBLE_EQ(s.unknown_first, 1.0);
  // A reading beyond the limit is cut at it.
  const HeldOutScore far = scoreHeldOut(corridor(-1), {oneBeam(0.125, 0.5, 0.0, 45.0f)});
  EXPECT_NEAR(far.mean_abs_error, 0.0, 1e-6);
}

TEST(ScoreHeldOut, SkipsNoReturnsAndInvalidReadings) {
  Scan s = oneBeam(0.125, 0.5, 0.0, 0.9f);
  s.ranges = {0.9f, 80.0f, 0.0f, std::numeric_limits<float>::quiet_NaN()};
  const HeldOutScore score = scoreHeldOut(corridor(100), {s});
  EXPECT_EQ(score.beams, 1u);
  EXPECT_EQ(score.skipped, 3u);
}

TEST(HoldOut, TakesEveryNthScanFromTheFirst) {
  const HoldOut h{10, 5};
  EXPECT_FALSE(h.holds(4));
  EXPECT_TRUE(h.holds(5));
  EXPECT_FALSE(h.holds(6));
  EXPECT_TRUE(h.holds(15));
  EXPECT_FALSE(HoldOut{}.holds(5));
}

}  // namespace
}  // namespace octo_slice_mapper
