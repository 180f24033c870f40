// Several sensors through the node: a lidar's scans sent whole on one topic to one mapper, and
// split over two topics (each half in its own frame, tied to the lidar's by a static transform)
// to another, must give the same map: the same occupied cells and voxels, and each topic counted
// on its own on /diagnostics.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "ros_test_support.h"

namespace {

using octo_slice_mapper::test_support::waitFor;

constexpr int kBeams = 241;
constexpr double kAngleMin = -2.0, kIncrement = 4.0 / (kBeams - 1);
constexpr int kFirstHalf = 100;  // not at 0 rad: the second half's frame is turned by -0.33 rad

// The range from (x, y) along `angle` to the walls of the room [-1, 5] x [-2, 2] and a pillar
// (a 0.4 m square at (2.5, 1.0)); 8 m if nothing is met.
float rangeInRoom(double x, double y, double angle) {
  const double dx = std::cos(angle), dy = std::sin(angle);
  double best = 8.0;
  auto wall = [&](double t) {
    if (t > 1e-6) best = std::min(best, t);
  };
  if (dx > 0) wall((5.0 - x) / dx);
  if (dx < 0) wall((-1.0 - x) / dx);
  if (dy > 0) wall((2.0 - y) / dy);
  if (dy < 0) wall((-2.0 - y) / dy);
  // The pillar, by slabs.
  double t0 = 0.0, t1 = 1e9;
  const double lo[2] = {2.3, 0.8}, hi[2] = {2.7, 1.2}, o[2] = {x, y}, d[2] = {dx, dy};
  bool hit = true;
  for (int a = 0; a < 2 && hit; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      hit = o[a] >= lo[a] && o[a] <= hi[a];
      continue;
    }
    double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    hit = t0 <= t1;
  }
  if (hit && t0 > 1e-6) best = std::min(best, t0);
  return static_cast<float>(best);
}

class SeveralSensorsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    whole_ = nh_.advertise<sensor_msgs::LaserScan>("scan_whole", 50);
    first_ = nh_.advertise<sensor_msgs::LaserScan>("scan_first_half", 50);
    second_ = nh_.advertise<sensor_msgs::LaserScan>("scan_second_half", 50);
    diagnostics_sub_ = nh_.subscribe("/diagnostics", 50, &SeveralSensorsTest::onDiagnostics, this);
    maps_[0] = nh_.subscribe<nav_msgs::OccupancyGrid>(
        "one_topic/incremental_map", 2, [this](const nav_msgs::OccupancyGrid::ConstPtr& m) { map_[0] = m; });
    maps_[1] = nh_.subscribe<nav_msgs::OccupancyGrid>(
        "two_topics/incremental_map", 2, [this](const nav_msgs::OccupancyGrid::ConstPtr& m) { map_[1] = m; });
    voxels_[0] = nh_.subscribe<sensor_msgs::PointCloud2>(
        "one_topic/occupied_voxels", 2, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { cloud_[0] = m; });
    voxels_[1] = nh_.subscribe<sensor_msgs::PointCloud2>(
        "two_topics/occupied_voxels", 2, [this](const sensor_msgs::PointCloud2::ConstPtr& m) { cloud_[1] = m; });
    // The lidar on the base; its halves' frames: the first the lidar's own, the second turned to
    // where its first beam points.
    std::vector<geometry_msgs::TransformStamped> ties = {tie("base_link", "laser", 0.10, 0.26, 0.0),
                                                         tie("laser", "laser_first", 0.0, 0.0, 0.0),
                                                         tie("laser", "laser_second", 0.0, 0.0,
                                                             kAngleMin + kFirstHalf * kIncrement)};
    static_tf_.sendTransform(ties);
    // The moving transform on /tf directly, so that the test can wait for both mappers' tf
    // listeners: a scan whose transform a mapper never heard of is skipped, not mapped.
    tf_ = nh_.advertise<tf2_msgs::TFMessage>("/tf", 100);
    ASSERT_TRUE(waitFor([this] {
      return whole_.getNumSubscribers() >= 1 && first_.getNumSubscribers() >= 1 && second_.getNumSubscribers() >= 1 &&
             tf_.getNumSubscribers() >= 2;
    }, 20.0)) << "the mappers did not subscribe";
  }

  static geometry_msgs::TransformStamped tie(const std::string& parent, const std::string& child, double x, double z,
                                             double yaw) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = ros::Time::now();
    t.header.frame_id = parent;
    t.child_frame_id = child;
    t.transform.translation.x = x;
    t.transform.translation.z = z;
    t.transform.rotation.z = std::sin(yaw / 2);
    t.transform.rotation.w = std::cos(yaw / 2);
    return t;
  }

  void onDiagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
    for (const auto& status : msg->status) {
      const std::string node = status.name.substr(0, status.name.find(':'));
      for (const auto& kv : status.values) diagnostics_[node][kv.key] = std::atof(kv.value.c_str());
    }
  }
  double diagnostic(const std::string& node, const std::string& key) {
    auto& values = diagnostics_[node];
    const auto it = values.find(key);
    return it == values.end() ? -1.0 : it->second;
  }

  ros::NodeHandle nh_;
  ros::Publisher whole_, first_, second_;
  ros::Subscriber diagnostics_sub_, maps_[2], voxels_[2];
  nav_msgs::OccupancyGrid::ConstPtr map_[2];
  sensor_msgs::PointCloud2::ConstPtr cloud_[2];
  std::map<std::string, std::map<std::string, double>> diagnostics_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  ros::Publisher tf_;
};

