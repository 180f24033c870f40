// PointCloud2 layouts a sender can get wrong are refused before any byte is read, and
// a well-formed cloud's points come out in the map frame, the non-finite ones left out and counted.
#include "ros/point_cloud_conversion.h"

#include <gtest/gtest.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <cmath>
#include <limits>
#include <cstring>
#include <random>
#include <string>

#include "octo_slice_mapper/internal/flying_pixels.h"

using octo_slice_mapper::ReadingCounts;
using octo_slice_mapper::ReadingKind;
using namespace octo_slice_mapper::ros_adapter;

namespace {

sensor_msgs::PointCloud2 xyzCloud(std::uint32_t width, std::uint32_t height) {
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2FieldsByString(1, "xyz");
  cloud.width = width;
  cloud.height = height;
  cloud.point_step = 16;  // x, y, z and the padding setPointCloud2FieldsByString leaves
  cloud.row_step = width * cloud.point_step;
  cloud.data.assign(std::size_t(cloud.row_step) * height, 0);
  return cloud;
}

}  // namespace

TEST(PointCloudConversion, AWellFormedCloudPassesAndItsPointsReachTheMapFrame) {
  sensor_msgs::PointCloud2 cloud = xyzCloud(2, 2);
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  const float values[4][3] = {{1, 2, 3}, {NAN, 0, 0}, {4, 5, 6}, {0, INFINITY, 0}};
  for (int k = 0; k < 4; ++k, ++x, ++y, ++z) *x = values[k][0], *y = values[k][1], *z = values[k][2];
  ASSERT_FALSE(checkCloudLayout(cloud).rejected());
  Eigen::Isometry3f to_map = Eigen::Isometry3f::Identity();
  to_map.translation() = Eigen::Vector3f(10, 0, 0);
  std::vector<Eigen::Vector3f> points;
  ReadingCounts left_out;
  cloudPointsInMap(cloud, to_map, &points, &left_out);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_TRUE(points[0].isApprox(Eigen::Vector3f(11, 2, 3)));
  EXPECT_TRUE(points[1].isApprox(Eigen::Vector3f(14, 5, 6)));
  EXPECT_EQ(left_out[ReadingKind::kNaN], 1u);
  EXPECT_EQ(left_out[ReadingKind::kInfinite], 1u);
  EXPECT_EQ(left_out.skipped(), 2u);
}

// An organized frame's borders are NaN, -inf or +inf, in runs and alone: whatever their mix, the
// finite points come out in order and every other point is counted once, NaN before inf.
TEST(PointCloudConversion, NonFinitePointsAreLeftOutAndCountedPerReason) {
  const int width = 64, height = 5;
  sensor_msgs::PointCloud2 cloud = xyzCloud(width, height);
  std::mt19937 rng(5);
  std::vector<Eigen::Vector3f> finite;
  std::uint64_t nan = 0, inf = 0;
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  for (int k = 0; k < width * height; ++k, ++x, ++y, ++z) {
    Eigen::Vector3f v(0.01f * k, -0.02f * k, 1.0f);
    const int kind = k < 40 ? 1 : int(rng() % 5);  // a run of NaN first, then mixed
    if (kind == 1) v.x() = NAN, ++nan;
    if (kind == 2) v.z() = -INFINITY, ++inf;
    if (kind == 3) v.y() = INFINITY, v.z() = NAN, ++nan;  // NaN counts before inf
    if (kind == 0 || kind == 4) finite.push_back(v);
    *x = v.x(), *y = v.y(), *z = v.z();
  }
  std::vector<Eigen::Vector3f> points;
  ReadingCounts left_out;
  cloudPointsInMap(cloud, Eigen::Isometry3f::Identity(), &points, &left_out);
  ASSERT_EQ(points.size(), finite.size());
  for (std::size_t k = 0; k < points.size(); ++k) EXPECT_EQ(points[k], finite[k]) << k;
  EXPECT_EQ(left_out[ReadingKind::kNaN], nan);
  EXPECT_EQ(left_out[ReadingKind::kInfinite], inf);
  EXPECT_EQ(left_out.skipped(), nan + inf);
  EXPECT_GT(nan, 40u);
  EXPECT_GT(inf, 20u);
}

