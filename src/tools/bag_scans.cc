#include "bag_scans.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <deque>
#include <optional>
#include <set>

#include "ros/laser_scan_conversion.h"
#include "ros/point_cloud_conversion.h"
#include "ros/tf_lookup.h"

namespace octo_slice_mapper {
namespace tools {
namespace {

std::string absoluteTopic(const std::string& topic) { return topic.empty() || topic[0] == '/' ? topic : "/" + topic; }

// One sensor message read and held (`held`) until tf can place it; then converted to the core's
// type and handed on, or, where it cannot be, the reason counted. A message of the wrong type is
// counted at once.
template <typename Msg, typename Core, typename Convert, typename Held>
void hold(const rosbag::MessageInstance& m, const char* wrong_type, const char* no_transform, Convert convert,
          const std::function<void(const Core&)>& hand_on, std::map<std::string, std::size_t>* skipped,
          std::deque<Held>* held) {
  const boost::shared_ptr<const Msg> msg = m.instantiate<Msg>();
  if (!msg) {
    (*skipped)[wrong_type]++;
    return;
  }
  const std::function<void(const Core&)>* on = &hand_on;  // the caller's, which outlives the bag's reading
  held->push_back({m.getTime(), msg->header.stamp, msg->header.frame_id, m.size(), [=](const Eigen::Isometry3d* pose) {
                     if (!pose) {
                       (*skipped)[no_transform]++;
                       return;
                     }
                     Core core;
                     const ros_adapter::ScanRejection rejection = convert(msg, *pose, &core);
                     if (rejection.rejected()) {
                       (*skipped)[rejection.key]++;
                       return;
                     }
                     if (*on) (*on)(core);
                   }});
}

}  // namespace

// The bag is read once, in its order: tf as it comes, each sensor message held until tf can place
// it (as the node's tf filter holds it). A pass over the bag's tf of its own would read every
// chunk of a camera's bag, since its tf lies in the chunks beside the clouds: the whole bag twice.
bool readBag(const std::string& path, const BagTopics& topics, const std::string& fixed_frame,
             const BagHandlers& handlers, std::map<std::string, std::size_t>* skipped, std::string* error,
             const std::function<void(double)>& progress, const std::string& floor_base_frame) {
  try {
    rosbag::Bag bag(path, rosbag::bagmode::Read);
    const ros_adapter::FloorBase base = ros_adapter::floorBaseOf(floor_base_frame);
    const std::set<std::string> tf_topics = {"/tf", "/tf_static"};
    std::set<std::string> scan_topics;  // absolute names
    std::vector<std::string> wanted;  // as given, and absolute (a bag may record either)
    for (const std::string& t : topics.scans) {
      if (t.empty()) continue;
      scan_topics.insert(absoluteTopic(t));
      wanted.push_back(t), wanted.push_back(absoluteTopic(t));
    }
    for (const std::string& t : topics.clouds) {
      if (!t.empty()) wanted.push_back(t), wanted.push_back(absoluteTopic(t));
    }
    if (wanted.empty()) {
      *error = "no scan or cloud topic given";
      return false;
    }
    rosbag::View sensors(bag, rosbag::TopicQuery(wanted));
    const std::size_t total = sensors.size();
    if (total == 0) {
      std::string names;
      std::size_t count = 0;
      for (const auto* list : {&topics.scans, &topics.clouds}) {
        for (const std::string& t : *list) {
          if (!t.empty()) names += (count++ ? ", '" : "'") + t + "'";
        }
      }
      *error = path + ": no messages on topic" + (count > 1 ? "s " : " ") + names;
      return false;
    }
    std::vector<std::string> read = wanted;
    for (const std::string& t : tf_topics) read.push_back(t), read.push_back(t.substr(1));  // absolute, and as recorded without '/'
    rosbag::View view(bag, rosbag::TopicQuery(read));
    // Every transform of the bag is kept: a message may be stamped long before it was recorded.
    tf2::BufferCore buffer(view.getEndTime() - view.getBeginTime() + ros::Duration(10.0));
    // Sensor messages read and not yet placed, in the bag's order; each is placed once tf can
    // place it, or given up (its transform is not coming: counted) once the bag has gone kTfWait
    // past it (bag time: slow tf, a second apart, still places every message) or the messages
    // held pass kMaxHeldBytes (a camera's 5 MB frames at 30 Hz: 3 s), or at the end of the bag.
    const ros::Duration kTfWait(5.0);
    constexpr std::size_t kMaxHeldBytes = std::size_t{512} << 20;
    struct Held {
      ros::Time recorded, stamp;
      std::string frame;
      std::size_t bytes;  // as serialized
      std::function<void(const Eigen::Isometry3d*)> place;  // null: no transform
    };
    std::deque<Held> held;
    std::size_t held_bytes = 0;
    const auto placeReady = [&](const ros::Time& now, bool end) {
      while (!held.empty()) {
        Held& h = held.front();
        const bool ready = buffer.canTransform(fixed_frame, h.frame, h.stamp);
        if (!ready && !end && now < h.recorded + kTfWait && held_bytes <= kMaxHeldBytes) return;
        const std::optional<Eigen::Isometry3d> pose =
            ready ? ros_adapter::lookupPose(buffer, fixed_frame, h.frame, h.stamp) : std::nullopt;
        h.place(pose ? &*pose : nullptr);
        held_bytes -= h.bytes;
        held.pop_front();
      }
    };
    std::size_t seen = 0;
    for (const rosbag::MessageInstance& m : view) {
      const std::string topic = absoluteTopic(m.getTopic());
      if (tf_topics.count(topic)) {
        if (const auto tf = m.instantiate<tf2_msgs::TFMessage>()) {
          const bool is_static = topic == "/tf_static";
          for (const auto& t : tf->transforms) {
            try {
              buffer.setTransform(t, "bag", is_static);
            } catch (const tf2::TransformException&) {
              (*skipped)["bad_tf"]++;
            }
          }
        }
        placeReady(m.getTime(), false);
        continue;
      }
      if (progress && seen++ % 100 == 0) progress(double(seen) / total);
      const std::size_t before = held.size();
      if (scan_topics.count(topic)) {
        hold<sensor_msgs::LaserScan, Scan>(
            m, "not_a_laser_scan", "no_transform",
            [](const sensor_msgs::LaserScan::ConstPtr& msg, const Eigen::Isometry3d& pose, Scan* out) {
              return ros_adapter::toCoreScan(*msg, pose, out);
            },
            handlers.scan, skipped, &held);
      } else {
        hold<sensor_msgs::PointCloud2, DeferredCloud>(
            m, "cloud_not_a_point_cloud2", "cloud_no_transform",
            [&](const sensor_msgs::PointCloud2::ConstPtr& msg, const Eigen::Isometry3d& pose, DeferredCloud* out) {
              const ros_adapter::ScanRejection rejection = ros_adapter::toDeferredCloud(msg, pose, out);
              // None where there is none: mapped all the same, its floor found from its points alone.
              if (!rejection.rejected()) out->ground = ros_adapter::groundPoint(buffer, fixed_frame, base, msg->header.stamp);
              return rejection;
            },
            handlers.cloud, skipped, &held);
      }
      if (held.size() > before) held_bytes += held.back().bytes;
      placeReady(m.getTime(), false);
    }
    placeReady(ros::TIME_MAX, true);
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

bool readBagScans(const std::string& path, const std::string& scan_topic, const std::string& fixed_frame,
                  BagScans* out, std::string* error, const std::function<void(double)>& progress) {
  BagHandlers handlers;
  handlers.scan = [out](const Scan& scan) { out->scans.push_back(scan); };
  return readBag(path, BagTopics{{scan_topic}, {}}, fixed_frame, handlers, &out->skipped, error, progress);
}

}  // namespace tools
}  // namespace octo_slice_mapper
