// The node's map outputs: the slice on `map` (+ `map_metadata`), what each scan or cloud changed
// on `map_updates`, occupied voxels on ~occupied_cells and the global pass's result on
// ~optimized_map. Messages are built under the session's lock and sent outside it.
#pragma once

#include <ros/ros.h>

#include <atomic>
#include <cstdint>
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
  void publishOptimized(const GridImage& grid, double slice_min_z);

 private:
  std::string frame_id_;
  bool publish_markers_;
  ros::Publisher map_pub_, metadata_pub_, updates_pub_, markers_pub_, optimized_pub_;
  std::atomic<std::uint64_t> published_geometry_{~std::uint64_t{0}};  // slice geometry last sent whole
  std::atomic<std::uint64_t> published_changes_{~std::uint64_t{0}};   // session.changes() then
  static constexpr std::int64_t kSettleNs = 300000000;                // 0.3 s of whole maps after growth
  std::atomic<std::int64_t> whole_maps_until_ns_{0};                  // wall clock
};

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
