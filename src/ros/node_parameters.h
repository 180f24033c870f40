// ROS parameters -> core options structs, from the option tables. doc/parameters.md is generated
// from them (parameter_doc; test/parameter_table_test.cc keeps it current).
#pragma once

#include <ros/node_handle.h>

#include <string>
#include <vector>

#include "octo_slice_mapper/mapper.h"
#include "octo_slice_mapper/option_table.h"

namespace octo_slice_mapper {
namespace ros_adapter {

struct NodeOptions {
  // The input topics, resolved in the node's namespace: names separated by spaces or commas (a
  // YAML list is read the same). Each is subscribed to on its own, placed with its own frame
  // through tf2 and counted on its own on /diagnostics; all go into one map, each topic in its
  // arrival order.
  std::string scan_topics = "scan";       // sensor_msgs/LaserScan
  std::string cloud_topics = "cloud_in";  // sensor_msgs/PointCloud2
  std::string frame_id = "odom";     // fixed frame the map is built in (the odometry is the pose oracle)
  // A frame whose origin lies on the floor the cameras' carrier stands on: each depth frame's floor
  // is then the one through it. "auto": REP 120's base_footprint where tf has that frame (a
  // robot's tf does, a hand-held camera's does not); "": none, the floor found from the points alone.
  std::string floor_base_frame = "auto";
  double publish_rate = 2.0;         // Hz, map / markers publishing when something changed
  bool publish_markers = true;       // ~occupied_cells
  // s (wall): ~occupied_voxels is published at most this often, when the map changed and someone
  // listens (a walk of the whole octree, on its own thread).
  double occupied_voxels_period = 1.0;
  double transform_timeout = 0.5;    // s (wall), how long a scan may wait for its transform
  // Scans ROS queues for the node and the tf filter holds while waiting for tf. ROS drops the oldest
  // of a full queue silently: 200 is 5 s of a 40 Hz lidar, 1 s of a 10 Hz log replayed at 20x
  // (50 lost 0-3 scans there to stalls of 150 ms; a scan message is 3-9 KB).
  int scan_queue_size = 200;
  std::string map_file;              // .bt/.ot to resume from
  std::string save_on_shutdown;      // prefix written when the node stops ("" = don't)
  std::string maps_dir;              // where ~save_map writes relative prefixes
  bool allow_any_path = false;       // let ~save_map write outside maps_dir
  bool optimize_on_save = true;      // a save runs the global pass: PREFIX.* its map, PREFIX_incremental.* the slice
  bool optimize_warm_start = true;  // ... starting from the incremental map (false: all-free, the lab's start)
  bool write_optimized_into_map = true;  // the global pass's result goes into the octree's slice band
  bool online_optimize = true;           // keep running the global pass in the background: ~optimized_map
  double online_optimize_period = 0.5;   // s (wall) between looks for a finished pass and a changed map
  // Worker threads of the background pass. One: a second one makes the pass faster but takes the
  // core the scans need (their p99 latency at 40 Hz doubles, bench/run_live_latency); saves and
  // ~optimize use every core.
  int online_optimize_threads = 1;
  // Workers preparing point clouds, frames in parallel, applied in arrival order (0: every core).
  int cloud_threads = 0;
};

// The node's own options, named once like the mapper's (option_table.h); maps_dir's default is
// the package's maps/ folder.
const std::vector<OptionSpec<NodeOptions>>& nodeOptionTable();

// The names of a topic list (scan_topics, cloud_topics), in order, without repeats.
std::vector<std::string> topicNames(const std::string& list);

// Every option of both tables read as a private parameter.
MapperOptions readMapperOptions(const ros::NodeHandle& pnh);
NodeOptions readNodeOptions(const ros::NodeHandle& pnh);

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
