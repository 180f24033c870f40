#include "bag_scans.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_msgs/TFMessage.h>

#include "ros/laser_scan_conversion.h"

namespace octo_slice_mapper {
namespace tools {

bool readBagScans(const std::string& path, const std::string& scan_topic, const std::string& fixed_frame,
                  BagScans* out, std::string* error, const std::function<void(double)>& progress) {
  try {
    rosbag::Bag bag(path, rosbag::bagmode::Read);
    // Pass 1: all of the bag's tf, so a scan can use transforms recorded just after it.
    rosbag::View tf_view(bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static", "tf", "tf_static"}));
    const ros::Duration span = tf_view.getEndTime() - tf_view.getBeginTime();
    tf2::BufferCore buffer(span + ros::Duration(10.0));
    for (const rosbag::MessageInstance& m : tf_view) {
      const auto tf = m.instantiate<tf2_msgs::TFMessage>();
      if (!tf) continue;
      const bool is_static = m.getTopic().find("tf_static") != std::string::npos;
      for (const auto& t : tf->transforms) {
        try {
          buffer.setTransform(t, "bag", is_static);
        } catch (const tf2::TransformException&) {
          out->skipped["bad_tf"]++;
        }
      }
    }
    // Pass 2: the scans.
    const std::string topic = scan_topic.empty() || scan_topic[0] == '/' ? scan_topic : "/" + scan_topic;
    rosbag::View view(bag, rosbag::TopicQuery(std::vector<std::string>{topic, scan_topic}));
    const std::size_t total = view.size();
    std::size_t seen = 0;
    for (const rosbag::MessageInstance& m : view) {
      if (progress && seen++ % 100 == 0) progress(total ? double(seen) / total : 1.0);
      const auto msg = m.instantiate<sensor_msgs::LaserScan>();
      if (!msg) {
        out->skipped["not_a_laser_scan"]++;
        continue;
      }
      Eigen::Isometry3d pose;
      try {
        pose = tf2::transformToEigen(buffer.lookupTransform(fixed_frame, msg->header.frame_id, msg->header.stamp));
      } catch (const tf2::TransformException&) {
        out->skipped["no_transform"]++;
        continue;
      }
      Scan scan;
      const ros_adapter::ScanRejection rejection = ros_adapter::toCoreScan(*msg, pose, &scan);
      if (rejection.rejected()) {
        out->skipped[rejection.key]++;
        continue;
      }
      out->scans.push_back(std::move(scan));
    }
    if (view.size() == 0) {
      *error = path + ": no messages on topic '" + scan_topic + "'";
      return false;
    }
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

}  // namespace tools
}  // namespace octo_slice_mapper
