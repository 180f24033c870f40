// The ROS face of the mapper: tf2-filtered scans in, OccupancyGrid / markers out, save, reset and
// the global pass. All mapping logic lives in the core Mapper; this class only converts and wires.
// Scans (and dynamic_map) are handled in order on the global callback queue; the ~ services run on
// a queue and thread of their own, and save / optimize work on a snapshot, so they don't hold up
// scan insertion.
#pragma once

#include <message_filters/subscriber.h>
#include <nav_msgs/GetMap.h>
#include <nav_msgs/OccupancyGrid.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>
#include <tf2_ros/transform_listener.h>

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "octo_slice_mapper/Optimize.h"
#include "octo_slice_mapper/SaveMap.h"
#include "octo_slice_mapper/mapper.h"
#include "ros/diagnostics.h"
#include "ros/node_parameters.h"
#include "ros/online_pass.h"
#include "ros/pending_messages.h"

namespace octo_slice_mapper {
namespace ros_adapter {

class MapperNode {
 public:
  MapperNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  // Writes ~save_on_shutdown (if set) and logs the session summary.
  void shutdown();
  std::string summary() const;

 private:
  // Scans and clouds the tf filter delivered, in the order they arrived (see PendingMessages).
  // Whether tf has the message's transform now.
  template <typename M>
  bool transformThere(const boost::shared_ptr<const M>& msg);
  void handleReadyScans();
  void handleReadyClouds();
  void insertScan(const sensor_msgs::LaserScan::ConstPtr& msg);
  void insertCloud(const sensor_msgs::PointCloud2::ConstPtr& msg);
  void onScanTransformFailure(const sensor_msgs::LaserScan::ConstPtr& msg, tf2_ros::FilterFailureReason reason);
  template <typename M>
  void onTransformFailure(const boost::shared_ptr<const M>& msg, tf2_ros::FilterFailureReason reason);
  bool sensorPose(const std_msgs::Header& header, Eigen::Isometry3d* pose);
  void skip(const std::string& reason, const std::string& message);
  // A message stamped 0 is skipped as zero_stamp (true).
  bool stampedZero(const std_msgs::Header& header);
  void afterInsert(const InsertResult& result, double seconds, bool from_scan);
  void publish(const ros::TimerEvent&);
  void publishFullMap(const ros::Time& stamp, bool with_markers);
  void publishDiagnostics(const ros::TimerEvent&);
  void expireWaitingScans(const ros::WallTimerEvent&);
  template <typename M>
  void expireWaiting(PendingMessages<M>* waiting, const std::string& what);
  // A scan stamped well before the last one: a bag restarted (--loop) or /clock reset.
  void checkTimeJump(const ros::Time& stamp);
  bool onSaveMap(SaveMap::Request& req, SaveMap::Response& res);
  // True when `requested_prefix` was the last save's and the map has not changed since.
  bool savedAlready(const std::string& requested_prefix) const;
  bool onReset(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool onGetMap(nav_msgs::GetMap::Request&, nav_msgs::GetMap::Response& res);
  bool onOptimize(Optimize::Request& req, Optimize::Response& res);
  // The online pass's input when the map changed since the last one (copied under the map lock).
  std::optional<OnlineOptimizerInput> onlinePassInput();
  void noteServiceLock(const ros::WallTime& since);  // with mutex_ held
  // Writes the global pass's result into the live map's slice band (if ~write_optimized_into_map).
  void applyOptimizedToMap(const GridImage& grid);
  // Ends a snapshot's loan of the octree (at end() or on leaving the scope).
  class OctreeLoan {
   public:
    OctreeLoan(Mapper* mapper, std::mutex* mutex) : mapper_(mapper), mutex_(mutex) {}
    ~OctreeLoan();
    OctreeLoan(const OctreeLoan&) = delete;
    OctreeLoan& operator=(const OctreeLoan&) = delete;
    void end();

   private:
    Mapper* mapper_;
    std::mutex* mutex_;
  };
  // The global pass on a snapshot; publishes ~optimized_map.
  OptimizedMap optimizeSnapshot(const MapSnapshot& snapshot, bool warm_start);

  ros::NodeHandle nh_, pnh_;
  NodeOptions options_;
  Mapper mapper_;
  mutable std::mutex mutex_;  // guards mapper_ and the counters

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  message_filters::Subscriber<sensor_msgs::LaserScan> scan_sub_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::LaserScan>> scan_filter_;
  message_filters::Subscriber<sensor_msgs::PointCloud2> cloud_sub_;
  std::unique_ptr<tf2_ros::MessageFilter<sensor_msgs::PointCloud2>> cloud_filter_;

  ros::Publisher map_pub_, metadata_pub_, map_updates_pub_, markers_pub_, optimized_pub_, diagnostics_pub_;
  ros::CallbackQueue service_queue_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  std::mutex service_mutex_;  // one save / optimize / reset at a time
  ros::ServiceServer save_srv_, reset_srv_, optimize_srv_, get_map_srv_;
  ros::Timer publish_timer_, diagnostics_timer_;
  ros::WallTimer expire_timer_;
  PendingMessages<sensor_msgs::LaserScan> waiting_scans_;
  PendingMessages<sensor_msgs::PointCloud2> waiting_clouds_;

  bool map_changed_ = true;
  // Counts the changes to the map from scans, clouds, resets and ~optimize (not those a save's own
  // global pass writes back), so that ~save_on_shutdown can skip a save that would repeat the last.
  std::uint64_t map_version_ = 0;
  std::string last_saved_prefix_;  // with the map_version_ it saved; guarded by mutex_
  std::uint64_t last_saved_version_ = 0;
  std::uint64_t published_geometry_ = ~std::uint64_t{0};  // slice geometry of the last full map sent
  NodeCounters counters_;  // guarded by mutex_; map sizes filled in when reported
  std::map<std::string, ros::WallTime> last_logged_skip_;  // per skip reason; guarded by mutex_
  std::uint64_t skipped_at_last_report_ = 0;
  ros::Time last_scan_stamp_;
  double insert_seconds_ = 0.0;
  ros::WallTime started_;
  std::uint64_t online_input_version_ = ~std::uint64_t{0};  // map_version_ of the last pass's input
  // Last: its thread reads mapper_ through the node until it is destroyed.
  std::unique_ptr<OnlinePass> online_pass_;
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
