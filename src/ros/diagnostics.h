// The node's counters on /diagnostics, so a user sees in rqt_runtime_monitor or
// `rostopic echo /diagnostics` what the mapper does and why scans are dropped.
#pragma once

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/time.h>

#include <cstdint>
#include <map>
#include <string>

namespace octo_slice_mapper {
namespace ros_adapter {

// One input topic's own counts (a robot with several lidars sees which one stopped or drops).
struct TopicCounters {
  std::uint64_t received = 0, inserted = 0;
  std::uint64_t missed = 0, lost = 0;  // as NodeCounters' below, for this topic alone
};

struct NodeCounters {
  std::uint64_t scans_received = 0;  // by the subscriber, before waiting for tf
  std::uint64_t scans_inserted = 0;
  std::uint64_t clouds_received = 0, clouds_inserted = 0;  // cloud_in; their skips are skipped_cloud_*
  // Never received: gaps in their publishers' header.seq (ROS dropped them from a full queue).
  std::uint64_t scans_missed = 0, clouds_missed = 0;
  // Of them, those their stream has gone SequenceGaps::kSettle messages past: surely lost, not
  // late (what the log and the status warn of; not a /diagnostics value of its own).
  std::uint64_t scans_lost = 0, clouds_lost = 0;
  std::map<std::string, std::uint64_t> skipped;  // whole scans dropped, per reason
  std::map<std::string, TopicCounters> topics;    // per input topic (resolved name); the sums above
  std::uint64_t time_jumps_back = 0;
  // Delivered by the tf filter ahead of an earlier scan, and held until that one's turn.
  std::uint64_t scans_held_for_order = 0;
  // Handed on by the node itself, their transform there but no word from the tf filter yet (which
  // can miss a transform that arrives while it adds the message; see PendingMessages).
  std::uint64_t scans_taken_over = 0;
  double last_insert_ms = 0.0;
  double scan_insert_seconds = 0.0, cloud_insert_seconds = 0.0;  // summed over the inserted ones
  // The same as CPU time of the inserting thread: less than the above when it waited for a core.
  double scan_insert_cpu_seconds = 0.0, cloud_insert_cpu_seconds = 0.0;
  // Longest a scan waited for the map (held by a service taking its snapshot), and longest a
  // service held it: both must stay under one scan period for saving not to stall mapping.
  double max_insert_wait_ms = 0.0;
  double longest_service_lock_ms = 0.0;
  double longest_service_lock_cpu_ms = 0.0;
  // Octree nodes, inner ones included, as of the last flush (the session summary counts leaves),
  // and the changed voxels the insertion cache holds that the octree does not have yet.
  std::size_t octree_nodes = 0, unflushed_voxels = 0;
  std::size_t known_cells = 0, kept_scans = 0, revisit_scans_not_kept = 0;
  std::size_t waiting_for_tf = 0;  // in the tf filter's queue, within their timeout
  // The background global pass (~online_optimize): passes published, the last one's seconds, and
  // how far its map was behind the newest scan when published (s).
  std::uint64_t online_passes = 0;
  double online_pass_seconds = 0.0, optimized_map_age = 0.0;
  // Where the depth frames' floor came from (FloorStatus), shown once a frame came.
  std::string floor_source;
  double floor_height = 0.0, floor_tilt = 0.0;
  std::uint64_t floor_frames_found = 0, floor_frames_without = 0;
  std::size_t floor_cells = 0;
  std::uint64_t floor_ground_points = 0;  // clouds that came with a ground point (floor_base_frame)
  std::uint64_t skippedTotal() const;
};

// Which skips get a log line: the first of each reason, then at most one per `period` seconds
// per reason, so a flood of one kind never hides the first of another.
class SkipLog {
 public:
  explicit SkipLog(double period = 5.0) : period_(period) {}
  // `now`: seconds on any steady clock.
  bool shouldLog(const std::string& reason, double now);

 private:
  double period_;
  std::map<std::string, double> last_;
};

// What the session summary says about the map besides the counters (the mapper's figures).
struct MapFigures {
  std::string readings, cloud_points;  // ReadingCounts::summary(); cloud_points empty without clouds
  std::uint64_t beams_outside_octree = 0;
  std::size_t voxels = 0, known_cells = 0;
};

// The line the node logs at shutdown: the session's counts as /diagnostics has them (across
// resets: the mapper's own count starts again at a reset), then the map's figures.
std::string sessionSummary(const NodeCounters& counters, const MapFigures& map, double wall_seconds);

// What was lost since `before` (the counters at the last report): messages that never reached
// the node and whose stream has gone on past them (scans_lost, clouds_lost), in words for a log
// line and the status ("" when nothing). Not each gap as it is seen: a message recorded after
// the next one (a bag in another order) fills its gap at once, and is no loss.
std::string lostSince(const NodeCounters& now, const NodeCounters& before);

// One status: OK, or WARN when scans were skipped or messages lost since `before` (the counters
// at the last report), naming what.
diagnostic_msgs::DiagnosticArray toDiagnostics(const NodeCounters& counters, const NodeCounters& before,
                                               const std::string& node_name, const ros::Time& stamp);

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
