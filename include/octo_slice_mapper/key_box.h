// Axis-aligned bounding box of octree keys, used to limit work to what a scan touched.
#pragma once

#include <octomap/OcTreeKey.h>

#include <algorithm>

namespace octo_slice_mapper {

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
};

}  // namespace octo_slice_mapper
