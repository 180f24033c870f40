// simulate_session: writes the deterministic simulated TurtleBot run as a rosbag, plus the
// ground-truth map, for the demo and the tests.
//
//   simulate_session --bag FILE.bag --truth PREFIX [--seed N] [--real-robot] [--no-camera]
//
// Topics: /scan (LaserScan, frame "laser"), /tf (odom -> base_footprint -> base_link),
// /tf_static (base_link -> laser: x 0.10, z 0.26; base_link -> camera_link ->
// camera_depth_optical_frame), /odom (nav_msgs/Odometry), /camera/depth/points (PointCloud2,
// organized, NaN where the camera sees nothing; sim::CameraMount: 160 x 120 at 2 Hz).
// Truth: PREFIX.{pgm,yaml} for the lidar's plane, PREFIX_nav.{pgm,yaml} for the navigation band
// (kNavigationBandMinZ..kNavigationBandMaxZ, slice_grid.h: what the robot can hit).
//
// --real-robot: the traits of a real TurtleBot's recording: a REP 117 driver (+inf no
// return, -inf too close, NaN), the lidar mounted yawed 20 deg and 3 cm to the side, odometry
// from dead reckoning (drifting, ~1 deg of pitch and roll, base height moving by 2 cm), the first
// second of scans before any tf, and a few scans recorded out of order. Prints what it wrote as a
// JSON line, for the test that replays it.
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <limits>
#include <set>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/sim/depth_camera.h"
#include "octo_slice_mapper/sim/session.h"
#include "octo_slice_mapper/slice_grid.h"
#include "planar_transform.h"
#include "ros/point_cloud_conversion.h"

using octo_slice_mapper::sim::Pose2D;
using octo_slice_mapper::tools::planarTransform;

