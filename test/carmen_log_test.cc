#include "octo_slice_mapper/carmen_log.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "test_helpers.h"

using namespace octo_slice_mapper;

namespace {

class CarmenLogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/osm_carmen_XXXXXX";
    dir_ = ::mkdtemp(tmpl);
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }

  std::string writePlain(const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path) << text;
    return path;
  }
  std::string writeGzip(const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name;
    gzFile f = gzopen(path.c_str(), "wb");
    gzwrite(f, text.data(), static_cast<unsigned>(text.size()));
    gzclose(f);
    return path;
  }

  // An old-format line: n readings of `r`, laser pose (x, y, theta).
  static std::string oldLaser(const std::string& kind, int n, double r, double x, double y, double theta,
                              double stamp = 12.5) {
    std::ostringstream line;
    line << kind << ' ' << n;
    for (int i = 0; i < n; ++i) line << ' ' << r;
    line << ' ' << x << ' ' << y << ' ' << theta << ' ' << x << ' ' << y << ' ' << theta << ' ' << stamp
         << " host " << stamp << '\n';
    return line.str();
  }

  std::string dir_;
};

TEST_F(CarmenLogTest, OldFormatBeamLayouts) {
  const std::string log = "# comment\nPARAM robot_front_laser_max 50.0 1 host 1\nODOM 1 2 3 0 0 0 1 host 1\n" +
                          oldLaser("FLASER", 180, 2.0, 1.0, 2.0, 0.5) + oldLaser("FLASER", 360, 2.0, 0, 0, 0) +
                          oldLaser("FLASER", 361, 2.0, 0, 0, 0) + oldLaser("RLASER", 181, 1.5, 0, 0, M_PI);
  std::string error;
  std::vector<LogProblem> problems;
  const auto scans = readCarmenLog(writePlain("a.log", log), {}, &error, &problems);
  ASSERT_EQ(scans.size(), 4u) << error;
  EXPECT_TRUE(problems.empty());
  // 180 beams: 1 deg steps from -90 deg; the pose is the laser's, at the mount height.
  const Scan& s180 = scans[0].scan;
  EXPECT_NEAR(s180.angle_min, -M_PI / 2, 1e-6);
  EXPECT_NEAR(s180.angle_increment, M_PI / 180, 1e-6);
  EXPECT_NEAR(s180.beamAngle(179), M_PI / 2 - M_PI / 180, 1e-5);
  EXPECT_FLOAT_EQ(s180.range_max, 50.0f) << "PARAM robot_front_laser_max sets the FLASER range";
  EXPECT_NEAR(s180.sensor_pose.translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(s180.sensor_pose.translation().y(), 2.0, 1e-9);
  EXPECT_NEAR(s180.sensor_pose.translation().z(), 0.26, 1e-9);
  const Eigen::Vector3d x_axis = s180.sensor_pose.linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(std::atan2(x_axis.y(), x_axis.x()), 0.5, 1e-9);
  EXPECT_DOUBLE_EQ(s180.stamp, 12.5);
  EXPECT_EQ(scans[0].line, 4u);
  // 360: 0.5 deg from -90; 361: 0.5 deg from -90 to +90 inclusive; 181: 1 deg both ends.
  EXPECT_NEAR(scans[1].scan.angle_increment, M_PI / 360, 1e-6);
  EXPECT_NEAR(scans[2].scan.angle_increment, M_PI / 360, 1e-6);
  EXPECT_NEAR(scans[2].scan.beamAngle(360), M_PI / 2, 1e-5);
  EXPECT_EQ(scans[3].record, "RLASER");
  EXPECT_NEAR(scans[3].scan.beamAngle(180), M_PI / 2, 1e-5);
  EXPECT_FLOAT_EQ(scans[3].scan.range_max, 80.0f) << "no rear PARAM: the default";
}

TEST_F(CarmenLogTest, RobotLaserCarriesItsOwnGeometry) {
  std::ostringstream line;
  line << "ROBOTLASER1 0 -2.35619 4.71239 0.00436332 30.0 0.01 0 1081";
  for (int i = 0; i < 1081; ++i) line << ' ' << (i == 5 ? 30.0 : 3.0);
  line << " 2 7 7 1.5 -0.5 1.2 1.4 -0.5 1.2 0 0 0.5 0.3 0 77.25 host 77.5\n";
  std::string error;
  const auto scans = readCarmenLog(writeGzip("r.log.gz", line.str()), {}, &error);
  ASSERT_EQ(scans.size(), 1u) << error;
  const Scan& s = scans[0].scan;
  ASSERT_EQ(s.ranges.size(), 1081u);
  EXPECT_NEAR(s.angle_min, -2.35619, 1e-5);
  EXPECT_NEAR(s.angle_increment, 0.00436332, 1e-8);
  EXPECT_FLOAT_EQ(s.range_max, 30.0f);
  EXPECT_EQ(classifyReading(s.ranges[5], s.range_min, s.range_max, {}), ReadingKind::kNoReturn);
  EXPECT_NEAR(s.sensor_pose.translation().x(), 1.5, 1e-9) << "the laser pose, not the robot pose";
  EXPECT_DOUBLE_EQ(s.stamp, 77.5);
}

TEST_F(CarmenLogTest, BadLinesAreReportedWithTheirNumberAndSkipped) {
  const std::string good = oldLaser("FLASER", 180, 2.0, 0, 0, 0);
  std::string truncated_line = good.substr(0, good.size() / 2) + "\n";
  const std::string log = good + "FLASER 180 1 2 3\n" + "FLASER abc\n" + truncated_line +
                          oldLaser("FLASER", 4, 2.0, 0, 0, 0).replace(9, 1, "x") + good;
  CarmenLogReader reader;
  std::string error;
  ASSERT_TRUE(reader.open(writePlain("bad.log", log), &error)) << error;
  LogScan scan;
  std::vector<std::size_t> lines;
  while (reader.next(&scan)) lines.push_back(scan.line);
  EXPECT_EQ(lines, (std::vector<std::size_t>{1, 6}));
  ASSERT_EQ(reader.problemCount(), 4u);
  EXPECT_EQ(reader.problems()[0].line, 2u);
  EXPECT_NE(reader.problems()[0].message.find("180 beams announced"), std::string::npos) << reader.problems()[0].message;
  EXPECT_EQ(reader.problems()[1].line, 3u);
  EXPECT_EQ(reader.problems()[3].line, 5u);
  EXPECT_NE(reader.problems()[3].message.find("not a number"), std::string::npos) << reader.problems()[3].message;
  EXPECT_TRUE(reader.endError().empty());
}

TEST_F(CarmenLogTest, TruncatedGzipEndsWithAClearMessageAndTheScansSoFar) {
  std::string log;
  for (int k = 0; k < 400; ++k) log += oldLaser("FLASER", 180, 1.0 + 0.01 * k, 0.01 * k, 0, 0, k);
  const std::string whole = writeGzip("whole.log.gz", log);
  std::string bytes;
  {
    std::ifstream in(whole, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::string cut = writePlain("cut.log.gz", bytes.substr(0, bytes.size() / 2));
  std::string error, end_error;
  std::vector<LogProblem> problems;
  const auto scans = readCarmenLog(cut, {}, &error, &problems, &end_error);
  EXPECT_GT(scans.size(), 50u);
  EXPECT_LT(scans.size(), 400u);
  EXPECT_NE(end_error.find("truncated or corrupt"), std::string::npos) << "end error: " << end_error;
  for (std::size_t k = 0; k < scans.size(); ++k) EXPECT_NEAR(scans[k].scan.ranges[0], 1.0 + 0.01 * k, 1e-5);
  // The complete file reads to its end without an error.
  const auto all = readCarmenLog(whole, {}, &error, nullptr, &end_error);
  EXPECT_EQ(all.size(), 400u);
  EXPECT_TRUE(end_error.empty()) << end_error;
}

TEST_F(CarmenLogTest, MissingFileIsAClearError) {
  CarmenLogReader reader;
  std::string error;
  EXPECT_FALSE(reader.open(dir_ + "/nope.log", &error));
  EXPECT_NE(error.find("nope.log"), std::string::npos);
  EXPECT_FALSE(reader.open(dir_, &error)) << "a folder is not a log";
}

// The shared datasets, as their VERIFY.txt counts them.
TEST(CarmenSharedData, IntelAndFreiburg079) {
  struct Expected {
    const char* path;
    std::size_t scans, beams, no_returns;
  };
  for (const Expected& e : {Expected{"/intel_corrected/intel-corrected.log.gz", 910, 180, 4172},
                            Expected{"/fr079_corrected/freiburg-079-corrected.log.gz", 4791, 360, 36004}}) {
    const std::string path = test_support::sharedDataDir() + e.path;
    std::string error;
    std::vector<LogProblem> problems;
    std::string end_error;
    const auto scans = readCarmenLog(path, {}, &error, &problems, &end_error);
    ASSERT_TRUE(error.empty()) << error << " (set OSM_DATA_DIR)";
    ASSERT_EQ(scans.size(), e.scans) << path;
    EXPECT_TRUE(problems.empty()) << problems.front().message;
    EXPECT_TRUE(end_error.empty()) << end_error;
    std::size_t no_returns = 0;
    for (const LogScan& s : scans) {
      ASSERT_EQ(s.scan.ranges.size(), e.beams);
      for (float r : s.scan.ranges) {
        no_returns += classifyReading(r, s.scan.range_min, s.scan.range_max, {}) == ReadingKind::kNoReturn;
      }
    }
    EXPECT_EQ(no_returns, e.no_returns) << path;
  }
}

}  // namespace
