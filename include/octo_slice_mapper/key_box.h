// Octree keys: a safe coordinate -> key conversion, and a bounding box of keys used to limit work
// to what a scan touched.
#pragma once

#include <octomap/OcTree.h>
#include <octomap/OcTreeKey.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace octo_slice_mapper {

// OctoMap's coordToKeyChecked casts the scaled coordinate to int before its range check, which is
// undefined behaviour for a coordinate that is not finite or far outside the tree (found by
// fuzzing: a finite pose of 1e308 m, or a 3e38 m reading under range_max = FLT_MAX). This checks
// the range in double first, then computes OctoMap's key, floor(coordinate / resolution) + the
// centre key, with OctoMap's own arithmetic (the factor 1 / resolution as OcTreeBaseImpl keeps
// it) but inline and with the floor taken from the truncation: through the tree it was an
// out-of-line call and a libm floor() per axis, for every ray end of every scan and frame.
inline bool coordToKeySafe(const octomap::OcTree& tree, double x, double y, double z, octomap::OcTreeKey* key) {
  const double resolution = tree.getResolution();
  const int centre = 1 << (tree.getTreeDepth() - 1);  // OctoMap's tree_max_val
  const double half_extent = resolution * centre;
  if (!(std::abs(x) < half_extent && std::abs(y) < half_extent && std::abs(z) < half_extent)) return false;
  const double factor = 1. / resolution;  // OcTreeBaseImpl's resolution_factor
  const auto keyOf = [&](double coordinate, octomap::key_type* k) {
    const double scaled = factor * coordinate;  // within (-centre, centre] after the check above
    int floored = static_cast<int>(scaled);      // truncation, then down for negative non-integers
    floored -= scaled < static_cast<double>(floored);
    const int v = floored + centre;
    if (v < 0 || v >= 2 * centre) return false;
    *k = static_cast<octomap::key_type>(v);
    return true;
  };
  octomap::OcTreeKey k;
  if (!keyOf(x, &k[0]) || !keyOf(y, &k[1]) || !keyOf(z, &k[2])) return false;
  *key = k;
  return true;
}

struct KeyBox {
  octomap::OcTreeKey min{0xFFFF, 0xFFFF, 0xFFFF};
  octomap::OcTreeKey max{0, 0, 0};

  bool empty() const { return min[0] > max[0]; }
  void add(const octomap::OcTreeKey& k) {
    for (int i = 0; i < 3; ++i) {
      min[i] = std::min(min[i], k[i]);
      max[i] = std::max(max[i], k[i]);
    }
  }
  void add(const KeyBox& other) {
    if (other.empty()) return;
    add(other.min);
    add(other.max);
  }
  // The box of `keys` (empty for none).
  static KeyBox of(const std::vector<octomap::OcTreeKey>& keys) {
    KeyBox box;
    for (const octomap::OcTreeKey& k : keys) box.add(k);
    return box;
  }
};

}  // namespace octo_slice_mapper
