// CARMEN log -> rosbag -> scans placed by the bag's own tf: the same scans as read from the log.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdlib>
#include <map>

#include "bag_scans.h"
#include "carmen_bag_writer.h"
#include "planar_transform.h"
#include "ros/point_cloud_conversion.h"
#include "ros/tf_lookup.h"
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

// A depth camera's bag: clouds placed through the bag's tf at their stamps, in the bag's order
// with the scans; one whose transform is recorded after it, and one between two transforms 1.1 s
// apart, held until it comes; one before any tf and one with a broken layout counted, not handed on.
TEST(BagClouds, CloudsComeThroughTheBagsTfInOrderWithTheScans) {
  char tmpl[] = "/tmp/osm_bag_clouds_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  const std::string path = dir + "/camera.bag";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    tf2_msgs::TFMessage statics;
    statics.transforms.push_back(tools::planarTransform("base_link", "camera", ros::Time(100.0), 0.1, 0.0, 0.3, 0.0));
    statics.transforms.push_back(tools::planarTransform("base_link", "laser", ros::Time(100.0), 0.1, 0.0, 0.26, 0.0));
    bag.write("/tf_static", ros::Time(100.0), statics);
    const auto cloudAt = [](double t) {
      sensor_msgs::PointCloud2 c =
          ros_adapter::organizedCloud({Eigen::Vector3f(1.0f, 0.0f, 0.0f), Eigen::Vector3f(NAN, NAN, NAN)}, 2, 1, "camera");
      c.header.stamp = ros::Time(t);
      return c;
    };
    const auto scanAt = [](double t) {
      sensor_msgs::LaserScan scan;
      scan.header.stamp = ros::Time(t);
      scan.header.frame_id = "laser";
      scan.angle_min = 0.0f;
      scan.angle_increment = 0.1f;
      scan.angle_max = 0.2f;
      scan.range_min = 0.1f;
      scan.range_max = 10.0f;
      scan.ranges = {1.0f, 2.0f, 3.0f};
      return scan;
    };
    bag.write("/camera/points", ros::Time(100.5), cloudAt(100.5));  // before any odom tf
    for (int k = 0; k < 5; ++k) {
      const double t = 101.0 + k;
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(tools::planarTransform("odom", "base_link", ros::Time(t), 2.0 * k, 0.0, 0.0, M_PI / 2));
      bag.write("/tf", ros::Time(t), tf);
      bag.write("/scan", ros::Time(t), scanAt(t));
      bag.write("/camera/points", ros::Time(t + 0.01), cloudAt(t));  // recorded just after the scan
    }
    sensor_msgs::PointCloud2 broken = cloudAt(103.0);
    broken.data.resize(4);  // less data than 2 points declare
    bag.write("/camera/points", ros::Time(103.0), broken);
    // A cloud whose transform is recorded 0.3 s after it: held until it comes, then placed.
    bag.write("/camera/points", ros::Time(106.0), cloudAt(106.0));
    tf2_msgs::TFMessage late;
    late.transforms.push_back(tools::planarTransform("odom", "base_link", ros::Time(106.0), 10.0, 0.0, 0.0, M_PI / 2));
    bag.write("/tf", ros::Time(106.3), late);
    // Slow tf: a scan between two transforms 1.1 s apart waits for the second.
    sensor_msgs::LaserScan between = scanAt(106.5);
    bag.write("/scan", ros::Time(106.5), between);
    bag.write("/camera/points", ros::Time(107.55), cloudAt(107.0));  // read while the scan waits
    tf2_msgs::TFMessage next;
    next.transforms.push_back(tools::planarTransform("odom", "base_link", ros::Time(107.1), 12.0, 0.0, 0.0, M_PI / 2));
    bag.write("/tf", ros::Time(107.6), next);
  }
  std::vector<char> order;
  std::vector<SensorCloud> clouds;
  std::vector<Scan> scans;
  tools::BagHandlers handlers;
  handlers.scan = [&](const Scan& s) {
    order.push_back('s');
    scans.push_back(s);
  };
  handlers.cloud = [&](const DeferredCloud& c) {  // its points made here, as a pipeline's worker would
    order.push_back('c');
    clouds.push_back(c.made(FlyingPixelOptions()));
  };
  std::map<std::string, std::size_t> skipped;
  std::string error;
  ASSERT_TRUE(tools::readBag(path, {{"scan"}, {"camera/points"}}, "odom", handlers, &skipped, &error)) << error;
  EXPECT_EQ(std::string(order.begin(), order.end()), "scscscscsccsc");
  ASSERT_EQ(scans.size(), 6u);
  EXPECT_NEAR(scans[5].sensor_pose.translation().x(), 10.0 + 2.0 * 0.5 / 1.1, 1e-6) << "placed between the two transforms";
  EXPECT_EQ(skipped["cloud_no_transform"], 1u);
  EXPECT_EQ(skipped["cloud_short_data"], 1u);
  ASSERT_EQ(clouds.size(), 7u);
  EXPECT_TRUE(clouds[5].origin.isApprox(Eigen::Vector3d(10.0, 0.1, 0.3), 1e-6)) << clouds[5].origin.transpose();
  // The camera 0.1 m ahead of a base at (2k, 0) facing +y, 0.3 m up; its point 1 m ahead of it.
  for (int k = 0; k < 5; ++k) {
    EXPECT_TRUE(clouds[k].origin.isApprox(Eigen::Vector3d(2.0 * k, 0.1, 0.3), 1e-6)) << clouds[k].origin.transpose();
    ASSERT_EQ(clouds[k].points.size(), 1u) << "the NaN pixel left out";
    EXPECT_TRUE(clouds[k].points[0].isApprox(Eigen::Vector3f(2.0f * k, 1.1f, 0.3f), 1e-5f));
    EXPECT_EQ(clouds[k].left_out[ReadingKind::kNaN], 1u) << "and counted, for the cloud's readings";
  }
  for (const SensorCloud& c : clouds) EXPECT_FALSE(c.ground) << "no floor_base_frame: no ground point";
  // The clouds alone; and a bag without the topic is an error.
  order.clear();
  skipped.clear();
  ASSERT_TRUE(tools::readBag(path, {{}, {"/camera/points"}}, "odom", handlers, &skipped, &error)) << error;
  const std::map<std::string, std::size_t> skipped_without_base = skipped;
  EXPECT_EQ(std::string(order.begin(), order.end()), "ccccccc");
  // With a floor_base_frame, each cloud's ground point is that frame's origin at its stamp; a
  // cloud tf cannot place it for is read without one, and is no skipped cloud.
  clouds.clear();
  ASSERT_TRUE(tools::readBag(path, {{}, {"/camera/points"}}, "odom", handlers, &skipped, &error, {}, "base_link"));
  ASSERT_EQ(clouds.size(), 7u);
  for (int k = 0; k < 5; ++k) {
    ASSERT_TRUE(clouds[std::size_t(k)].ground);
    EXPECT_TRUE(clouds[std::size_t(k)].ground->isApprox(Eigen::Vector3d(2.0 * k, 0.0, 0.0), 1e-6));
  }
  skipped.clear();
  clouds.clear();
  ASSERT_TRUE(tools::readBag(path, {{}, {"/camera/points"}}, "odom", handlers, &skipped, &error, {}, "no_such_frame"));
  EXPECT_EQ(clouds.size(), 7u);
  EXPECT_EQ(skipped, skipped_without_base) << "clouds mapped without a ground point are no skipped ones";
  for (const SensorCloud& c : clouds) EXPECT_FALSE(c.ground);
  // "auto" asks for base_footprint, which this bag's tf has not (a hand-held camera's): none.
  skipped.clear();
  clouds.clear();
  ASSERT_TRUE(tools::readBag(path, {{}, {"/camera/points"}}, "odom", handlers, &skipped, &error, {}, "auto"));
  EXPECT_EQ(clouds.size(), 7u);
  EXPECT_EQ(skipped, skipped_without_base);
  for (const SensorCloud& c : clouds) EXPECT_FALSE(c.ground);
  EXPECT_FALSE(tools::readBag(path, {{}, {"/no/such/topic"}}, "odom", handlers, &skipped, &error));
  EXPECT_NE(error.find("no messages on topic '/no/such/topic'"), std::string::npos) << error;
  std::system(("rm -rf " + dir).c_str());
}