// Both transforms (four points at a time for x, y, z in 16 bytes, one at a time for any other
// layout, here 24 bytes) sum as `rotation * v + translation` does, so every point is that one to
// the bit (the map's bytes depend on it: a coordinate rounded the other way moves an .ot's
// log-odds); rows of 643 points end in a partial group of four.
TEST(PointCloudConversion, PointsAreTheRotationAndTranslationToTheBit) {
  for (const std::uint32_t point_step : {16u, 24u}) {
    SCOPED_TRACE("point_step " + std::to_string(point_step));
    const int width = 643, height = 8;
    sensor_msgs::PointCloud2 cloud = xyzCloud(width, height);
    cloud.point_step = point_step;
    cloud.row_step = width * point_step;
    cloud.data.assign(std::size_t(cloud.row_step) * height, 0);
    std::mt19937 rng(23);
    std::uniform_real_distribution<float> coordinate(-6.0f, 6.0f);
    std::vector<Eigen::Vector3f> sensor;
    sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
    for (int k = 0; k < width * height; ++k, ++x, ++y, ++z) {
      Eigen::Vector3f v(coordinate(rng), coordinate(rng), coordinate(rng));
      if (k % 97 == 0) v.y() = NAN;
      sensor.push_back(v);
      *x = v.x(), *y = v.y(), *z = v.z();
    }
    Eigen::Isometry3f to_map = Eigen::Isometry3f::Identity();
    to_map.linear() = Eigen::AngleAxisf(0.7f, Eigen::Vector3f(0.3f, -0.2f, 0.9f).normalized()).toRotationMatrix();
    to_map.translation() = Eigen::Vector3f(1.31f, -0.27f, 0.33f);
    const Eigen::Matrix3f rotation = to_map.linear();
    const Eigen::Vector3f translation = to_map.translation();
    std::vector<Eigen::Vector3f> points;
    ReadingCounts left_out;
    cloudPointsInMap(cloud, to_map, &points, &left_out);
    std::size_t compared = 0;
    for (const Eigen::Vector3f& v : sensor) {
      if (!v.allFinite()) continue;
      ASSERT_LT(compared, points.size());
      const Eigen::Vector3f expected = rotation * v + translation;
      ASSERT_EQ(std::memcmp(points[compared].data(), expected.data(), sizeof expected), 0)
          << compared << ": " << points[compared].transpose() << " against " << expected.transpose();
      ++compared;
    }
    EXPECT_EQ(compared, points.size());
    EXPECT_EQ(left_out[ReadingKind::kNaN], sensor.size() - compared);
    EXPECT_GT(compared, 5000u);
  }
}

// The cloud that crashed the node inside pcl::fromROSMsg: 2 000 000 points declared, 120 bytes sent.
TEST(PointCloudConversion, LessDataThanDeclaredIsRefused) {
  sensor_msgs::PointCloud2 cloud = xyzCloud(2000000, 1);
  cloud.data.resize(120);
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_short_data");
  cloud = xyzCloud(1000, 1);
  cloud.data.resize(10 * cloud.point_step);
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_short_data") << "1000 points declared, data for 10";
}

TEST(PointCloudConversion, FieldsMustFitAndBeCoordinates) {
  sensor_msgs::PointCloud2 cloud = xyzCloud(3, 1);
  cloud.point_step = 4;  // smaller than x, y and z
  cloud.row_step = 12;
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_bad_layout");
  cloud = xyzCloud(3, 1);
  cloud.fields.pop_back();  // no z
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_bad_fields");
  cloud = xyzCloud(3, 1);
  cloud.fields[1].datatype = sensor_msgs::PointField::UINT8;
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_bad_fields");
  cloud = xyzCloud(3, 1);
  cloud.row_step = 8;  // shorter than one row of points
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_bad_layout");
  cloud = xyzCloud(3, 1);
  cloud.is_bigendian = true;
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_big_endian");
  cloud = xyzCloud(0, 4000000);  // no points, but four million rows to walk
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_empty");
  cloud = xyzCloud(1, 1);
  cloud.width = 100000;
  cloud.height = 100000;  // 10^10 points: the size alone is refused, whatever the data
  EXPECT_EQ(checkCloudLayout(cloud).key, "cloud_too_large");
}

TEST(PointCloudConversion, Float64CoordinatesAreRead) {
  sensor_msgs::PointCloud2 cloud;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(3, "x", 1, sensor_msgs::PointField::FLOAT64, "y", 1, sensor_msgs::PointField::FLOAT64,
                                "z", 1, sensor_msgs::PointField::FLOAT64);
  modifier.resize(1);
  sensor_msgs::PointCloud2Iterator<double> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  *x = 1.5, *y = -2.0, *z = 0.25;
  ASSERT_FALSE(checkCloudLayout(cloud).rejected());
  std::vector<Eigen::Vector3f> points;
  ReadingCounts left_out;
  cloudPointsInMap(cloud, Eigen::Isometry3f::Identity(), &points, &left_out);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_TRUE(points[0].isApprox(Eigen::Vector3f(1.5f, -2.0f, 0.25f)));
}

