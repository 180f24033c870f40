#include "octo_slice_mapper/scan.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace octo_slice_mapper;

TEST(ClassifyReading, EachKind) {
  ReadingPolicy policy;
  policy.inf_is_no_return = false;  // +inf invalid, as some older drivers mean it
  EXPECT_EQ(classifyReading(1.0f, 0.1f, 5.0f, policy), ReadingKind::kHit);
  EXPECT_EQ(classifyReading(5.0f, 0.1f, 5.0f, policy), ReadingKind::kNoReturn);
  EXPECT_EQ(classifyReading(81.83f, 0.1f, 5.0f, policy), ReadingKind::kNoReturn);
  EXPECT_EQ(classifyReading(std::nanf(""), 0.1f, 5.0f, policy), ReadingKind::kNaN);
  EXPECT_EQ(classifyReading(std::numeric_limits<float>::infinity(), 0.1f, 5.0f, policy), ReadingKind::kInfinite);
  EXPECT_EQ(classifyReading(-std::numeric_limits<float>::infinity(), 0.1f, 5.0f, policy), ReadingKind::kInfinite);
  EXPECT_EQ(classifyReading(-0.5f, 0.1f, 5.0f, policy), ReadingKind::kNegative);
  EXPECT_EQ(classifyReading(0.0f, 0.1f, 5.0f, policy), ReadingKind::kBelowMin);
  EXPECT_EQ(classifyReading(0.05f, 0.1f, 5.0f, policy), ReadingKind::kBelowMin);
}

// REP 117 by default: +inf is no return, -inf too close (counted, no update), NaN invalid.
TEST(ClassifyReading, Rep117ByDefault) {
  const ReadingPolicy policy;
  EXPECT_EQ(classifyReading(std::numeric_limits<float>::infinity(), 0.1f, 5.0f, policy), ReadingKind::kNoReturn);
  EXPECT_EQ(classifyReading(-std::numeric_limits<float>::infinity(), 0.1f, 5.0f, policy), ReadingKind::kInfinite);
  EXPECT_EQ(classifyReading(std::nanf(""), 0.1f, 5.0f, policy), ReadingKind::kNaN);
}

TEST(ReadingCounts, SkippedCountsOnlyInvalidReadings) {
  ReadingCounts c;
  c[ReadingKind::kHit] = 10;
  c[ReadingKind::kNoReturn] = 3;
  c[ReadingKind::kNaN] = 2;
  c[ReadingKind::kNegative] = 1;
  EXPECT_EQ(c.skipped(), 3u);
  ReadingCounts d = c;
  d += c;
  EXPECT_EQ(d[ReadingKind::kHit], 20u);
  EXPECT_NE(c.summary().find("nan=2"), std::string::npos);
}

TEST(ValidateScanHeader, RejectsStructuralProblems) {
  Scan scan;
  scan.angle_increment = 0.01f;
  scan.range_min = 0.1f;
  scan.range_max = 5.0f;
  EXPECT_FALSE(validateScanHeader(scan).empty()) << "empty scan";
  scan.ranges.assign(10, 1.0f);
  EXPECT_TRUE(validateScanHeader(scan).empty());
  Scan zero_inc = scan;
  zero_inc.angle_increment = 0.0f;
  EXPECT_FALSE(validateScanHeader(zero_inc).empty());
  Scan bad_limits = scan;
  bad_limits.range_max = 0.05f;
  EXPECT_FALSE(validateScanHeader(bad_limits).empty());
  Scan huge = scan;
  huge.ranges.assign(1000000, 1.0f);
  EXPECT_FALSE(validateScanHeader(huge).empty());
  Scan bad_pose = scan;
  bad_pose.sensor_pose.translation().x() = std::nan("");
  EXPECT_FALSE(validateScanHeader(bad_pose).empty());
}

namespace {
// Entry i of the table is exactly what std::cos / std::sin give for beamAngle(i), bit for bit.
void expectExactTable(BeamDirections& directions, const Scan& scan) {
  const std::vector<Eigen::Vector2d>& unit = directions.of(scan);
  ASSERT_EQ(unit.size(), scan.ranges.size());
  for (std::size_t i = 0; i < unit.size(); ++i) {
    const double a = scan.beamAngle(i);
    EXPECT_EQ(std::signbit(unit[i].x()), std::signbit(std::cos(a))) << "beam " << i;
    EXPECT_EQ(std::signbit(unit[i].y()), std::signbit(std::sin(a))) << "beam " << i;
    EXPECT_EQ(unit[i].x(), std::cos(a)) << "beam " << i;
    EXPECT_EQ(unit[i].y(), std::sin(a)) << "beam " << i;
  }
}
}  // namespace

// The table follows the scans' geometry: the same for the same lidar, made anew when the first
// angle (bit for bit: -0 too), the step or the number of beams changes.
TEST(BeamDirections, FollowTheScansGeometryExactly) {
  BeamDirections directions;
  Scan scan;
  scan.angle_min = -2.35619f;
  scan.angle_increment = 0.00436332f;
  scan.ranges.assign(1081, 1.0f);
  expectExactTable(directions, scan);
  expectExactTable(directions, scan);  // kept
  scan.angle_increment = 0.0087f;
  expectExactTable(directions, scan);
  scan.ranges.assign(720, 1.0f);
  expectExactTable(directions, scan);
  scan.angle_min = 0.0f;
  expectExactTable(directions, scan);
  scan.angle_min = -0.0f;
  expectExactTable(directions, scan);
  scan.ranges.clear();
  EXPECT_TRUE(directions.of(scan).empty());
}

TEST(ReadingCounts, FlyingPixelsAreSkippedReadings) {
  ReadingCounts c;
  c[ReadingKind::kHit] = 5;
  c[ReadingKind::kFlyingPixel] = 2;
  c[ReadingKind::kNaN] = 1;
  EXPECT_EQ(c.skipped(), 3u);
  EXPECT_NE(c.summary().find("flying_pixel=2"), std::string::npos);
}