namespace {

const double kStartTime = 1000.0;  // bag time of t = 0 (ROS time 0 means "unset")

geometry_msgs::TransformStamped staticTransform(const Eigen::Isometry3d& pose, const std::string& parent,
                                                const std::string& child, const ros::Time& stamp) {
  geometry_msgs::TransformStamped t = tf2::eigenToTransform(pose);
  t.header.frame_id = parent;
  t.header.stamp = stamp;
  t.child_frame_id = child;
  return t;
}

void usage() {
  std::cerr << "usage: simulate_session --bag FILE.bag --truth PREFIX [--seed N] [--real-robot] [--no-camera]\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string bag_path, truth_prefix;
  auto spec = octo_slice_mapper::sim::SessionSpec::officeTour();
  bool real_robot = false, camera = true;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--real-robot") {
      const std::uint32_t seed = spec.seed;
      spec = octo_slice_mapper::sim::SessionSpec::realRobotTour();
      spec.seed = seed;
      real_robot = true;
      camera = false;  // the real robot's recording is its lidar's
    } else if (arg == "--no-camera") {
      camera = false;
    } else if (arg == "--bag" && i + 1 < argc) bag_path = argv[++i];
    else if (arg == "--truth" && i + 1 < argc) truth_prefix = argv[++i];
    else if (arg == "--seed" && i + 1 < argc) spec.seed = static_cast<std::uint32_t>(std::stoul(argv[++i]));
    else {
      usage();
      return 2;
    }
  }
  if (bag_path.empty() || truth_prefix.empty()) {
    usage();
    return 2;
  }
  const auto plan = octo_slice_mapper::sim::FloorPlan::office();
  const octo_slice_mapper::sim::SimulatedSession session(plan, spec);

  std::string error;
  const auto truth = plan.groundTruth(0.05);
  if (!octo_slice_mapper::savePgmYaml(truth, truth_prefix, &error) ||
      !octo_slice_mapper::savePgmYaml(
          plan.groundTruthBand(0.05, octo_slice_mapper::kNavigationBandMinZ, octo_slice_mapper::kNavigationBandMaxZ),
          truth_prefix + "_nav", &error)) {
    std::cerr << "simulate_session: " << error << "\n";
    return 1;
  }

  const std::string tmp_bag = bag_path + ".partial";
  try {
    rosbag::Bag bag(tmp_bag, rosbag::bagmode::Write);
    const ros::Time t0(kStartTime);
    tf2_msgs::TFMessage statics;
    statics.transforms.push_back(planarTransform("base_link", "laser", t0, spec.lidar.mount_x, spec.lidar.mount_y,
                                                 spec.lidar.mount_z, spec.lidar.mount_yaw));
    const octo_slice_mapper::sim::CameraMount mount;
    if (camera) {
      statics.transforms.push_back(
          staticTransform(octo_slice_mapper::sim::cameraLinkOnBase(mount), "base_link", "camera_link", t0));
      statics.transforms.push_back(staticTransform(octo_slice_mapper::sim::opticalOnCameraLink(), "camera_link",
                                                   "camera_depth_optical_frame", t0));
    }
    auto latched = boost::make_shared<ros::M_string>();
    (*latched)["latching"] = "1";
    (*latched)["callerid"] = "/simulate_session";
    (*latched)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
    (*latched)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
    (*latched)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();
    bag.write("/tf_static", t0, statics, latched);

    // A real robot's odometry: dead reckoning, and its tf starts a second after the lidar.
    const std::vector<octo_slice_mapper::sim::Pose3D> odometry =
        octo_slice_mapper::sim::deadReckoned(session.poses(), octo_slice_mapper::sim::DeadReckoning());
    double first_tf = -1.0;  // the stamp of the first tf written (a second in for a real robot)
    for (std::size_t k = 0; k < session.poses().size(); ++k) {
      const Pose2D& p = session.poses()[k];
      if (real_robot && p.t < 1.0) continue;
      if (first_tf < 0.0) first_tf = p.t;
      const ros::Time stamp(kStartTime + p.t);
      tf2_msgs::TFMessage tf;
      if (real_robot) {
        geometry_msgs::TransformStamped odom_tf = tf2::eigenToTransform(odometry[k].pose);
        odom_tf.header.frame_id = "odom";
        odom_tf.header.stamp = stamp;
        odom_tf.child_frame_id = "base_footprint";
        tf.transforms.push_back(odom_tf);
      } else {
        tf.transforms.push_back(planarTransform("odom", "base_footprint", stamp, p.x, p.y, 0.0, p.yaw));
      }
      tf.transforms.push_back(planarTransform("base_footprint", "base_link", stamp, 0.0, 0.0, 0.0, 0.0));
      bag.write("/tf", stamp, tf);
      nav_msgs::Odometry odom;
      odom.header.stamp = stamp;
      odom.header.frame_id = "odom";
      odom.child_frame_id = "base_footprint";
      odom.pose.pose.position.x = p.x;
      odom.pose.pose.position.y = p.y;
      odom.pose.pose.orientation.z = std::sin(0.5 * p.yaw);
      odom.pose.pose.orientation.w = std::cos(0.5 * p.yaw);
      odom.twist.twist.linear.x = p.v;
      odom.twist.twist.angular.z = p.w;
      bag.write("/odom", stamp, odom);
    }

    std::mt19937 rng(spec.seed);
    std::size_t count = 0, before_tf = 0, plus_inf = 0, minus_inf = 0, nans = 0;
    const std::vector<double> times = session.scanTimes();
    // Scans recorded out of order: each of these is written after the one that follows it.
    const std::set<std::size_t> late = real_robot ? std::set<std::size_t>{50, 120, 200, 333} : std::set<std::size_t>{};
    for (std::size_t k = 0; k < times.size(); ++k) {
      const double t = times[k];
      const octo_slice_mapper::Scan scan = session.scanAt(t, &rng);
      // Compared as stamps (nanoseconds), as tf compares them.
      const bool placeable = ros::Time(kStartTime + t) >= ros::Time(kStartTime + first_tf);
      if (!placeable) ++before_tf;
      // The readings of the scans the mapper can place (a transform exists at their stamp).
      for (float r : placeable ? scan.ranges : std::vector<float>()) {
        if (std::isnan(r)) ++nans;
        else if (std::isinf(r)) ++(r > 0 ? plus_inf : minus_inf);
      }
      sensor_msgs::LaserScan msg;
      msg.header.stamp = ros::Time(kStartTime + t);
      msg.header.frame_id = "laser";
      msg.header.seq = static_cast<std::uint32_t>(count);
      msg.angle_min = scan.angle_min;
      msg.angle_increment = scan.angle_increment;
      msg.angle_max = scan.angle_min + scan.angle_increment * static_cast<float>(scan.ranges.size() - 1);
      msg.time_increment = 0.1f / 1024.0f;
      msg.scan_time = static_cast<float>(1.0 / spec.lidar.rate_hz);
      msg.range_min = scan.range_min;
      msg.range_max = scan.range_max;
      msg.ranges = scan.ranges;
      // A late scan and the next one trade places in the recording (bag time = arrival).
      const bool is_late = late.count(k) > 0, after_late = k > 0 && late.count(k - 1) > 0;
      const double arrival = is_late ? times[k + 1] + 1e-4 : after_late ? times[k - 1] : t;
      bag.write("/scan", ros::Time(kStartTime + arrival), msg);
      ++count;
    }
    // The depth camera: organized frames of the building in 3D, from the robot's true pose.
    std::size_t frames = 0;
    if (camera) {
      const octo_slice_mapper::sim::BoxScene scene = octo_slice_mapper::sim::BoxScene::of(plan);
      std::mt19937 camera_rng(spec.seed + 1);
      for (double t = 0.5 / mount.rate_hz; t <= session.duration(); t += 1.0 / mount.rate_hz, ++frames) {
        const Pose2D p = session.poseAt(t);
        const std::vector<Eigen::Vector3f> points = octo_slice_mapper::sim::depthFrame(
            scene, octo_slice_mapper::sim::opticalOnRobot(mount, p.x, p.y, p.yaw), mount.spec, &camera_rng);
        sensor_msgs::PointCloud2 cloud = octo_slice_mapper::ros_adapter::organizedCloud(
            points, mount.spec.width, mount.spec.height, "camera_depth_optical_frame");
        cloud.header.stamp = ros::Time(kStartTime + t);
        cloud.header.seq = static_cast<std::uint32_t>(frames);
        bag.write("/camera/depth/points", cloud.header.stamp, cloud);
      }
    }
    bag.close();
    if (std::rename(tmp_bag.c_str(), bag_path.c_str()) != 0) {
      std::cerr << "simulate_session: cannot rename " << tmp_bag << ": " << std::strerror(errno) << "\n";
      return 1;
    }
    std::cout << "simulate_session: wrote " << bag_path << " (" << count << " scans, " << frames << " depth frames, "
              << session.duration() << " s) and " << truth_prefix << "{,_nav}.{pgm,yaml}\n";
    if (real_robot) {
      std::printf("{\"scans\": %zu, \"scans_before_tf\": %zu, \"scans_out_of_order\": %zu, \"plus_inf\": %zu, "
                  "\"minus_inf\": %zu, \"nan\": %zu, \"beams_per_scan\": %d}\n",
                  count, before_tf, late.size(), plus_inf, minus_inf, nans, spec.lidar.beams);
    }
  } catch (const std::exception& e) {
    std::remove(tmp_bag.c_str());
    std::cerr << "simulate_session: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
