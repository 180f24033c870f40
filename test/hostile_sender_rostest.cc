// Hostile messages and requests through a real roscore: the node stays up, counts
// each one under its reason, and the map it saves is byte for byte the map of the valid messages
// alone (a second node that gets only those).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/point_cloud2_iterator.h>
#include <sys/stat.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <string>

#include "octo_slice_mapper/SaveMap.h"
#include "octo_slice_mapper/internal/atomic_file.h"
#include "ros_test_support.h"

namespace {

const char kMapsDir[] = "/tmp/osm_hostile_maps";
const float kNaN = std::numeric_limits<float>::quiet_NaN();

class HostileSenderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ::mkdir(kMapsDir, 0755);
    diagnostics_sub_ = nh_.subscribe("/diagnostics", 50, &HostileSenderTest::onDiagnostics, this);
    for (const char* node : {"hostile", "clean"}) {
      const std::string ns = std::string(node) == "clean" ? "clean/" : "";
      scans_[node] = nh_.advertise<sensor_msgs::LaserScan>(ns + "scan", 50);
      clouds_[node] = nh_.advertise<sensor_msgs::PointCloud2>(ns + "cloud_in", 50);
    }
    std::vector<geometry_msgs::TransformStamped> tfs;
    tfs.push_back(transform("odom", "base_link", 0.0, 0.0));
    tfs.push_back(transform("base_link", "laser", 0.10, 0.26));
    tfs.push_back(transform("odom", "far_laser", 1e7, 0.26));  // beyond what the octree can hold
    static_tf_.sendTransform(tfs);
    ASSERT_TRUE(waitFor([this] {
      for (auto& p : scans_) if (p.second.getNumSubscribers() < 1) return false;
      for (auto& p : clouds_) if (p.second.getNumSubscribers() < 1) return false;
      return true;
    }, 20.0)) << "the mappers did not subscribe";
  }

  static geometry_msgs::TransformStamped transform(const char* parent, const char* child, double x, double z) {
    geometry_msgs::TransformStamped t;
    t.header.frame_id = parent;
    t.header.stamp = ros::Time::now();
    t.child_frame_id = child;
    t.transform.translation.x = x;
    t.transform.translation.z = z;
    t.transform.rotation.w = 1.0;
    return t;
  }

  void onDiagnostics(const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
    for (const auto& status : msg->status) {
      for (const char* node : {"hostile", "clean"}) {
        if (status.name.rfind(std::string("/") + node + ":", 0) != 0) continue;
        for (const auto& kv : status.values) diagnostics_[node][kv.key] = std::atof(kv.value.c_str());
      }
    }
  }
  double diagnostic(const std::string& node, const std::string& key) {
    const auto it = diagnostics_[node].find(key);
    return it == diagnostics_[node].end() ? -1.0 : it->second;
  }

  bool waitFor(const std::function<bool()>& condition, double seconds) {
    return octo_slice_mapper::test_support::waitFor(condition, seconds);
  }

  // A 181-beam half circle: a room 3 m across with a wall `d` ahead, some of it seen at an angle.
  static sensor_msgs::LaserScan scan(double d, ros::Time stamp, const char* frame = "laser") {
    sensor_msgs::LaserScan msg;
    msg.header.frame_id = frame;
    msg.header.stamp = stamp;
    msg.angle_min = -M_PI / 2;
    msg.angle_increment = M_PI / 180;
    msg.angle_max = M_PI / 2;
    msg.range_min = 0.02f;
    msg.range_max = 5.6f;
    for (int i = 0; i <= 180; ++i) {
      const double a = msg.angle_min + i * msg.angle_increment;
      const double ahead = d / std::max(1e-3, std::cos(a)), side = 1.5 / std::max(1e-3, std::abs(std::sin(a)));
      msg.ranges.push_back(static_cast<float>(std::min({ahead, side, 5.5})));
    }
    return msg;
  }

  static sensor_msgs::PointCloud2 cloud(int points, ros::Time stamp) {
    sensor_msgs::PointCloud2 msg;
    msg.header.frame_id = "laser";
    msg.header.stamp = stamp;
    sensor_msgs::PointCloud2Modifier modifier(msg);
    modifier.setPointCloud2FieldsByString(1, "xyz");
    modifier.resize(points);
    sensor_msgs::PointCloud2Iterator<float> x(msg, "x");
    for (int i = 0; i < points; ++i, ++x) x[0] = 1.2f, x[1] = -0.5f + 0.05f * i, x[2] = 0.1f;
    return msg;
  }

  void toBoth(const sensor_msgs::LaserScan& msg) {
    for (auto& p : scans_) p.second.publish(msg);
  }

  ros::NodeHandle nh_;
  ros::Subscriber diagnostics_sub_;
  std::map<std::string, ros::Publisher> scans_, clouds_;
  std::map<std::string, std::map<std::string, double>> diagnostics_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
};