TEST_F(SeveralSensorsTest, ALidarSplitOverTwoTopicsGivesTheOneTopicMap) {
  constexpr int kScans = 40;
  for (int k = 0; k < kScans; ++k) {
    // The robot drives along x, turning slowly; the lidar 0.10 m ahead of it.
    const double x = 0.08 * k, y = 0.3 * std::sin(0.1 * k), yaw = 0.02 * k;
    const ros::Time stamp = ros::Time::now();
    geometry_msgs::TransformStamped odom_base = tie("odom", "base_link", 0.0, 0.0, yaw);
    odom_base.header.stamp = stamp;
    odom_base.transform.translation.x = x;
    odom_base.transform.translation.y = y;
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(odom_base);
    tf_.publish(tf);
    sensor_msgs::LaserScan whole;
    whole.header.stamp = stamp;
    whole.header.frame_id = "laser";
    whole.angle_min = kAngleMin;
    whole.angle_increment = kIncrement;
    whole.angle_max = kAngleMin + (kBeams - 1) * kIncrement;
    whole.range_min = 0.05f;
    whole.range_max = 10.0f;
    const double lx = x + 0.10 * std::cos(yaw), ly = y + 0.10 * std::sin(yaw);
    for (int b = 0; b < kBeams; ++b) whole.ranges.push_back(rangeInRoom(lx, ly, yaw + kAngleMin + b * kIncrement));
    sensor_msgs::LaserScan first = whole, second = whole;
    first.header.frame_id = "laser_first";
    first.ranges.assign(whole.ranges.begin(), whole.ranges.begin() + kFirstHalf);
    first.angle_max = kAngleMin + (kFirstHalf - 1) * kIncrement;
    second.header.frame_id = "laser_second";
    second.ranges.assign(whole.ranges.begin() + kFirstHalf, whole.ranges.end());
    second.angle_min = 0.0f;
    second.angle_max = (kBeams - kFirstHalf - 1) * kIncrement;
    ros::WallDuration(0.01).sleep();  // the transform first
    whole_.publish(whole);
    first_.publish(first);
    second_.publish(second);
    ros::WallDuration(0.04).sleep();
  }
  ASSERT_TRUE(waitFor([this] {
    return diagnostic("/one_topic", "scans_inserted") == kScans && diagnostic("/two_topics", "scans_inserted") == 2 * kScans;
  }, 30.0)) << "inserted: one topic " << diagnostic("/one_topic", "scans_inserted") << ", two topics "
            << diagnostic("/two_topics", "scans_inserted");
  EXPECT_EQ(diagnostic("/two_topics", "/scan_first_half inserted"), kScans) << "each topic counted on its own";
  EXPECT_EQ(diagnostic("/two_topics", "/scan_second_half inserted"), kScans);
  EXPECT_EQ(diagnostic("/two_topics", "/scan_second_half received"), kScans);
  EXPECT_EQ(diagnostic("/two_topics", "/scan_second_half missed"), 0);

  // The maps as they are after the last scan: each is sent when it changed (the slice at 5 Hz,
  // the voxels every 0.2 s), so the newest of each, a second after the last insertion, is it.
  waitFor([] { return false; }, 1.5);
  ASSERT_TRUE(waitFor([this] { return map_[0] && map_[1] && cloud_[0] && cloud_[1]; }, 10.0));
  const double wanted = 0.98;
  std::size_t occupied_one = 0, occupied_two = 0, both = 0;
  for (double wx = -1.2; wx < 5.2; wx += 0.05) {
    for (double wy = -2.2; wy < 2.2; wy += 0.05) {
      const int a = octo_slice_mapper::test_support::cellOf(map_[0], wx + 0.025, wy + 0.025);
      const int b = octo_slice_mapper::test_support::cellOf(map_[1], wx + 0.025, wy + 0.025);
      occupied_one += a > 50, occupied_two += b > 50, both += a > 50 && b > 50;
    }
  }
  ASSERT_GT(occupied_one, 100u) << "the room's walls";
  EXPECT_GE(both, wanted * occupied_two) << "precision: " << both << " of " << occupied_two;
  EXPECT_GE(both, wanted * occupied_one) << "recall: " << both << " of " << occupied_one;
  const double voxels_one = cloud_[0]->width, voxels_two = cloud_[1]->width;
  EXPECT_NEAR(voxels_two, voxels_one, 0.03 * voxels_one) << "occupied voxels";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "several_sensors_rostest");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
