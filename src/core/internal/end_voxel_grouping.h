// A depth frame's points grouped by the octree voxel they end in: one ray per end
// voxel, towards the mean of its points, instead of one per point.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdint>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {

// Points that end in one voxel: its key (x | y << 16 | z << 32), their sum and their count.
struct EndVoxel {
  std::uint64_t key;
  Eigen::Vector3d sum;
  std::uint64_t n;
};

struct EndVoxels {
  std::vector<EndVoxel> voxels;          // in a deterministic order (see groupByEndVoxel)
  std::vector<Eigen::Vector3d> outside;  // finite points outside the octree's keys, in order
  ReadingCounts non_finite;              // nan / inf
};

// What keyCoordinates gives a coordinate that has no key: NaN, infinite or outside the octree.
constexpr std::int32_t kNoKeyCoordinate = -1;

// Per float of `coords` (a frame's x, y, z in turn), its key along its axis in an octree whose key
// of coordinate 0 is `centre` (OctoMap's tree_max_val) and whose 1 / resolution is `inverse`:
// trunc(double(c) * inverse + centre) where that lies in [0, 2 centre), else kNoKeyCoordinate.
// This is OctoMap's floor(c / resolution) + centre but at the rounding of a value within an ulp
// of a voxel boundary (the grouping has always used it). On x86-64 four floats at a time (SSE2),
// each the same as keyCoordinateOf.
void keyCoordinates(const float* coords, std::size_t count, double inverse, double centre, std::int32_t* keys);
// One coordinate: the reference for keyCoordinates.
std::int32_t keyCoordinateOf(float coord, double inverse, double centre);

// Points by the voxel (of an octree of this resolution and depth) they end in, with the
// non-finite ones counted and the ones outside the octree's keys listed. The same groups, sums
// and order on any number of `threads` (0: every core). The points are summed in floats as
// offsets from `reference`, a point near them (the sensor's origin; a float, so that what is
// added back to the sums is what was taken off). Each addition rounds by at most half an ulp of
// the sum, so the mean of a voxel's n points, each at most d from the reference, is within
// n d 2^-24 of theirs (0.1 mm for 2 000 points 1 m away, a camera's closest voxels; far less
// in practice, the roundings cancelling), however far from the map's origin they are. (No
// default: the map's origin, far from a robot's points, is the reference that loses precision.)
EndVoxels groupByEndVoxel(const std::vector<Eigen::Vector3f>& points, double resolution, unsigned depth,
                          unsigned threads, const Eigen::Vector3f& reference);

// The mean of a voxel's points, inside the voxel: a millionth of a voxel in from a face it lies
// on or, by the sums' rounding, just beyond (points on a face, as a simulated wall's, are common).
// Its octree key is the voxel's. (Inline: a frame has thousands of voxels.)
inline Eigen::Vector3d meanInVoxel(const EndVoxel& voxel, double resolution, unsigned depth) {
  const double centre = static_cast<double>(1 << (depth - 1));
  // A millionth of a voxel: far beyond the rounding of a key's arithmetic.
  const double margin = 1e-6 * resolution;
  const double n = static_cast<double>(voxel.n);
  Eigen::Vector3d mean;
  for (int d = 0; d < 3; ++d) {
    const double low = (static_cast<double>((voxel.key >> (16 * d)) & 0xffff) - centre) * resolution;
    mean[d] = std::min(std::max(voxel.sum[d] / n, low + margin), low + (resolution - margin));
  }
  return mean;
}

}  // namespace octo_slice_mapper
