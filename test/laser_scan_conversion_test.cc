#include "ros/laser_scan_conversion.h"

#include <gtest/gtest.h>

#include <limits>

using namespace octo_slice_mapper;
using namespace octo_slice_mapper::ros_adapter;

namespace {
sensor_msgs::LaserScan goodScan(std::size_t n = 11) {
  sensor_msgs::LaserScan msg;
  msg.header.frame_id = "laser";
  msg.header.stamp = ros::Time(12.5);
  msg.angle_min = -0.5f;
  msg.angle_increment = 0.1f;
  msg.angle_max = msg.angle_min + msg.angle_increment * static_cast<float>(n - 1);
  msg.range_min = 0.02f;
  msg.range_max = 5.6f;
  msg.ranges.assign(n, 1.0f);
  return msg;
}
}  // namespace

TEST(LaserScanConversion, GoodScanCarriesEverythingOver) {
  auto msg = goodScan();
  msg.ranges[3] = std::numeric_limits<float>::quiet_NaN();  // single bad readings are the core's to count
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << 1, 2, 0.26;
  Scan scan;
  const auto r = toCoreScan(msg, pose, &scan);
  ASSERT_FALSE(r.rejected()) << r.message;
  EXPECT_EQ(scan.ranges.size(), 11u);
  EXPECT_DOUBLE_EQ(scan.stamp, 12.5);
  EXPECT_FLOAT_EQ(scan.angle_min, -0.5f);
  EXPECT_TRUE(scan.sensor_pose.isApprox(pose));
}

TEST(LaserScanConversion, StructuralProblemsAreRefusedWithAReason) {
  Scan scan;
  const Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  auto msg = goodScan();
  msg.intensities.assign(5, 1.0f);
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "length_mismatch");
  msg = goodScan();
  msg.angle_increment = 0.0f;
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "bad_angles");
  msg = goodScan();
  msg.angle_increment = -0.1f;
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "bad_angles") << "inconsistent with angle_max";
  msg = goodScan();
  msg.angle_max = 3.0f;
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "bad_angles");
  msg = goodScan();
  msg.ranges.clear();
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "empty");
  msg = goodScan();
  msg.range_max = 0.0f;
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "bad_range_limits");
  msg = goodScan(1000000);
  EXPECT_EQ(toCoreScan(msg, pose, &scan).key, "too_many_beams");
  msg = goodScan();
  Eigen::Isometry3d bad = pose;
  bad.translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(toCoreScan(msg, bad, &scan).key, "bad_transform");
}

TEST(LaserScanConversion, DescendingScansAreFine) {
  auto msg = goodScan();
  msg.angle_min = 0.5f;
  msg.angle_increment = -0.1f;
  msg.angle_max = -0.5f;
  Scan scan;
  EXPECT_FALSE(toCoreScan(msg, Eigen::Isometry3d::Identity(), &scan).rejected());
}