// floor_base_frame "auto" on a robot's bag (REP 120: odom -> base_footprint -> base_link): each
// cloud's ground point is base_footprint's origin, on the floor under the robot, not base_link's;
// "" asks for none.
TEST(BagClouds, AutoFloorBaseIsTheRobotsBaseFootprint) {
  char tmpl[] = "/tmp/osm_bag_auto_base_XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  const std::string path = dir + "/robot.bag";
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    tf2_msgs::TFMessage statics;
    statics.transforms.push_back(tools::planarTransform("base_footprint", "base_link", ros::Time(100.0), 0.0, 0.0, 0.1, 0.0));
    statics.transforms.push_back(tools::planarTransform("base_link", "camera", ros::Time(100.0), 0.1, 0.0, 0.3, 0.0));
    bag.write("/tf_static", ros::Time(100.0), statics);
    for (int k = 0; k < 3; ++k) {
      const double t = 101.0 + k;
      tf2_msgs::TFMessage tf;
      tf.transforms.push_back(tools::planarTransform("odom", "base_footprint", ros::Time(t), 1.0 * k, 2.0, 0.0, 0.0));
      bag.write("/tf", ros::Time(t), tf);
      sensor_msgs::PointCloud2 c = ros_adapter::organizedCloud({Eigen::Vector3f(1.0f, 0.0f, 0.0f)}, 1, 1, "camera");
      c.header.stamp = ros::Time(t);
      bag.write("/camera/points", ros::Time(t + 0.01), c);
    }
  }
  std::vector<SensorCloud> clouds;
  tools::BagHandlers handlers;
  handlers.cloud = [&](const DeferredCloud& c) { clouds.push_back(c.made(FlyingPixelOptions())); };
  std::map<std::string, std::size_t> skipped;
  std::string error;
  ASSERT_TRUE(tools::readBag(path, {{}, {"camera/points"}}, "odom", handlers, &skipped, &error, {}, "auto")) << error;
  ASSERT_EQ(clouds.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(clouds[std::size_t(k)].ground) << k;
    EXPECT_TRUE(clouds[std::size_t(k)].ground->isApprox(Eigen::Vector3d(1.0 * k, 2.0, 0.0), 1e-9))
        << clouds[std::size_t(k)].ground->transpose();
    EXPECT_NEAR(clouds[std::size_t(k)].origin.z(), 0.4, 1e-9) << "the camera 0.4 m above the floor";
  }
  clouds.clear();
  ASSERT_TRUE(tools::readBag(path, {{}, {"camera/points"}}, "odom", handlers, &skipped, &error, {}, "")) << error;
  ASSERT_EQ(clouds.size(), 3u);
  for (const SensorCloud& c : clouds) EXPECT_FALSE(c.ground) << "\"\": no ground point";
  std::system(("rm -rf " + dir).c_str());
}

