// Shared by the benchmarks: medians, and scans' returns as OctoMap point clouds (for the methods
// OctoMap offers, which take returns only).
#pragma once

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {
namespace bench {

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct CloudScan {
  octomap::point3d origin;
  octomap::Pointcloud points;  // the returns (readings classified kHit), in the map frame
};

inline std::vector<CloudScan> returnsAsClouds(const std::vector<Scan>& scans) {
  std::vector<CloudScan> clouds;
  clouds.reserve(scans.size());
  for (const Scan& s : scans) {
    CloudScan c;
    const Eigen::Vector3d o = s.sensor_pose.translation();
    c.origin = octomap::point3d(o.x(), o.y(), o.z());
    for (std::size_t i = 0; i < s.ranges.size(); ++i) {
      if (classifyReading(s.ranges[i], s.range_min, s.range_max, {}) != ReadingKind::kHit) continue;
      const double a = s.beamAngle(i);
      const Eigen::Vector3d p = s.sensor_pose * Eigen::Vector3d(s.ranges[i] * std::cos(a), s.ranges[i] * std::sin(a), 0.0);
      c.points.push_back(p.x(), p.y(), p.z());
    }
    clouds.push_back(std::move(c));
  }
  return clouds;
}

// One scan as octomap_server's insertScan puts it into its octree (without its ground filter):
// free / occupied KeySets from computeRayKeys (occupied wins), then updateNode per key.
inline void insertLikeOctomapServer(octomap::OcTree* tree, const CloudScan& scan) {
  octomap::KeySet free_cells, occupied_cells;
  octomap::KeyRay ray;
  for (const octomap::point3d& p : scan.points) {
    if (tree->computeRayKeys(scan.origin, p, ray)) free_cells.insert(ray.begin(), ray.end());
    octomap::OcTreeKey key;
    if (tree->coordToKeyChecked(p, key)) occupied_cells.insert(key);
  }
  for (const octomap::OcTreeKey& k : free_cells) {
    if (!occupied_cells.count(k)) tree->updateNode(k, false);
  }
  for (const octomap::OcTreeKey& k : occupied_cells) tree->updateNode(k, true);
}

}  // namespace bench
}  // namespace octo_slice_mapper
