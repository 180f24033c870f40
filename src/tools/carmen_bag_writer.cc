#include "carmen_bag_writer.h"

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>

#include "bag_file.h"
#include "planar_transform.h"

namespace octo_slice_mapper {
namespace tools {

bool writeCarmenBag(CarmenLogReader* reader, const std::string& bag_path, const CarmenBagOptions& options,
                    CarmenBagReport* report, std::string* error, const std::function<void(double)>& progress) {
  return writeBagWhole(bag_path, [&](rosbag::Bag& bag, std::string* why) {
    LogScan record;
    double last_stamp = -1.0;
    bool wrote_static = false;
    while (reader->next(&record)) {
      const Scan& scan = record.scan;
      // Keep time strictly increasing even where the log repeats or lacks stamps.
      double t = scan.stamp > 0.0 ? scan.stamp + options.time_offset : last_stamp + 0.1;
      if (last_stamp >= 0.0 && t <= last_stamp) t = last_stamp + 1e-3;
      if (last_stamp < 0.0 && t <= 0.0) t = options.time_offset;
      last_stamp = t;
      const ros::Time stamp(t);
      const Eigen::Vector3d p = scan.sensor_pose.translation();
      const Eigen::Vector3d x_axis = scan.sensor_pose.linear() * Eigen::Vector3d::UnitX();
      const double yaw = std::atan2(x_axis.y(), x_axis.x());
      if (!wrote_static) {
        tf2_msgs::TFMessage statics;
        statics.transforms.push_back(planarTransform(options.base_frame, options.laser_frame, stamp, 0.0, 0.0, p.z(), 0.0));
        bag.write("/tf_static", stamp, statics);
        wrote_static = true;
      }
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(planarTransform(options.fixed_frame, options.base_frame, stamp, p.x(), p.y(), 0.0, yaw));
      bag.write("/tf", stamp, tf);
      nav_msgs::Odometry odom;
      odom.header.stamp = stamp;
      odom.header.frame_id = options.fixed_frame;
      odom.child_frame_id = options.base_frame;
      odom.pose.pose.position.x = p.x();
      odom.pose.pose.position.y = p.y();
      odom.pose.pose.orientation.z = std::sin(0.5 * yaw);
      odom.pose.pose.orientation.w = std::cos(0.5 * yaw);
      bag.write("/odom", stamp, odom);
      sensor_msgs::LaserScan msg;
      msg.header.stamp = stamp;
      msg.header.frame_id = options.laser_frame;
      msg.header.seq = static_cast<std::uint32_t>(report->scans);
      msg.angle_min = scan.angle_min;
      msg.angle_increment = scan.angle_increment;
      msg.angle_max = scan.angle_min + scan.angle_increment * static_cast<float>(scan.ranges.size() - 1);
      msg.range_min = scan.range_min;
      msg.range_max = scan.range_max;
      msg.ranges = scan.ranges;
      bag.write(options.scan_topic, stamp, msg);
      ++report->scans;
      if (progress && report->scans % 50 == 0 && reader->fileSize()) {
        progress(double(reader->bytesRead()) / reader->fileSize());
      }
    }
    report->bad_lines = reader->problemCount();
    report->log_error = reader->endError();
    if (report->scans == 0) {
      *why = "no laser scans in the log";
      return false;
    }
    return true;
  }, error);
}

}  // namespace tools
}  // namespace octo_slice_mapper
