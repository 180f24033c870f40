#include "ros/diagnostics.h"

#include <diagnostic_msgs/DiagnosticStatus.h>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace octo_slice_mapper {
namespace ros_adapter {

std::uint64_t NodeCounters::skippedTotal() const {
  std::uint64_t total = 0;
  for (const auto& kv : skipped) total += kv.second;
  return total;
}

bool SkipLog::shouldLog(const std::string& reason, double now) {
  auto [last, first] = last_.emplace(reason, now);
  if (!first && now - last->second < period_) return false;
  last->second = now;
  return true;
}

std::string sessionSummary(const NodeCounters& c, const MapFigures& map, double wall_seconds) {
  std::ostringstream out;
  out << "scans_inserted=" << c.scans_inserted << " scans_skipped=" << c.skippedTotal()
      << " scans_missed=" << c.scans_missed
      << " time_jumps_back=" << c.time_jumps_back << " scans_held_for_order=" << c.scans_held_for_order
      << " scans_taken_over=" << c.scans_taken_over << " clouds_inserted=" << c.clouds_inserted;
  for (const auto& kv : c.skipped) out << " skipped_" << kv.first << '=' << kv.second;
  if (c.clouds_missed) out << " clouds_missed=" << c.clouds_missed;
  out << " readings: " << map.readings << " beams_outside_octree=" << map.beams_outside_octree;
  if (!map.cloud_points.empty()) out << " cloud_points: " << map.cloud_points;
  out << " voxels=" << map.voxels << " known_cells=" << map.known_cells;
  out << " insert_ms_per_scan=" << (c.scans_inserted ? 1000.0 * c.scan_insert_seconds / c.scans_inserted : 0.0);
  out << " insert_cpu_ms_per_scan=" << (c.scans_inserted ? 1000.0 * c.scan_insert_cpu_seconds / c.scans_inserted : 0.0);
  if (c.clouds_inserted) {
    out << " insert_ms_per_cloud=" << 1000.0 * c.cloud_insert_seconds / c.clouds_inserted;
    out << " insert_cpu_ms_per_cloud=" << 1000.0 * c.cloud_insert_cpu_seconds / c.clouds_inserted;
  }
  out << " wall_s=" << wall_seconds;
  return out.str();
}

std::string lostSince(const NodeCounters& now, const NodeCounters& before) {
  // A count taken back (a message later than kSettle) is not negative loss.
  const auto grew = [](std::uint64_t now, std::uint64_t before) { return now > before ? now - before : 0; };
  const std::uint64_t scans = grew(now.scans_lost, before.scans_lost);
  const std::uint64_t clouds = grew(now.clouds_lost, before.clouds_lost);
  if (scans == 0 && clouds == 0) return "";
  std::string what;
  if (scans) what = std::to_string(scans) + " scan(s)";
  if (clouds) what += (what.empty() ? "" : " and ") + std::to_string(clouds) + " cloud(s)";
  return what + " never reached the mapper (gaps in header.seq): ROS drops the oldest message of a full queue; "
                "replay slower (or, for scans, raise ~scan_queue_size)";
}

diagnostic_msgs::DiagnosticArray toDiagnostics(const NodeCounters& c, const NodeCounters& before,
                                               const std::string& node_name, const ros::Time& stamp) {
  diagnostic_msgs::DiagnosticStatus status;
  status.name = node_name + ": mapping";
  status.hardware_id = "octo_slice_mapper";
  auto add = [&status](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  char ms[32];
  std::snprintf(ms, sizeof(ms), "%.3f", c.last_insert_ms);
  add("scans_received", std::to_string(c.scans_received));
  add("scans_inserted", std::to_string(c.scans_inserted));
  add("scans_skipped", std::to_string(c.skippedTotal()));
  add("clouds_received", std::to_string(c.clouds_received));
  add("clouds_inserted", std::to_string(c.clouds_inserted));
  add("scans_missed", std::to_string(c.scans_missed));
  add("clouds_missed", std::to_string(c.clouds_missed));
  for (const auto& kv : c.skipped) add("skipped_" + kv.first, std::to_string(kv.second));
  for (const auto& kv : c.topics) {
    const TopicCounters& t = kv.second;
    add(kv.first + " received", std::to_string(t.received));
    add(kv.first + " inserted", std::to_string(t.inserted));
    add(kv.first + " missed", std::to_string(t.missed));
  }
  add("waiting_for_tf", std::to_string(c.waiting_for_tf));
  add("time_jumps_back", std::to_string(c.time_jumps_back));
  add("scans_held_for_order", std::to_string(c.scans_held_for_order));
  add("scans_taken_over", std::to_string(c.scans_taken_over));
  add("last_insert_ms", ms);
  std::snprintf(ms, sizeof(ms), "%.3f", c.max_insert_wait_ms);
  add("max_insert_wait_ms", ms);
  std::snprintf(ms, sizeof(ms), "%.3f", c.longest_service_lock_ms);
  add("longest_service_lock_ms", ms);
  std::snprintf(ms, sizeof(ms), "%.3f", c.longest_service_lock_cpu_ms);
  add("longest_service_lock_cpu_ms", ms);
  add("octree_nodes", std::to_string(c.octree_nodes));
  add("unflushed_voxels", std::to_string(c.unflushed_voxels));
  add("known_cells", std::to_string(c.known_cells));
  add("kept_scans", std::to_string(c.kept_scans));
  add("revisit_scans_not_kept", std::to_string(c.revisit_scans_not_kept));
  if (c.clouds_inserted) {
    char text[32];
    add("floor_source", c.floor_source);
    std::snprintf(text, sizeof text, "%.3f", c.floor_height);
    add("floor_height", text);
    std::snprintf(text, sizeof text, "%.2f", c.floor_tilt * 180.0 / M_PI);
    add("floor_tilt_deg", text);
    add("floor_frames_found", std::to_string(c.floor_frames_found));
    add("floor_frames_without", std::to_string(c.floor_frames_without));
    add("floor_cells", std::to_string(c.floor_cells));
    add("floor_ground_points", std::to_string(c.floor_ground_points));
  }
  add("online_passes", std::to_string(c.online_passes));
  std::snprintf(ms, sizeof(ms), "%.3f", c.online_pass_seconds);
  add("online_pass_s", ms);
  std::snprintf(ms, sizeof(ms), "%.3f", c.optimized_map_age);
  add("optimized_map_age_s", ms);
  const std::uint64_t new_skips = c.skippedTotal() - std::min(before.skippedTotal(), c.skippedTotal());
  const std::string lost = lostSince(c, before);
  if (new_skips == 0 && lost.empty()) {
    status.level = diagnostic_msgs::DiagnosticStatus::OK;
    status.message = "mapping";
  } else {
    status.level = diagnostic_msgs::DiagnosticStatus::WARN;
    if (new_skips) status.message = std::to_string(new_skips) + " scans skipped since the last report (see skipped_*)";
    if (!lost.empty()) status.message += (status.message.empty() ? "" : "; ") + lost;
  }
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  return array;
}

}  // namespace ros_adapter
}  // namespace octo_slice_mapper
