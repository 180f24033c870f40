// The node's map outputs. `map` (+ `map_metadata`, `map_updates`) carries the best map the node
// has: the incremental slice until the global pass gives a result, that result from then on (a
// planner and rviz read one map, and it is the one that predicts scans best). The incremental
// slice is always on ~incremental_map (+ ~incremental_map_updates: what each scan or cloud
// changed), occupied voxels on ~occupied_cells, and each result of the pass as it came on
// ~optimized_map. Slice messages are built under the session's lock and sent outside it.
#pragma once

#include <ros/ros.h>

#include <nav_msgs/OccupancyGrid.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

#include "octo_slice_mapper/mapping_session.h"

namespace octo_slice_mapper {
namespace ros_adapter {

class MapPublisher {
 public:
  MapPublisher(ros::NodeHandle nh, ros::NodeHandle pnh, std::string frame_id, bool publish_markers);

  // After an insertion that touched `touched`: an update of that part, or the whole map first
  // when the grid grew or moved since it was last sent whole (an update can't describe that).
  void publishChange(MappingSession& session, const KeyBox& touched, const ros::Time& stamp);
  // The whole slice, and the voxel markers when `with_markers` and someone listens.
  void publishFull(MappingSession& session, const ros::Time& stamp, bool with_markers);
  // The whole slice if the map changed since it was last sent whole.
  void publishIfChanged(MappingSession& session, const ros::Time& stamp);
  // A global pass's result (a save's or the optimize service's) on ~optimized_map, and as the
  // best map when `as_best`.
  void publishOptimized(const GridImage& grid, double slice_min_z, bool as_best);
  // A global pass's result becomes the best map: sent whole on `map` (map_updates then carries
  // no slice changes any more). Thread-safe.
  void publishBest(const nav_msgs::OccupancyGrid& grid);
  // The map was reset or cleared: the incremental slice is the best map again, sent whole.
  void forgetBest(MappingSession& session, const ros::Time& stamp);

 private:
  void publishSlice(const nav_msgs::OccupancyGrid& grid);
  std::string frame_id_;
  bool publish_markers_;
  ros::Publisher map_pub_, metadata_pub_, updates_pub_, markers_pub_, optimized_pub_;
  ros::Publisher incremental_pub_, incremental_updates_pub_;
  std::mutex full_mutex_;  // one whole map built and sent at a time
  std::mutex best_mutex_;  // guards has_best_: orders a pass's result against a reset's return to the slice
  bool has_best_ = false;  // map carries a pass's result
  std::atomic<std::uint64_t> published_geometry_{~std::uint64_t{0}};  // slice geometry last sent whole
  std::atomic<std::uint64_t> published_changes_{~std::uint64_t{0}};   // session.changes() then
  static constexpr std::int64_t kSettleNs = 300000000;                // 0.3 s of whole maps after growth
  std::atomic<std::int64_t> whole_maps_until_ns_{0};                  // wall clock
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
