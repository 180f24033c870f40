#include "octo_slice_mapper/internal/scan_store.h"

#include <cmath>
#include <cstring>

namespace octo_slice_mapper {

Scan StoredScan::toScan() const {
  Scan scan;
  scan.sensor_pose = Eigen::Isometry3d::Identity();
  scan.sensor_pose.linear() = rotation.cast<double>().toRotationMatrix();
  scan.sensor_pose.translation() = origin.cast<double>();
  scan.angle_min = angle_min;
  scan.angle_increment = angle_increment;
  scan.range_min = range_min;
  scan.range_max = range_max;
  scan.ranges = ranges;
  return scan;
}

// Position and heading (of the laser's x axis, in the map's x-y plane) quantised into one key,
// mixed with where the scan's beams lie in the laser's frame (its first angle and count): two
// lidars on one base, or a lidar's beams split over two topics, share a position and may share a
// heading, but not the beams. One lidar's scans all have the same beams, and so the same mix.
std::uint64_t ScanStore::revisitBin(const Eigen::Vector3f& origin, const Eigen::Quaternionf& rotation,
                                    float angle_min, std::size_t beams) const {
  const Eigen::Vector3f axis = rotation * Eigen::Vector3f::UnitX();
  auto bin = [](double v, double size) {
    return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v / size)) & 0x1FFFFF);
  };
  std::uint32_t angle_bits = 0;
  std::memcpy(&angle_bits, &angle_min, sizeof angle_bits);
  std::uint64_t beams_mix = (std::uint64_t{angle_bits} << 32 | static_cast<std::uint32_t>(beams)) * 0x9E3779B97F4A7C15ull;
  beams_mix ^= beams_mix >> 29;
  return (bin(origin.x(), options_.revisit_cell) | bin(origin.y(), options_.revisit_cell) << 21 |
          bin(std::atan2(axis.y(), axis.x()) + M_PI, options_.revisit_angle) << 42) ^
         beams_mix;
}

std::uint64_t ScanStore::revisitBinOf(const StoredScan& s) const {
  return revisitBin(s.origin, s.rotation, s.angle_min, s.ranges.size());
}

bool ScanStore::add(const Scan& scan) {
  const Eigen::Vector3f origin = scan.sensor_pose.translation().cast<float>();
  const Eigen::Quaternionf rotation(scan.sensor_pose.linear().cast<float>());
  const bool revisits = options_.revisit_cell > 0.0 && options_.revisit_angle > 0.0 && origin.allFinite();
  const std::uint64_t bin = revisits ? revisitBin(origin, rotation, scan.angle_min, scan.ranges.size()) : 0;
  if (revisits && visited_.count(bin)) {
    ++revisits_;
    return false;
  }
  if (!scans_.empty() && (options_.min_distance > 0.0 || options_.min_rotation > 0.0)) {
    const StoredScan& last = scans_.back();
    const bool moved = (origin - last.origin).norm() >= options_.min_distance;
    const bool turned = last.rotation.angularDistance(rotation) >= options_.min_rotation;
    if (!moved && !turned) {
      ++skipped_;
      return false;
    }
  }
  if (options_.max_scans > 0 && scans_.size() >= options_.max_scans) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < scans_.size(); i += 2, ++kept) {
      if (i != kept) scans_[kept] = std::move(scans_[i]);  // a self-move would empty the ranges
    }
    dropped_ += scans_.size() - kept;
    scans_.resize(kept);
    ++rewrites_;
    visited_.clear();  // places of dropped scans may be kept again
    if (revisits) {
      for (const StoredScan& s : scans_) visited_.insert(revisitBinOf(s));
    }
  }
  if (revisits) visited_.insert(bin);
  scans_.push_back({origin, rotation, scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max, scan.ranges});
  scans_.back().ranges.shrink_to_fit();
  return true;
}

std::size_t ScanStore::removeIf(const std::function<bool(const StoredScan&)>& drop) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < scans_.size(); ++i) {
    if (drop(scans_[i])) continue;
    if (i != kept) scans_[kept] = std::move(scans_[i]);
    ++kept;
  }
  const std::size_t removed = scans_.size() - kept;
  scans_.resize(kept);
  if (removed > 0) {  // the places of dropped scans may be kept again
    ++rewrites_;
    visited_.clear();
    for (const StoredScan& s : scans_) {
      if (options_.revisit_cell > 0.0 && options_.revisit_angle > 0.0 && s.origin.allFinite()) {
        visited_.insert(revisitBinOf(s));
      }
    }
  }
  return removed;
}

void ScanStore::clear() {
  scans_.clear();
  visited_.clear();
  skipped_ = dropped_ = revisits_ = 0;
  ++rewrites_;
}

std::size_t ScanStore::memoryBytes() const {
  std::size_t bytes = sizeof(*this) + scans_.capacity() * sizeof(StoredScan) +
                      visited_.size() * (sizeof(std::uint64_t) + 2 * sizeof(void*));
  for (const StoredScan& s : scans_) bytes += s.ranges.capacity() * sizeof(float);
  return bytes;
}

}  // namespace octo_slice_mapper
