// sensor_msgs/PointCloud2 -> points in the map frame, after checking that the message's layout
// holds what it declares (pcl::fromROSMsg trusts it: a cloud with less data than width x height x
// point_step would make it read past the buffer; one with point_step 4 or without z is no cloud).
#pragma once

#include <sensor_msgs/PointCloud2.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "ros/laser_scan_conversion.h"

namespace octo_slice_mapper {
namespace ros_adapter {

constexpr std::size_t kMaxPointsPerCloud = 5000000;

// Checks the layout: x, y and z fields of FLOAT32 or FLOAT64, each inside point_step, row_step
// at least width x point_step, data at least row_step x height, host byte order, a sane size.
// A refusal names its diagnostics key (cloud_bad_fields, cloud_bad_layout, cloud_short_data,
// cloud_big_endian, cloud_empty, cloud_too_large).
ScanRejection checkCloudLayout(const sensor_msgs::PointCloud2& msg);

// The cloud's finite points through `to_map` (the sensor frame's pose in the map frame), in the
// message's order; points with a non-finite coordinate are left out and counted into `left_out`
// (kNaN if any coordinate is NaN, else kInfinite). The layout must have passed checkCloudLayout.
// With `flying` (and an organized cloud, height > 2), its flying pixels are left out too and
// counted as kFlyingPixel.
void cloudPointsInMap(const sensor_msgs::PointCloud2& msg, const Eigen::Isometry3f& to_map,
                      std::vector<Eigen::Vector3f>* points, ReadingCounts* left_out,
                      const FlyingPixelOptions* flying = nullptr);

// Both steps: the layout checked, then the points through `sensor_pose` with the sensor's origin.
ScanRejection toCoreCloud(const sensor_msgs::PointCloud2& msg, const Eigen::Isometry3d& sensor_pose, SensorCloud* out);
// The same with the conversion left to whoever prepares the cloud (a CloudPipeline's worker):
// only the layout is checked now; the message is kept alive by the DeferredCloud.
ScanRejection toDeferredCloud(const sensor_msgs::PointCloud2::ConstPtr& msg, const Eigen::Isometry3d& sensor_pose,
                              DeferredCloud* out);

// The other way, as a depth camera's driver sends it: an organized cloud (row by row, x y z
// FLOAT32, NaN kept), for the simulator, the benchmark and the tests.
sensor_msgs::PointCloud2 organizedCloud(const std::vector<Eigen::Vector3f>& points, int width, int height,
                                        const std::string& frame_id);

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
