// bench_live_latency: drives mapper_node through a real roscore like a fast lidar would, and
// measures how soon each scan shows up in the published map (bench/run_live_latency starts it).
//
// A UTM-30LX-like lidar (1081 beams over 270 deg, 30 m) at ~rate Hz drives the simulated office tour
// in real time: /tf odom -> base_link and the scan, both stamped now. The mapper answers each scan
// with a map_updates message stamped with the scan's stamp; latency = arrival - stamp. Reports
// median and p99 over the first and the last third of the run (a small and a grown map), scans
// without an answer (dropped), the mapper's CPU share (from /proc), and the full map's size; and
// of the background global pass (~online_optimize): the optimized maps received, and from
// /diagnostics the passes done, the longest pass and how far the published optimized map lagged
// behind the newest scan at most and at the end.
// With ~camera_rate > 0 (camera:=true in live_latency.launch) a Kinect-class depth camera runs
// beside the lidar: organized 640 x 480 PointCloud2 frames on camera_depth_optical_frame at that
// rate, answered and measured like the scans. Its frames are rendered before the clock
// starts (a second's worth along the tour, then again: each frame's rays cost the mapper what a
// live one would, though after the first second they no longer fit the robot's pose).
// With ~listen_voxels the bench also subscribes to ~occupied_voxels, so that the node walks its
// octree and publishes the cloud (it does only while someone listens): what that costs the scans.
// Both subscriptions ask for TCP_NODELAY, as a latency-minded client should: without it the
// node's small map_updates messages sit in the kernel (Nagle's algorithm meeting the client's
// delayed ACK) and ~1 % of them arrive ~20 ms late (measured: p99 20.5 ms against 3 ms).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <map_msgs/OccupancyGridUpdate.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/transform_broadcaster.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.h"
#include "octo_slice_mapper/sim/depth_camera.h"
#include "octo_slice_mapper/sim/session.h"
#include "planar_transform.h"
#include "ros/point_cloud_conversion.h"

namespace osm = octo_slice_mapper;

