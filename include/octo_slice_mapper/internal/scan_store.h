// The scans kept for the global pass: compact, bounded in number, thinned by keyframe selection.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <unordered_set>
#include <vector>

#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {

struct StoredScan {
  Eigen::Vector3f origin;         // laser origin in the map frame
  Eigen::Quaternionf rotation;    // laser orientation in the map frame
  float angle_min, angle_increment, range_min, range_max;
  std::vector<float> ranges;

  Scan toScan() const;
  std::size_t bytes() const { return sizeof(StoredScan) + ranges.capacity() * sizeof(float); }
};

struct ScanStoreOptions {
  // Keep a scan only after the laser moved this far (m) or turned this much (rad) since the last
  // kept one. The defaults keep every scan (the shared datasets are already thinned).
  double min_distance = 0.0;
  double min_rotation = 0.0;
  // Skip a scan taken where a kept one was taken by the same lidar: laser position in the same
  // revisit_cell x revisit_cell square and heading in the same revisit_angle sector (and the same
  // beams: a second lidar at the same place is no revisit). A robot standing still, or a bag
  // replayed in a loop, then stops adding scans, so the store grows with the explored area, not
  // with time. 0 disables it.
  double revisit_cell = 0.02;   // m
  double revisit_angle = 0.02;  // rad
  // At most this many scans; when full, every second scan is dropped (uniform thinning), so the
  // store keeps covering the whole run. 20000 scans of 1081 beams are ~90 MB.
  std::size_t max_scans = 20000;
};

class ScanStore {
 public:
  explicit ScanStore(const ScanStoreOptions& options = {}) : options_(options) {}

  // True when kept.
  bool add(const Scan& scan);
  void clear();
  // Drops the kept scans `drop` is true for; returns how many.
  std::size_t removeIf(const std::function<bool(const StoredScan&)>& drop);
  const std::vector<StoredScan>& scans() const { return scans_; }
  std::size_t memoryBytes() const;
  std::uint64_t skippedByKeyframe() const { return skipped_; }
  std::uint64_t skippedAsRevisit() const { return revisits_; }
  std::uint64_t droppedWhenFull() const { return dropped_; }
  // Counts the changes other than appending a scan (thinning, removeIf, clear): while it stays
  // the same, a copy of scans() can be brought up to date by appending the scans past its end.
  std::uint64_t rewrites() const { return rewrites_; }

 private:
  std::uint64_t revisitBin(const Eigen::Vector3f& origin, const Eigen::Quaternionf& rotation, float angle_min,
                           std::size_t beams) const;
  std::uint64_t revisitBinOf(const StoredScan& scan) const;

  ScanStoreOptions options_;
  std::vector<StoredScan> scans_;
  std::unordered_set<std::uint64_t> visited_;  // revisit bins of the kept scans
  std::uint64_t skipped_ = 0, dropped_ = 0, revisits_ = 0;
  std::uint64_t rewrites_ = 0;
};

}  // namespace octo_slice_mapper