TEST(PointCloudConversion, AnOrganizedFramesFlyingPixelsAreLeftOutAndCounted) {
  // A box at 1.5 m before a wall at 4 m, its left edge's column mixed (no two alike), some NaN:
  // converted with the filter, the mixed column is left out and counted, everything else is the
  // conversion without it, point for point.
  constexpr int kW = 37, kH = 23;  // not a multiple of four: the rows' ends go one by one
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Eigen::Vector3f> points(kW * kH);
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      float depth = u >= 14 && u < 30 ? 1.5f : 4.0f;
      if (u == 13) depth = (v % 2) ? 2.3f : 3.1f;
      const Eigen::Vector3f ray((u - kW / 2) / 500.0f, (v - kH / 2) / 500.0f, 1.0f);
      points[std::size_t(v) * kW + u] = (u == 5 && v == 7) ? Eigen::Vector3f(nan, nan, nan) : Eigen::Vector3f(ray * depth);
    }
  }
  const sensor_msgs::PointCloud2 msg = organizedCloud(points, kW, kH, "camera");
  const Eigen::Isometry3f pose(Eigen::Translation3f(1.0f, 2.0f, 0.5f) * Eigen::AngleAxisf(0.3f, Eigen::Vector3f::UnitZ()));
  std::vector<Eigen::Vector3f> plain, filtered;
  ReadingCounts plain_left, filtered_left;
  cloudPointsInMap(msg, pose, &plain, &plain_left);
  const octo_slice_mapper::FlyingPixelOptions flying;
  cloudPointsInMap(msg, pose, &filtered, &filtered_left, &flying);
  EXPECT_EQ(filtered_left[ReadingKind::kFlyingPixel], std::uint64_t(kH - 2));  // the border rows are kept
  EXPECT_EQ(filtered_left[ReadingKind::kNaN], 1u);
  ASSERT_EQ(filtered.size() + kH - 2, plain.size());
  std::size_t k = 0;
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      if (u == 5 && v == 7) continue;
      const Eigen::Vector3f& p = plain[std::size_t(v) * kW + u - (v > 7 || (v == 7 && u > 5) ? 1 : 0)];
      if (u == 13 && v > 0 && v + 1 < kH) continue;  // left out
      ASSERT_LT(k, filtered.size());
      EXPECT_EQ(filtered[k++], p) << u << " " << v;
    }
  }
  EXPECT_EQ(k, filtered.size());
}

// On a frame with many flying pixels, holes and surfaces at random, the conversion leaves out
// exactly the pixels the core's whole-frame rule (flagFlyingPixels) flags, and keeps the rest in
// order: rows with several flagged pixels, next to holes, at the ends of rows, beside infinite
// pixels (not written) and finite ones whose range overflows to infinity (written).
TEST(PointCloudConversion, TheFilteredConversionLeavesOutExactlyWhatTheRuleFlags) {
  constexpr int kW = 41, kH = 29;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Eigen::Vector3f> points(kW * kH);
  for (int v = 0; v < kH; ++v) {
    for (int u = 0; u < kW; ++u) {
      const float x = unit(rng);
      const float depth = x < 0.1f    ? nan
                          : x < 0.12f ? std::numeric_limits<float>::infinity()
                          : x < 0.14f ? 1e20f
                          : x < 0.55f ? 1.5f + 0.01f * unit(rng)
                          : x < 0.85f ? 3.0f
                                      : 0.5f + 4.0f * unit(rng);
      const Eigen::Vector3f ray((u - kW / 2) / 500.0f, (v - kH / 2) / 500.0f, 1.0f);
      points[std::size_t(v) * kW + u] = ray * depth;
    }
  }
  const octo_slice_mapper::FlyingPixelOptions flying;
  std::vector<std::uint8_t> flags;
  const std::size_t flagged = octo_slice_mapper::flagFlyingPixels(points, kW, kH, flying, &flags);
  ASSERT_GT(flagged, std::size_t(kH));  // several per row
  const sensor_msgs::PointCloud2 msg = organizedCloud(points, kW, kH, "camera");
  const Eigen::Isometry3f pose(Eigen::Translation3f(1.0f, 2.0f, 0.5f) * Eigen::AngleAxisf(0.3f, Eigen::Vector3f::UnitZ()));
  std::vector<Eigen::Vector3f> plain, filtered;
  ReadingCounts plain_left, filtered_left;
  cloudPointsInMap(msg, pose, &plain, &plain_left);
  cloudPointsInMap(msg, pose, &filtered, &filtered_left, &flying);
  EXPECT_EQ(filtered_left[ReadingKind::kFlyingPixel], flagged);
  EXPECT_EQ(filtered_left[ReadingKind::kNaN], plain_left[ReadingKind::kNaN]);
  std::vector<Eigen::Vector3f> expected;
  std::size_t k = 0;  // the plain conversion's point of pixel i
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    if (!flags[i]) expected.push_back(plain[k]);
    ++k;
  }
  ASSERT_EQ(k, plain.size());
  EXPECT_EQ(filtered, expected);
}
