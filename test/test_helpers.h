// Small builders shared by the core tests.
#pragma once

#include <dirent.h>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <string>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {
namespace test_support {

// Same nodes (inner ones too) with the same log-odds and children: the same tree, pruning and all.
inline void expectSameTree(const octomap::OcTree& a, const octomap::OcTree& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.getNumLeafNodes(), b.getNumLeafNodes());
  for (auto it = a.begin_tree(); it != a.end_tree(); ++it) {
    if (it.getDepth() == 0) continue;  // search() reads depth 0 as "full depth"
    const octomap::OcTreeNode* other = b.search(it.getKey(), it.getDepth());
    ASSERT_NE(other, nullptr);
    ASSERT_EQ(other->getLogOdds(), it->getLogOdds());
    ASSERT_EQ(b.nodeHasChildren(other), a.nodeHasChildren(&*it));
  }
}

// The lab's TurtleBot laser mount: 0.10 m forward, 0.26 m up, on a robot at (x, y, yaw).
inline Eigen::Isometry3d laserPoseOnRobot(double x, double y, double yaw, double pitch = 0.0) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(x, y, 0.0));
  pose.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  pose.rotate(Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()));
  pose.translate(Eigen::Vector3d(0.10, 0.0, 0.26));
  return pose;
}

inline Scan makeScan(const Eigen::Isometry3d& pose, float angle_min, float increment, std::vector<float> ranges,
                     float range_min = 0.02f, float range_max = 5.6f) {
  Scan scan;
  scan.sensor_pose = pose;
  scan.angle_min = angle_min;
  scan.angle_increment = increment;
  scan.range_min = range_min;
  scan.range_max = range_max;
  scan.ranges = std::move(ranges);
  return scan;
}

// The shared datasets: $OSM_DATA_DIR, by default ../shared/data beside the checkout (never
// copied into the project).
inline std::string sharedDataDir() {
  const char* dir = std::getenv("OSM_DATA_DIR");
  return dir && *dir ? dir : std::string(OSM_SOURCE_DIR) + "/../shared/data";
}

// Names in a folder (without "." and "..").
inline std::vector<std::string> filesIn(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (dirent* e = ::readdir(d)) {
      const std::string n = e->d_name;
      if (n != "." && n != "..") names.push_back(n);
    }
    ::closedir(d);
  }
  return names;
}

}  // namespace test_support
}  // namespace octo_slice_mapper