TEST_F(HostileSenderTest, HostileMessagesAreCountedAndTheMapEqualsTheValidOnesAlone) {
  ros::Publisher& hostile_scan = scans_["hostile"];
  ros::Publisher& hostile_cloud = clouds_["hostile"];
  const ros::Time t0 = ros::Time::now();
  // The hostile messages, one of each kind.
  std::vector<std::function<void()>> attacks;
  attacks.push_back([&] {  // a cloud declaring 2 000 000 points, 120 bytes sent (crashed the node)
    auto c = cloud(3, ros::Time::now());
    c.width = 2000000;
    c.row_step = c.width * c.point_step;
    c.data.resize(120);
    hostile_cloud.publish(c);
  });
  attacks.push_back([&] {  // point_step smaller than x, y, z (went into the map)
    auto c = cloud(3, ros::Time::now());
    c.point_step = 4;
    c.row_step = 12;
    hostile_cloud.publish(c);
  });
  attacks.push_back([&] {  // no z field (was inserted at z = 0)
    auto c = cloud(3, ros::Time::now());
    c.fields.resize(2);
    hostile_cloud.publish(c);
  });
  attacks.push_back([&] {  // 1000 points declared, data for 10
    auto c = cloud(10, ros::Time::now());
    c.width = 1000;
    c.row_step = c.width * c.point_step;
    hostile_cloud.publish(c);
  });
  attacks.push_back([&] { hostile_scan.publish(scan(2.0, ros::Time(0))); });  // stamped 0
  attacks.push_back([&] { hostile_scan.publish(scan(2.0, ros::Time::now(), "far_laser")); });  // origin out of range
  attacks.push_back([&] { hostile_scan.publish(scan(2.0, ros::Time::now(), "nobody_publishes")); });
  attacks.push_back([&] {  // intensities of the wrong length
    auto s = scan(2.0, ros::Time::now());
    s.intensities.assign(7, 1.0f);
    hostile_scan.publish(s);
  });
  attacks.push_back([&] {  // angle_increment 0
    auto s = scan(2.0, ros::Time::now());
    s.angle_increment = 0.0f;
    hostile_scan.publish(s);
  });
  attacks.push_back([&] {  // range_max NaN
    auto s = scan(2.0, ros::Time::now());
    s.range_max = kNaN;
    hostile_scan.publish(s);
  });

  const int kValid = 12;
  for (int k = 0; k < kValid; ++k) {
    toBoth(scan(2.0 + 0.01 * k, t0 + ros::Duration(0.01 * k)));
    ros::WallDuration(0.03).sleep();
    if (k < static_cast<int>(attacks.size())) attacks[k]();
    ros::WallDuration(0.03).sleep();
  }
  ASSERT_TRUE(waitFor([&] {
    return diagnostic("hostile", "scans_inserted") >= kValid && diagnostic("clean", "scans_inserted") >= kValid &&
           diagnostic("hostile", "skipped_cloud_short_data") >= 2;
  }, 30.0)) << "hostile inserted " << diagnostic("hostile", "scans_inserted") << ", clean "
            << diagnostic("clean", "scans_inserted");
  // Each hostile message counted under a reason; the clean node skipped nothing.
  EXPECT_GE(diagnostic("hostile", "skipped_cloud_short_data"), 2);
  EXPECT_GE(diagnostic("hostile", "skipped_cloud_bad_layout"), 1);
  EXPECT_GE(diagnostic("hostile", "skipped_cloud_bad_fields"), 1);
  EXPECT_GE(diagnostic("hostile", "skipped_zero_stamp"), 1);
  EXPECT_GE(diagnostic("hostile", "skipped_invalid_scan"), 1) << "the origin out of the octree's range";
  EXPECT_GE(diagnostic("hostile", "skipped_unknown_frame"), 1);
  EXPECT_GE(diagnostic("hostile", "skipped_length_mismatch"), 1);
  EXPECT_GE(diagnostic("hostile", "skipped_bad_angles"), 1);
  EXPECT_GE(diagnostic("hostile", "skipped_bad_range_limits"), 1);
  EXPECT_EQ(diagnostic("clean", "scans_skipped"), 0);
  EXPECT_EQ(diagnostic("hostile", "scans_inserted"), kValid);
  EXPECT_EQ(diagnostic("hostile", "clouds_inserted"), 0);
  EXPECT_EQ(diagnostic("clean", "scans_inserted"), kValid);

  // Hostile requests: refused with a reason, nothing written.
  octo_slice_mapper::SaveMap bad;
  for (const std::string& prefix : {std::string("two\nlines"), std::string(251, 'p'), std::string("../outside")}) {
    bad.request.prefix = prefix;
    ASSERT_TRUE(ros::service::call("hostile/save_map", bad));
    EXPECT_FALSE(bad.response.success) << prefix.size() << " characters";
    EXPECT_FALSE(bad.response.message.empty());
  }

  // Both save; the files are the same bytes.
  for (const char* node : {"hostile", "clean"}) {
    octo_slice_mapper::SaveMap save;
    save.request.prefix = node;
    ASSERT_TRUE(ros::service::waitForService(std::string(node) + "/save_map", 10000));
    ASSERT_TRUE(ros::service::call(std::string(node) + "/save_map", save));
    ASSERT_TRUE(save.response.success) << node << ": " << save.response.message;
  }
  for (const char* ext : {".bt", ".ot", ".pgm"}) {
    std::string hostile, clean, error;
    ASSERT_TRUE(octo_slice_mapper::readFile(std::string(kMapsDir) + "/hostile" + ext, &hostile, &error)) << error;
    ASSERT_TRUE(octo_slice_mapper::readFile(std::string(kMapsDir) + "/clean" + ext, &clean, &error)) << error;
    EXPECT_GT(hostile.size(), 100u) << ext;
    EXPECT_TRUE(hostile == clean) << ext << ": the hostile node's map differs from the valid messages' map";
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "hostile_sender_rostest");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
