// libFuzzer target: any LaserScan contents (angles, limits, ranges, intensities, frame) and sensor
// pose through the node's conversion and into the octree. The message is built field by field:
// roscpp's wire deserializer is not ours to test (it allocates whatever length a header claims).
#include <fuzzer/FuzzedDataProvider.h>
#include <sensor_msgs/LaserScan.h>

#include <cmath>

#include "octo_slice_mapper/internal/scan_inserter.h"
#include "ros/laser_scan_conversion.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace osm = octo_slice_mapper;
  FuzzedDataProvider in(data, size);
  double pose[6];
  for (double& p : pose) p = in.ConsumeFloatingPoint<double>();
  sensor_msgs::LaserScan msg;
  msg.header.frame_id = in.ConsumeRandomLengthString(16);
  msg.angle_min = in.ConsumeFloatingPoint<float>();
  msg.angle_max = in.ConsumeFloatingPoint<float>();
  msg.angle_increment = in.ConsumeFloatingPoint<float>();
  msg.range_min = in.ConsumeFloatingPoint<float>();
  msg.range_max = in.ConsumeFloatingPoint<float>();
  const std::size_t beams = in.ConsumeIntegralInRange<std::size_t>(0, 2048);
  const bool with_intensities = in.ConsumeBool();
  for (std::size_t i = 0; i < beams && in.remaining_bytes() > 0; ++i) {
    msg.ranges.push_back(in.ConsumeFloatingPoint<float>());
    if (with_intensities) msg.intensities.push_back(in.ConsumeFloatingPoint<float>());
  }
  if (in.ConsumeBool()) msg.intensities.resize(in.ConsumeIntegralInRange<std::size_t>(0, 8));
  Eigen::Isometry3d sensor = Eigen::Isometry3d::Identity();
  sensor.translation() = Eigen::Vector3d(pose[0], pose[1], pose[2]);
  sensor.linear() = (Eigen::AngleAxisd(pose[3], Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(pose[4], Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(pose[5], Eigen::Vector3d::UnitX())).toRotationMatrix();
  osm::Scan scan;
  if (osm::ros_adapter::toCoreScan(msg, sensor, &scan).rejected()) return 0;
  octomap::OcTree tree(0.1);
  osm::InsertOptions insert;
  insert.max_range = 20.0;  // bounded work per input
  osm::ScanInserter inserter(&tree, insert);
  inserter.insert(scan);
  inserter.flush();  // the cached layer into the octree as well
  return 0;
}
