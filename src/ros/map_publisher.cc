#include "ros/map_publisher.h"

#include <map_msgs/OccupancyGridUpdate.h>
#include <nav_msgs/MapMetaData.h>
#include <nav_msgs/OccupancyGrid.h>
#include <visualization_msgs/MarkerArray.h>

#include "ros/map_conversion.h"

namespace octo_slice_mapper {
namespace ros_adapter {

MapPublisher::MapPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, std::string frame_id, bool publish_markers)
    : frame_id_(std::move(frame_id)), publish_markers_(publish_markers) {
  map_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("map", 1, true);
  metadata_pub_ = nh.advertise<nav_msgs::MapMetaData>("map_metadata", 1, true);
  // What each scan changed, right after it is inserted (rviz's Map display reads TOPIC_updates).
  updates_pub_ = nh.advertise<map_msgs::OccupancyGridUpdate>("map_updates", 100);
  incremental_pub_ = pnh.advertise<nav_msgs::OccupancyGrid>("incremental_map", 1, true);
  incremental_updates_pub_ = pnh.advertise<map_msgs::OccupancyGridUpdate>("incremental_map_updates", 100);
  markers_pub_ = pnh.advertise<visualization_msgs::MarkerArray>("occupied_cells", 1, true);
  optimized_pub_ = pnh.advertise<nav_msgs::OccupancyGrid>("optimized_map", 1, true);
}

void MapPublisher::publishChange(MappingSession& session, const KeyBox& touched, const ros::Time& stamp) {
  if (touched.empty()) return;
  map_msgs::OccupancyGridUpdate update;
  bool send_full = false, send_update = false;
  // For a moment after the grid grew, whole maps instead of updates: the small update can reach a
  // subscriber before the large map it refers to, and rviz's Map display then rejects it ("Update
  // area outside of original map area", red from then on; seen with the depth camera, whose
  // frames grow the grid as the robot looks into new rooms).
  const std::int64_t now = ros::WallTime::now().toNSec();
  const bool settling = now < whole_maps_until_ns_;
  session.withMapper([&](const Mapper& mapper) {
    send_full = settling || mapper.slice().geometry() != published_geometry_;
    send_update = !send_full && toOccupancyGridUpdate(mapper.slice(), touched, frame_id_, stamp, &update);
  });
  if (send_full && !settling) whole_maps_until_ns_ = now + kSettleNs;
  if (send_full) publishFull(session, stamp, /*with_markers=*/false);
  if (!send_update) return;
  incremental_updates_pub_.publish(update);
  std::lock_guard<std::mutex> lock(best_mutex_);
  if (!has_best_) updates_pub_.publish(update);
}

void MapPublisher::publishSlice(const nav_msgs::OccupancyGrid& grid) {
  incremental_pub_.publish(grid);
  std::lock_guard<std::mutex> lock(best_mutex_);
  if (has_best_) return;
  map_pub_.publish(grid);
  metadata_pub_.publish(grid.info);
}

void MapPublisher::publishBest(const nav_msgs::OccupancyGrid& grid) {
  std::lock_guard<std::mutex> lock(best_mutex_);
  has_best_ = true;
  if (!ros::ok()) return;
  map_pub_.publish(grid);
  metadata_pub_.publish(grid.info);
}

void MapPublisher::forgetBest(MappingSession& session, const ros::Time& stamp) {
  {
    std::lock_guard<std::mutex> lock(best_mutex_);
    has_best_ = false;
  }
  publishFull(session, stamp, /*with_markers=*/false);
}

void MapPublisher::publishFull(MappingSession& session, const ros::Time& stamp, bool with_markers) {
  // One at a time (the scan thread, the timer and the services all send whole maps): an older
  // map sent after a newer one would stay latched while updates refer to the newer one.
  std::lock_guard<std::mutex> one_at_a_time(full_mutex_);
  nav_msgs::OccupancyGrid grid;
  visualization_msgs::MarkerArray markers;
  published_changes_ = session.changes();  // before the copy: a change during it is sent again next time
  const bool markers_wanted = with_markers && publish_markers_ && markers_pub_.getNumSubscribers() > 0;
  session.withMapper([&](Mapper& mapper) {  // the markers' tree() flushes the insertion cache
    published_geometry_ = mapper.slice().geometry();
    toOccupancyGrid(mapper.slice(), frame_id_, stamp, &grid);
    if (markers_wanted) markers = occupiedVoxelMarkers(mapper.tree(), frame_id_, stamp);
  });
  publishSlice(grid);
  if (!markers.markers.empty()) markers_pub_.publish(markers);
}

void MapPublisher::publishIfChanged(MappingSession& session, const ros::Time& stamp) {
  if (session.changes() != published_changes_) publishFull(session, stamp, /*with_markers=*/true);
}

void MapPublisher::publishOptimized(const GridImage& grid, double slice_min_z, bool as_best) {
  nav_msgs::OccupancyGrid msg;
  toOccupancyGrid(grid, slice_min_z, frame_id_, ros::Time::now(), &msg);
  if (ros::ok()) optimized_pub_.publish(msg);
  if (as_best) publishBest(msg);
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