namespace {

// CPU ticks (user + system) of the newest process whose command line starts with `name`.
long cpuTicksOf(const std::string& name, int* pid_out) {
  FILE* p = ::popen(("pgrep -n -f '^[^ ]*" + name + "'").c_str(), "r");
  int pid = 0;
  if (p) {
    if (std::fscanf(p, "%d", &pid) != 1) pid = 0;
    ::pclose(p);
  }
  *pid_out = pid;
  if (!pid) return -1;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(stat, line);
  std::istringstream in(line.substr(line.rfind(')') + 2));
  std::string field;
  long utime = 0, stime = 0;
  for (int k = 3; k <= 15 && in >> field; ++k) {
    if (k == 14) utime = std::stol(field);
    if (k == 15) stime = std::stol(field);
  }
  return utime + stime;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()))];
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_live_latency");
  ros::NodeHandle nh, pnh("~");
  double duration = 60.0, rate = 40.0, camera_rate = 0.0;
  bool listen_voxels = false;
  pnh.param("listen_voxels", listen_voxels, listen_voxels);
  pnh.param("duration", duration, duration);
  pnh.param("rate", rate, rate);
  pnh.param("camera_rate", camera_rate, camera_rate);

  osm::sim::SessionSpec spec = osm::sim::SessionSpec::officeTour();
  spec.lidar.beams = 1081;
  spec.lidar.angle_min = static_cast<float>(-0.75 * M_PI);
  spec.lidar.angle_increment = static_cast<float>(1.5 * M_PI / 1080);
  spec.lidar.range_max = 30.0f;
  spec.lidar.rate_hz = rate;
  const osm::sim::SimulatedSession session(osm::sim::FloorPlan::office(), spec);

  std::map<double, double> latency_by_stamp;  // scan stamp -> latency (s)
  std::size_t full_maps = 0, map_cells = 0;
  // The incremental slice answers every scan (map itself turns to the global pass's map once the
  // background pass has a result).
  ros::Subscriber updates = nh.subscribe<map_msgs::OccupancyGridUpdate>(
      "mapper_node/incremental_map_updates", 1000, [&](const map_msgs::OccupancyGridUpdate::ConstPtr& u) {
        latency_by_stamp.emplace(u->header.stamp.toSec(), (ros::Time::now() - u->header.stamp).toSec());
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ros::Subscriber maps = nh.subscribe<nav_msgs::OccupancyGrid>("mapper_node/incremental_map", 5, [&](const nav_msgs::OccupancyGrid::ConstPtr& m) {
    ++full_maps;
    map_cells = m->data.size();
    // When a scan grows the grid the node answers it with the whole map (stamped with the scan)
    // instead of an update; the periodic full maps carry other stamps and match no scan.
    latency_by_stamp.emplace(m->header.stamp.toSec(), (ros::Time::now() - m->header.stamp).toSec());
  }, ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  std::size_t voxel_clouds = 0, voxels_at_end = 0;
  ros::Subscriber voxels;
  if (listen_voxels) {
    voxels = nh.subscribe<sensor_msgs::PointCloud2>("mapper_node/occupied_voxels", 2,
                                                    [&](const sensor_msgs::PointCloud2::ConstPtr& c) {
                                                      ++voxel_clouds;
                                                      voxels_at_end = c->width;
                                                    });
  }
  std::size_t optimized_maps = 0;
  ros::Subscriber optimized = nh.subscribe<nav_msgs::OccupancyGrid>(
      "mapper_node/optimized_map", 5, [&](const nav_msgs::OccupancyGrid::ConstPtr&) { ++optimized_maps; });
  double online_passes = 0.0, longest_pass = 0.0, max_age = 0.0, last_age = 0.0;
  ros::Subscriber diagnostics = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& a) {
        for (const auto& status : a->status) {
          for (const auto& kv : status.values) {
            const double v = std::atof(kv.value.c_str());
            if (kv.key == "online_passes") online_passes = v;
            if (kv.key == "online_pass_s") longest_pass = std::max(longest_pass, v);
            if (kv.key == "optimized_map_age_s" && online_passes > 0) max_age = std::max(max_age, v), last_age = v;
          }
        }
      });
  ros::Publisher scan_pub = nh.advertise<sensor_msgs::LaserScan>("scan", 100);
  ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("camera/depth/points", 5);
  tf2_ros::TransformBroadcaster tf;
  tf2_ros::StaticTransformBroadcaster static_tf;
  std::vector<geometry_msgs::TransformStamped> statics{
      osm::tools::planarTransform("base_link", "laser", ros::Time::now(), spec.lidar.mount_x, 0, spec.lidar.mount_z, 0)};
  const osm::sim::CameraMount mount;
  const Eigen::Isometry3d optical_on_base = osm::sim::cameraLinkOnBase(mount) * osm::sim::opticalOnCameraLink();
  if (camera_rate > 0.0) {
    geometry_msgs::TransformStamped t = tf2::eigenToTransform(optical_on_base);
    t.header.frame_id = "base_link";
    t.header.stamp = ros::Time::now();
    t.child_frame_id = "camera_depth_optical_frame";
    statics.push_back(t);
  }
  static_tf.sendTransform(statics);
  ros::AsyncSpinner spinner(1);
  spinner.start();
  const ros::WallTime wait_until = ros::WallTime::now() + ros::WallDuration(20.0);
  while (ros::ok() && scan_pub.getNumSubscribers() == 0 && ros::WallTime::now() < wait_until) ros::WallDuration(0.05).sleep();
  ros::WallDuration(0.5).sleep();

  // The scans are simulated before the clock starts: ray casting 1081 beams 40 times a second
  // would load the 2 cores the mapper runs on and be measured as its latency.
  std::mt19937 rng(spec.seed);
  std::vector<osm::Scan> scans;
  std::vector<osm::sim::Pose2D> poses;
  for (std::size_t k = 0; k < static_cast<std::size_t>(duration * rate) + 1; ++k) {
    const double t = std::fmod(k / rate, session.duration());
    poses.push_back(session.poseAt(t));
    scans.push_back(session.scanAt(t, &rng));
  }
  std::vector<sensor_msgs::PointCloud2> frames;
  if (camera_rate > 0.0) {
    const osm::sim::BoxScene scene = osm::sim::BoxScene::of(session.plan());
    const osm::sim::DepthCameraSpec full;  // 640 x 480
    for (int k = 0; k < int(std::ceil(camera_rate)); ++k) {
      const osm::sim::Pose2D p = session.poseAt(k / camera_rate);
      const auto points = osm::sim::depthFrame(scene, osm::sim::opticalOnRobot(mount, p.x, p.y, p.yaw), full, &rng);
      frames.push_back(osm::ros_adapter::organizedCloud(points, full.width, full.height, "camera_depth_optical_frame"));
    }
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(10.0);
    while (ros::ok() && cloud_pub.getNumSubscribers() == 0 && ros::WallTime::now() < until) ros::WallDuration(0.05).sleep();
  }
  int pid = 0;
  const long ticks0 = cpuTicksOf("mapper_node", &pid);
  std::vector<double> stamps, cloud_stamps;
  double next_cloud = 0.0;  // wall seconds since the start
  ros::Rate loop(rate);
  const ros::WallTime start = ros::WallTime::now();
  for (std::size_t k = 0; ros::ok() && k < scans.size() && (ros::WallTime::now() - start).toSec() < duration; ++k) {
    const osm::sim::Pose2D& pose = poses[k];
    const osm::Scan& scan = scans[k];
    const ros::Time stamp = ros::Time::now();
    tf.sendTransform(osm::tools::planarTransform("odom", "base_link", stamp, pose.x, pose.y, 0.0, pose.yaw));
    sensor_msgs::LaserScan msg;
    msg.header.stamp = stamp;
    msg.header.frame_id = "laser";
    msg.angle_min = scan.angle_min;
    msg.angle_increment = scan.angle_increment;
    msg.angle_max = scan.angle_min + scan.angle_increment * (scan.ranges.size() - 1);
    msg.range_min = scan.range_min;
    msg.range_max = scan.range_max;
    msg.ranges = scan.ranges;
    // The transform goes out first; a second sample just after lets tf interpolate at this stamp.
    tf.sendTransform(osm::tools::planarTransform("odom", "base_link", stamp + ros::Duration(1e-3), pose.x, pose.y, 0.0, pose.yaw));
    scan_pub.publish(msg);
    stamps.push_back(stamp.toSec());
    // The camera's frames due by now, each stamped when sent, with the base's pose at that stamp.
    while (!frames.empty() && (ros::WallTime::now() - start).toSec() >= next_cloud) {
      sensor_msgs::PointCloud2& cloud = frames[cloud_stamps.size() % frames.size()];
      cloud.header.stamp = ros::Time::now();
      if (cloud.header.stamp.toSec() == stamp.toSec()) cloud.header.stamp += ros::Duration(1e-6);  // its own stamp
      tf.sendTransform(osm::tools::planarTransform("odom", "base_link", cloud.header.stamp + ros::Duration(1e-3), pose.x,
                                                   pose.y, 0.0, pose.yaw));
      cloud_pub.publish(cloud);
      cloud_stamps.push_back(cloud.header.stamp.toSec());
      next_cloud += 1.0 / camera_rate;
    }
    loop.sleep();
  }
  const double wall = (ros::WallTime::now() - start).toSec();
  const long ticks1 = cpuTicksOf("mapper_node", &pid);
  ros::WallDuration(1.0).sleep();  // the last updates
  spinner.stop();

  const std::size_t third = stamps.size() / 3;
  std::vector<double> early, late;
  std::size_t dropped = 0;
  for (std::size_t k = 0; k < stamps.size(); ++k) {
    const auto it = latency_by_stamp.find(stamps[k]);
    if (it == latency_by_stamp.end()) {
      ++dropped;
      continue;
    }
    if (k < third) early.push_back(it->second * 1000.0);
    if (k >= stamps.size() - third) late.push_back(it->second * 1000.0);
  }
  std::vector<double> cloud_latency;
  std::size_t clouds_dropped = 0;
  for (double st : cloud_stamps) {
    const auto it = latency_by_stamp.find(st);
    if (it == latency_by_stamp.end()) ++clouds_dropped;
    else cloud_latency.push_back(it->second * 1000.0);
  }
  const double cpu = ticks0 >= 0 && ticks1 >= 0 ? double(ticks1 - ticks0) / ::sysconf(_SC_CLK_TCK) / wall : -1.0;
  std::printf("{\"bench\": \"live_latency\", \"scans\": %zu, \"rate_hz\": %.1f, \"beams\": %d, \"seconds\": %.1f, "
              "\"dropped\": %zu, \"latency_ms_first_third\": {\"median\": %.2f, \"p99\": %.2f}, "
              "\"latency_ms_last_third\": {\"median\": %.2f, \"p99\": %.2f}, \"mapper_cpu_share\": %.3f, "
              "\"full_maps_received\": %zu, \"map_cells_at_end\": %zu, \"optimized_maps_received\": %zu, "
              "\"online_passes\": %.0f, \"longest_online_pass_s\": %.2f, \"optimized_map_age_s\": {\"max\": %.2f, "
              "\"last\": %.2f}, \"camera_hz\": %.1f, \"clouds\": %zu, \"clouds_dropped\": %zu, "
              "\"cloud_latency_ms\": {\"median\": %.2f, \"p99\": %.2f}, \"voxel_clouds\": %zu, "
              "\"occupied_voxels_at_end\": %zu}\n",
              stamps.size(), rate, spec.lidar.beams, wall, dropped, osm::bench::median(early), percentile(early, 0.99),
              osm::bench::median(late), percentile(late, 0.99), cpu, full_maps, map_cells, optimized_maps, online_passes,
              longest_pass, max_age, last_age, camera_rate, cloud_stamps.size(), clouds_dropped,
              osm::bench::median(cloud_latency), percentile(cloud_latency, 0.99), voxel_clouds, voxels_at_end);
  std::fflush(stdout);
  ros::shutdown();
  return 0;
}
