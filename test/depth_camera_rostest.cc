// Through a real roscore: a TurtleBot's depth camera (simulated Kinect, organized clouds
// with NaN where it sees nothing) into cloud_in. With the navigation band the table top (0.72 m)
// and the shelf's overhang (0.45-0.60 m) are occupied in /map, where the lidar's band, which the
// lidar sees through, has free floor or nothing; the floor itself is never occupied. The floor is
// the one through the robot's base_footprint (floor_base_frame).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/GetMap.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/transform_broadcaster.h>

#include <boost/make_shared.hpp>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <string>

#include "octo_slice_mapper/sim/depth_camera.h"
#include "ros/point_cloud_conversion.h"
#include "ros_test_support.h"

namespace osm = octo_slice_mapper;

using octo_slice_mapper::test_support::cellOf;
using octo_slice_mapper::test_support::waitFor;

TEST(DepthCamera, TheNavigationBandShowsTheTableTopAndTheOverhangTheLidarBandDoesNot) {
  ros::NodeHandle nh;
  nav_msgs::OccupancyGrid::ConstPtr nav, lidar;
  std::map<std::string, double> diagnostics, raised, lidar_band;
  ros::Subscriber diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 20, [&](const auto& msg) {
    for (const auto& status : msg->status) {
      std::map<std::string, double>* values = status.name.rfind("/nav_mapper:", 0) == 0           ? &diagnostics
                                               : status.name.rfind("/raised_base_mapper:", 0) == 0 ? &raised
                                               : status.name.rfind("/lidar_band_mapper:", 0) == 0  ? &lidar_band
                                                                                                   : nullptr;
      if (!values) continue;
      for (const auto& kv : status.values) (*values)[kv.key] = std::atof(kv.value.c_str());
    }
  });
  nav_msgs::OccupancyGrid::ConstPtr heights;
  ros::Subscriber heights_sub = nh.subscribe<nav_msgs::OccupancyGrid>(
      "/nav_mapper/height_map", 1, [&](const nav_msgs::OccupancyGrid::ConstPtr& msg) { heights = msg; });
  sensor_msgs::PointCloud2::ConstPtr floor_cells;
  ros::Subscriber floor_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/nav_mapper/floor_cells", 1, [&](const sensor_msgs::PointCloud2::ConstPtr& msg) { floor_cells = msg; });
  ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("cloud_in", 10);
  ASSERT_TRUE(waitFor([&] { return cloud_pub.getNumSubscribers() >= 3; }, 20.0)) << "the mappers did not subscribe";

  // The camera on the TurtleBot: 0.10 m forward of the base, 0.30 m up (here, with the base
  // moving, the whole chain is one transform odom -> optical frame per frame).
  tf2_ros::TransformBroadcaster tf;
  osm::sim::DepthCameraSpec spec;
  spec.width = 320, spec.height = 240;  // QVGA, as the Kinect also streams
  const osm::sim::BoxScene room = osm::sim::BoxScene::officeRoom();
  std::mt19937 rng(4);
  struct View {
    Eigen::Vector3d base;
    double yaw, pitch;
  };
  // Facing the table from the west, then the shelf from the south.
  // Pitched down 0.1 rad, the camera (0.30 m up) sees the underside of the table top from 1.4 m on.
  const std::vector<View> views = {{{0.8, 1.9, 0.0}, 0.0, 0.1}, {{0.9, 1.7, 0.0}, 0.1, 0.1},
                                   {{1.8, 2.8, 0.0}, 1.5708, 0.1}, {{1.6, 2.9, 0.0}, 1.45, 0.1}};
  // tf first, until the mappers' listeners have it (a cloud before that would wait for it and
  // might time out).
  ros::Publisher tf_probe = nh.advertise<tf2_msgs::TFMessage>("/tf", 10);
  ASSERT_TRUE(waitFor([&] { return tf_probe.getNumSubscribers() >= 3; }, 20.0)) << "the mappers do not listen to /tf";
  int sent = 0;
  for (int round = 0; round < 3; ++round) {
    for (const View& v : views) {
      const Eigen::Vector3d camera = v.base + Eigen::Vector3d(0.10 * std::cos(v.yaw), 0.10 * std::sin(v.yaw), 0.30);
      const Eigen::Isometry3d pose = osm::sim::opticalPose(camera, v.yaw, v.pitch);
      const ros::Time stamp = ros::Time::now();
      geometry_msgs::TransformStamped t = tf2::eigenToTransform(pose);
      t.header.frame_id = "odom";
      t.child_frame_id = "camera_depth_optical_frame";
      t.header.stamp = stamp;
      // The base on the floor (base_footprint), and a frame 0.5 m above it.
      Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
      base.translation() = v.base;
      geometry_msgs::TransformStamped footprint = tf2::eigenToTransform(base);
      footprint.header = t.header;
      footprint.child_frame_id = "base_footprint";
      base.translation().z() += 0.5;
      geometry_msgs::TransformStamped lifted = tf2::eigenToTransform(base);
      lifted.header = t.header;
      lifted.child_frame_id = "base_raised";
      tf.sendTransform({t, footprint, lifted});
      sensor_msgs::PointCloud2 cloud = osm::ros_adapter::organizedCloud(osm::sim::depthFrame(room, pose, spec, &rng), spec.width, spec.height,
                                                                  "camera_depth_optical_frame");
      cloud.header.stamp = stamp;
      ros::WallDuration(0.05).sleep();
      t.header.stamp = footprint.header.stamp = lifted.header.stamp = stamp + ros::Duration(0.05);  // no waiting
      tf.sendTransform({t, footprint, lifted});
      cloud_pub.publish(cloud);
      ++sent;
      ros::WallDuration(0.1).sleep();
    }
  }
  ASSERT_TRUE(waitFor([&] { return diagnostics["clouds_inserted"] >= sent; }, 30.0))
      << "clouds inserted " << diagnostics["clouds_inserted"] << " of " << sent;
  // The slices as they are now (dynamic_map answers with the current one).
  for (auto [service, grid] : {std::pair<const char*, nav_msgs::OccupancyGrid::ConstPtr*>{"nav_dynamic_map", &nav},
                               {"lidar_band_dynamic_map", &lidar}}) {
    ASSERT_TRUE(ros::service::waitForService(service, 10000)) << service;
    nav_msgs::GetMap get;
    ASSERT_TRUE(ros::service::call(service, get)) << service;
    *grid = boost::make_shared<nav_msgs::OccupancyGrid>(get.response.map);
  }

  // The table top, between its legs (x 2.6-3.6, y 1.6-2.2): the lidar's band (0.16-0.36 m) sees
  // under it; the navigation band (0.05-0.80 m) has it occupied.
  int top_nav = 0, top_lidar = 0, cells = 0;
  for (double x = 2.75; x < 3.5; x += 0.1) {
    for (double y = 1.7; y < 2.1; y += 0.1) {
      ++cells;
      top_nav += cellOf(nav, x, y) >= 65;
      top_lidar += cellOf(lidar, x, y) >= 65;
    }
  }
  EXPECT_GT(top_nav, cells * 7 / 10) << top_nav << " of " << cells << " table-top cells occupied (navigation band)";
  EXPECT_LT(top_lidar, cells / 10) << top_lidar << " of " << cells << " occupied in the lidar's band";
  // The shelf's overhang (y 4.35-4.7, at 0.45-0.60 m) in front of the cabinet (y >= 4.7).
  int over_nav = 0, over_lidar = 0, over = 0;
  for (double x = 1.2; x < 2.5; x += 0.1) {
    ++over;
    over_nav += cellOf(nav, x, 4.5) >= 65;
    over_lidar += cellOf(lidar, x, 4.5) >= 65;
  }
  EXPECT_GT(over_nav, over * 7 / 10) << over_nav << " of " << over << " overhang cells occupied";
  EXPECT_LT(over_lidar, over / 10) << over_lidar << " of " << over << " occupied in the lidar's band";
  // The floor between the robot and the table: seen, and free (it only clears).
  int floor_free = 0, floor = 0;
  for (double x = 1.5; x < 2.4; x += 0.1) {
    ++floor;
    const int v = cellOf(nav, x, 1.9);
    floor_free += v >= 0 && v <= 25;
  }
  EXPECT_GT(floor_free, floor * 7 / 10) << floor_free << " of " << floor << " floor cells free";
  EXPECT_GT(diagnostics["clouds_received"], 0.0);

  // The floor was found, and ~height_map has the table top's height above it (2 cm steps: the
  // top voxel's top, 0.70 or 0.75 m) and the bare floor at 0, on /map's lattice.
  EXPECT_GT(diagnostics["floor_frames_found"], 0.0);
  ASSERT_TRUE(waitFor([&] { return heights && !heights->data.empty(); }, 10.0)) << "no ~height_map";
  EXPECT_NEAR(std::remainder(heights->info.origin.position.x - nav->info.origin.position.x, 0.05), 0.0, 1e-4);
  int top_height = 0, top_cells = 0, bare = 0;
  for (double x = 2.75; x < 3.5; x += 0.1) {
    for (double y = 1.7; y < 2.1; y += 0.1) {
      const int v = cellOf(heights, x, y);
      top_cells += v >= 0;
      top_height += v >= 32 && v <= 40;
    }
  }
  for (double x = 1.5; x < 2.4; x += 0.1) bare += cellOf(heights, x, 1.9) == 0;
  EXPECT_GT(top_height, top_cells * 7 / 10) << top_height << " of " << top_cells << " table-top cells at 0.64-0.80 m";
  EXPECT_GT(bare, 5) << "bare floor cells between the robot and the table";
  // ~floor_cells: each cell with a floor at its centre on /map's lattice, z the floor found (the
  // room's, z = 0), top as ~height_map has it (the table top's at 0.64-0.80 m).
  ASSERT_TRUE(waitFor([&] { return floor_cells && floor_cells->width > 0; }, 10.0)) << "no ~floor_cells";
  ASSERT_EQ(floor_cells->fields.size(), 4u);
  EXPECT_EQ(floor_cells->fields[3].name, "top");
  ASSERT_EQ(floor_cells->data.size(), std::size_t(floor_cells->width) * 16);
  int on_lattice = 0, level = 0, table_tops = 0;
  for (std::uint32_t i = 0; i < floor_cells->width; ++i) {
    float p[4];
    std::memcpy(p, &floor_cells->data[16 * std::size_t(i)], sizeof p);
    on_lattice += std::abs(std::remainder(p[0] - nav->info.origin.position.x - 0.025, 0.05)) < 1e-3 &&
                  std::abs(std::remainder(p[1] - nav->info.origin.position.y - 0.025, 0.05)) < 1e-3;
    level += std::abs(p[2]) < 0.02;
    table_tops += p[0] > 2.75 && p[0] < 3.5 && p[1] > 1.7 && p[1] < 2.1 && p[3] >= 0.64 && p[3] <= 0.80;
  }
  const int cells_with_floor = int(floor_cells->width);
  EXPECT_EQ(on_lattice, cells_with_floor);
  EXPECT_GT(level, cells_with_floor * 95 / 100) << level << " of " << cells_with_floor << " cells' floor within 2 cm of z = 0";
  EXPECT_GT(table_tops, 20) << "cells under the table top with its height above the floor";

  // The node takes each cloud's ground point from floor_base_frame: with the base frame 0.5 m
  // above the floor no frame finds a floor (and each one still goes into the map).
  ASSERT_TRUE(waitFor([&] { return raised["clouds_inserted"] >= sent && raised["floor_frames_without"] >= sent; }, 30.0))
      << "clouds inserted " << raised["clouds_inserted"] << ", frames without a floor " << raised["floor_frames_without"];
  EXPECT_EQ(raised["floor_frames_found"], 0.0);
  EXPECT_EQ(raised["floor_ground_points"], double(sent));
  // floor_base_frame's default ("auto") takes the robot's base_footprint from tf: every frame the
  // navigation mapper inserted came with it; the lidar-band mapper asks for none ("").
  EXPECT_EQ(diagnostics["floor_ground_points"], double(sent));
  ASSERT_TRUE(waitFor([&] { return lidar_band["clouds_inserted"] >= sent; }, 30.0)) << lidar_band["clouds_inserted"];
  EXPECT_EQ(lidar_band["floor_ground_points"], 0.0);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "depth_camera_rostest");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
