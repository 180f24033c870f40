// The node's counters as /diagnostics and the session summary give them, and which skips get a
// log line (one throttle per reason; the summary agreeing with /diagnostics after a reset).
#include "ros/diagnostics.h"

#include <gtest/gtest.h>

#include <string>

using namespace octo_slice_mapper::ros_adapter;

namespace {

std::string valueOf(const diagnostic_msgs::DiagnosticArray& array, const std::string& key) {
  for (const auto& kv : array.status.at(0).values) {
    if (kv.key == key) return kv.value;
  }
  return "(missing)";
}

// A flood of one reason logs once per period, and never keeps another reason's first skip quiet.
TEST(SkipLog, EachReasonHasItsOwnThrottle) {
  SkipLog log(5.0);
  EXPECT_TRUE(log.shouldLog("bad_ranges", 100.0));
  for (double t = 100.1; t < 104.9; t += 0.1) EXPECT_FALSE(log.shouldLog("bad_ranges", t));
  EXPECT_TRUE(log.shouldLog("zero_stamp", 102.0)) << "the first of another reason, within the flood";
  EXPECT_FALSE(log.shouldLog("zero_stamp", 103.0));
  EXPECT_TRUE(log.shouldLog("bad_ranges", 105.0)) << "a period after its last line";
  EXPECT_FALSE(log.shouldLog("bad_ranges", 106.0));
  EXPECT_TRUE(log.shouldLog("zero_stamp", 107.5));
}

// After a reset the mapper's own count starts again; the summary takes the session's, as
// /diagnostics does, so the two never disagree.
TEST(SessionSummary, CountsAsDiagnosticsDoes) {
  NodeCounters c;
  c.scans_received = 52;
  c.scans_inserted = 50;  // 40 before a reset, 10 after
  c.skipped["zero_stamp"] = 2;
  c.scan_insert_seconds = 0.025;
  c.scan_insert_cpu_seconds = 0.02;
  MapFigures map;
  map.readings = "hit=900 no_return=100";
  map.beams_outside_octree = 2;
  map.voxels = 1234;
  map.known_cells = 567;
  const std::string line = sessionSummary(c, map, 12.5);
  const diagnostic_msgs::DiagnosticArray diagnostics = toDiagnostics(c, NodeCounters{}, "/mapper_node", ros::Time(1.0));
  EXPECT_NE(line.find("scans_inserted=" + valueOf(diagnostics, "scans_inserted") + " "), std::string::npos) << line;
  EXPECT_NE(line.find("scans_skipped=" + valueOf(diagnostics, "scans_skipped") + " "), std::string::npos) << line;
  EXPECT_NE(line.find("skipped_zero_stamp=" + valueOf(diagnostics, "skipped_zero_stamp")), std::string::npos) << line;
  EXPECT_NE(line.find("readings: hit=900 no_return=100 beams_outside_octree=2 voxels=1234 known_cells=567"), std::string::npos) << line;
  EXPECT_NE(line.find("insert_ms_per_scan=0.5 insert_cpu_ms_per_scan=0.4 "), std::string::npos) << line;
  EXPECT_EQ(line.find("cloud_points"), std::string::npos) << "no clouds, no cloud figures";
  EXPECT_EQ(diagnostics.status.at(0).level, diagnostic_msgs::DiagnosticStatus::WARN) << "skips since the last report";
}

// The log line and the status warn of messages lost since the last report (gaps their stream has
// gone on past, SequenceGaps::settled), once: not of a gap a late message filled, which was
// never counted as lost (SequenceGaps.AGapIsLostOnlyOnceItsStreamHasGoneOnPastIt).
TEST(LostSince, ReportsWhatWasLostSinceTheLastReport) {
  NodeCounters before, now;
  now.scans_missed = 3;  // gaps seen, not settled: they may still come
  EXPECT_EQ(lostSince(now, before), "");
  EXPECT_EQ(toDiagnostics(now, before, "/mapper_node", ros::Time(1.0)).status.at(0).level,
            diagnostic_msgs::DiagnosticStatus::OK);

  now.scans_lost = 2;
  now.clouds_lost = 1;
  const std::string said = lostSince(now, before);
  EXPECT_EQ(said.rfind("2 scan(s) and 1 cloud(s) never reached the mapper", 0), 0u) << said;
  const diagnostic_msgs::DiagnosticArray report = toDiagnostics(now, before, "/mapper_node", ros::Time(2.0));
  EXPECT_EQ(report.status.at(0).level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(report.status.at(0).message.find(said), std::string::npos) << report.status.at(0).message;

  before = now;  // reported: the same count is not news again
  EXPECT_EQ(lostSince(now, before), "");
  now.scans_lost = 1;  // one came later than anyone waits for, after all
  EXPECT_EQ(lostSince(now, before), "") << "a count taken back is no loss";
  now.skipped["zero_stamp"] = 1;
  EXPECT_EQ(toDiagnostics(now, before, "/mapper_node", ros::Time(3.0)).status.at(0).message,
            "1 scans skipped since the last report (see skipped_*)");
}

}  // namespace
