// libFuzzer target: any PointCloud2 layout (fields, offsets, types, width, height, point_step,
// row_step, byte order, data) and sensor pose through the node's checks and conversion and into
// the octree (a cloud declaring more points than its data holds must be refused, not read). The
// message is built field by field, as in fuzz_laser_scan.
#include <fuzzer/FuzzedDataProvider.h>
#include <sensor_msgs/PointCloud2.h>

#include "octo_slice_mapper/internal/scan_inserter.h"
#include "ros/point_cloud_conversion.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace osm = octo_slice_mapper;
  FuzzedDataProvider in(data, size);
  float pose[3];
  for (float& p : pose) p = in.ConsumeFloatingPoint<float>();
  sensor_msgs::PointCloud2 msg;
  static const char* kNames[] = {"x", "y", "z", "rgb", "intensity"};
  const int fields = in.ConsumeIntegralInRange<int>(0, 6);
  for (int k = 0; k < fields; ++k) {
    sensor_msgs::PointField f;
    f.name = kNames[in.ConsumeIntegralInRange<int>(0, 4)];
    f.offset = in.ConsumeIntegral<std::uint32_t>() % 64;
    f.datatype = in.ConsumeIntegralInRange<std::uint8_t>(0, 9);
    f.count = in.ConsumeIntegralInRange<std::uint32_t>(0, 2);
    msg.fields.push_back(f);
  }
  msg.width = in.ConsumeIntegral<std::uint32_t>();
  msg.height = in.ConsumeIntegral<std::uint32_t>();
  if (in.ConsumeBool()) msg.width %= 64, msg.height %= 8;  // often small enough to be inserted
  msg.point_step = in.ConsumeIntegral<std::uint32_t>() % 64;
  msg.row_step = in.ConsumeBool() ? msg.width * msg.point_step : in.ConsumeIntegral<std::uint32_t>();
  msg.is_bigendian = in.ConsumeBool();
  msg.data = in.ConsumeRemainingBytes<std::uint8_t>();
  if (osm::ros_adapter::checkCloudLayout(msg).rejected()) return 0;
  Eigen::Isometry3f to_map = Eigen::Isometry3f::Identity();
  to_map.translation() = Eigen::Vector3f(pose[0], pose[1], pose[2]);
  std::vector<Eigen::Vector3f> points;
  osm::ReadingCounts left_out;
  osm::ros_adapter::cloudPointsInMap(msg, to_map, &points, &left_out);
  // Every point either converted (finite) or counted.
  if (points.size() + left_out.skipped() != std::uint64_t(msg.width) * msg.height) __builtin_trap();
  // The same with the flying-pixel filter, which streams the frame's rows: again every point
  // converted or counted, and never more points than without it.
  std::vector<Eigen::Vector3f> kept;
  osm::ReadingCounts kept_left_out;
  const osm::FlyingPixelOptions flying;
  osm::ros_adapter::cloudPointsInMap(msg, to_map, &kept, &kept_left_out, &flying);
  if (kept.size() + kept_left_out.skipped() != std::uint64_t(msg.width) * msg.height) __builtin_trap();
  if (kept.size() > points.size()) __builtin_trap();
  octomap::OcTree tree(0.1);
  osm::InsertOptions insert;
  insert.max_range = 20.0;  // bounded work per input
  osm::ScanInserter inserter(&tree, insert);
  inserter.insertPoints(to_map.translation().cast<double>(), points, 0.002);
  inserter.flush();
  return 0;
}
