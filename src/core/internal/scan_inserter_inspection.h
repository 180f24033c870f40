// A narrow window into ScanInserter's fast path, for the tests, the benchmarks and the
// straightforward reference implementations that check it: the beams it reads from a scan or a
// cloud, the evidence it traces and the per-voxel updates it would apply. None of these changes
// the map; the mapper's own callers never need them (they insert, flush and read the octree).
#pragma once

#include <functional>
#include <vector>

#include "octo_slice_mapper/internal/scan_inserter.h"

namespace octo_slice_mapper {

class ScanInserterInspection {
 public:
  explicit ScanInserterInspection(ScanInserter& inserter) : inserter_(inserter) {}

  // How a cloud is read as beams (InsertOptions' cloud_* rules), in a deterministic order.
  std::vector<Beam> cloudBeams(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                               ReadingCounts* counts) const {
    return inserter_.cloudBeams(origin, points, counts);
  }
  // How a scan is read as beams.
  std::vector<Beam> beamsOf(const Scan& scan, ReadingCounts* counts) { return inserter_.beamsOf(scan, counts); }

  // Every (voxel, evidence) pair the model gives for a scan, each beam's once per voxel, before
  // the beams are combined per voxel. By default the model is evaluated for every voxel; with
  // `shortcuts`, as the fast path does, not where a voxel is surely in the free valley (the pairs
  // must be the same).
  void traceEvidence(const Scan& scan, const std::function<void(const octomap::OcTreeKey&, float)>& fn,
                     bool shortcuts = false) {
    inserter_.traceEvidence(scan, fn, shortcuts);
  }
  // The same for any beams from `origin` (a cloud's, from cloudBeams).
  void traceEvidence(const Eigen::Vector3d& origin, const std::vector<Beam>& beams, double half_angle,
                     const std::function<void(const octomap::OcTreeKey&, float)>& fn, bool shortcuts = false) {
    inserter_.traceEvidence(origin, beams, half_angle, fn, shortcuts);
  }
  // Per-voxel log-odds updates of beams before they are applied, in traversal order (a cloud's
  // first step).
  std::vector<KeyUpdate> computeUpdates(const Eigen::Vector3d& origin, const std::vector<Beam>& beams,
                                        double half_angle) {
    return inserter_.computeUpdates(origin, beams, half_angle);
  }
  // Whether a cloud's backward walk skips voxels its evidence cannot change (on by default): off,
  // the model is asked for them too, and the updates must be the same.
  void skipSettledVoxels(bool on) { inserter_.skip_settled_voxels_ = on; }

 private:
  ScanInserter& inserter_;
};

}  // namespace octo_slice_mapper
