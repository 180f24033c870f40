// CARMEN log -> rosbag -> scans placed by the bag's own tf: the same scans as read from the log.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "bag_scans.h"
#include "carmen_bag_writer.h"
#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

double yawOf(const Eigen::Isometry3d& pose) {
  const Eigen::Vector3d x = pose.linear() * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

void expectSameScans(const std::vector<LogScan>& log, const std::vector<Scan>& bag) {
  ASSERT_EQ(bag.size(), log.size());
  for (std::size_t k = 0; k < log.size(); ++k) {
    const Scan& a = log[k].scan;
    const Scan& b = bag[k];
    ASSERT_EQ(a.ranges, b.ranges) << "scan " << k;
    EXPECT_FLOAT_EQ(a.angle_min, b.angle_min);
    EXPECT_FLOAT_EQ(a.angle_increment, b.angle_increment);
    EXPECT_FLOAT_EQ(a.range_max, b.range_max);
    EXPECT_TRUE(a.sensor_pose.translation().isApprox(b.sensor_pose.translation(), 1e-6)) << "scan " << k;
    EXPECT_NEAR(std::remainder(yawOf(a.sensor_pose) - yawOf(b.sensor_pose), 2 * M_PI), 0.0, 1e-6) << "scan " << k;
  }
}

TEST(CarmenBag, RoundTripThroughTheBagsOwnTf) {
  char tmpl[] = "/tmp/osm_carmen_bag_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  {
    std::ofstream log(dir + "/small.log");
    for (int k = 0; k < 20; ++k) {
      log << "FLASER 180";
      for (int i = 0; i < 180; ++i) log << ' ' << 1.0 + 0.01 * i + 0.1 * k;
      const double x = 0.3 * k, y = -0.1 * k, theta = 0.2 * k - 1.5;
      log << ' ' << x << ' ' << y << ' ' << theta << ' ' << x << ' ' << y << ' ' << theta << ' ' << 10.0 + k
          << " host " << 10.0 + k << "\n";
    }
  }
  std::string error;
  const std::vector<LogScan> log = readCarmenLog(dir + "/small.log", {}, &error);
  ASSERT_EQ(log.size(), 20u) << error;
  CarmenLogReader reader;
  ASSERT_TRUE(reader.open(dir + "/small.log", &error)) << error;
  tools::CarmenBagReport report;
  ASSERT_TRUE(tools::writeCarmenBag(&reader, dir + "/small.bag", {}, &report, &error)) << error;
  EXPECT_EQ(report.scans, 20u);
  EXPECT_NE(::access((dir + "/small.bag.partial").c_str(), F_OK), 0) << "the partial file is renamed away";
  tools::BagScans bag;
  ASSERT_TRUE(tools::readBagScans(dir + "/small.bag", "scan", "odom", &bag, &error)) << error;
  EXPECT_TRUE(bag.skipped.empty());
  expectSameScans(log, bag.scans);
  std::system(("rm -rf " + dir).c_str());
}

TEST(CarmenBag, IntelDatasetRoundTrip) {
  const std::string path = test_support::sharedDataDir() + "/intel_corrected/intel-corrected.log.gz";
  std::string error;
  const std::vector<LogScan> log = readCarmenLog(path, {}, &error);
  ASSERT_EQ(log.size(), 910u) << error << " (set OSM_DATA_DIR)";
  char tmpl[] = "/tmp/osm_carmen_bag_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  CarmenLogReader reader;
  ASSERT_TRUE(reader.open(path, &error));
  tools::CarmenBagReport report;
  ASSERT_TRUE(tools::writeCarmenBag(&reader, dir + "/intel.bag", {}, &report, &error)) << error;
  tools::BagScans bag;
  ASSERT_TRUE(tools::readBagScans(dir + "/intel.bag", "/scan", "odom", &bag, &error)) << error;
  expectSameScans(log, bag.scans);
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