// The setting read: "auto" is base_footprint, asked for quietly; a name is that frame, required.
TEST(FloorBase, SettingsAndTheGroundPoint) {
  EXPECT_EQ(ros_adapter::floorBaseOf("auto").frame, "base_footprint");
  EXPECT_FALSE(ros_adapter::floorBaseOf("auto").required);
  EXPECT_EQ(ros_adapter::floorBaseOf("").frame, "");
  EXPECT_FALSE(ros_adapter::floorBaseOf("").required);
  EXPECT_EQ(ros_adapter::floorBaseOf("base_raised").frame, "base_raised");
  EXPECT_TRUE(ros_adapter::floorBaseOf("base_raised").required);
  tf2::BufferCore tf;
  const ros::Time t(50.0);
  std::string why;
  EXPECT_FALSE(ros_adapter::groundPoint(tf, "odom", ros_adapter::floorBaseOf("auto"), t, &why));
  EXPECT_TRUE(why.empty()) << "auto without base_footprint in tf is no failure: " << why;
  EXPECT_FALSE(ros_adapter::groundPoint(tf, "odom", ros_adapter::floorBaseOf("base_footprint"), t, &why));
  EXPECT_FALSE(why.empty()) << "a named frame tf cannot place says why";
  tf.setTransform(tools::planarTransform("odom", "base_footprint", t, 3.0, -1.0, 0.0, 0.5), "test");
  const auto ground = ros_adapter::groundPoint(tf, "odom", ros_adapter::floorBaseOf("auto"), t);
  ASSERT_TRUE(ground);
  EXPECT_TRUE(ground->isApprox(Eigen::Vector3d(3.0, -1.0, 0.0), 1e-12)) << ground->transpose();
  EXPECT_FALSE(ros_adapter::groundPoint(tf, "odom", ros_adapter::floorBaseOf(""), t));
}

}  // namespace
