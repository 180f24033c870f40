// simulate_session: writes the deterministic simulated TurtleBot run as a rosbag, plus the
// ground-truth map, for the demo and the tests.
//
//   simulate_session --bag FILE.bag --truth PREFIX [--seed N]
//
// Topics: /scan (LaserScan, frame "laser"), /tf (odom -> base_footprint -> base_link),
// /tf_static (base_link -> laser: x 0.10, z 0.26), /odom (nav_msgs/Odometry).
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

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/sim/session.h"
#include "planar_transform.h"

using octo_slice_mapper::sim::Pose2D;
using octo_slice_mapper::tools::planarTransform;

namespace {

const double kStartTime = 1000.0;  // bag time of t = 0 (ROS time 0 means "unset")

void usage() {
  std::cerr << "usage: simulate_session --bag FILE.bag --truth PREFIX [--seed N]\n";
}

}  // namespace

int main(int argc, char** argv) {
  std::string bag_path, truth_prefix;
  auto spec = octo_slice_mapper::sim::SessionSpec::officeTour();
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--bag" && i + 1 < argc) bag_path = argv[++i];
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
  if (!octo_slice_mapper::savePgmYaml(truth, truth_prefix, &error)) {
    std::cerr << "simulate_session: " << error << "\n";
    return 1;
  }

  const std::string tmp_bag = bag_path + ".partial";
  try {
    rosbag::Bag bag(tmp_bag, rosbag::bagmode::Write);
    const ros::Time t0(kStartTime);
    tf2_msgs::TFMessage statics;
    statics.transforms.push_back(
        planarTransform("base_link", "laser", t0, spec.lidar.mount_x, 0.0, spec.lidar.mount_z, 0.0));
    auto latched = boost::make_shared<ros::M_string>();
    (*latched)["latching"] = "1";
    (*latched)["callerid"] = "/simulate_session";
    (*latched)["type"] = ros::message_traits::datatype<tf2_msgs::TFMessage>();
    (*latched)["md5sum"] = ros::message_traits::md5sum<tf2_msgs::TFMessage>();
    (*latched)["message_definition"] = ros::message_traits::definition<tf2_msgs::TFMessage>();
    bag.write("/tf_static", t0, statics, latched);

    for (const Pose2D& p : session.poses()) {
      const ros::Time stamp(kStartTime + p.t);
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(planarTransform("odom", "base_footprint", stamp, p.x, p.y, 0.0, p.yaw));
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
    std::size_t count = 0;
    for (double t : session.scanTimes()) {
      const octo_slice_mapper::Scan scan = session.scanAt(t, &rng);
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
      bag.write("/scan", msg.header.stamp, msg);
      ++count;
    }
    bag.close();
    if (std::rename(tmp_bag.c_str(), bag_path.c_str()) != 0) {
      std::cerr << "simulate_session: cannot rename " << tmp_bag << ": " << std::strerror(errno) << "\n";
      return 1;
    }
    std::cout << "simulate_session: wrote " << bag_path << " (" << count << " scans, " << session.duration()
              << " s) and " << truth_prefix << ".{pgm,yaml}\n";
  } catch (const std::exception& e) {
    std::remove(tmp_bag.c_str());
    std::cerr << "simulate_session: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
