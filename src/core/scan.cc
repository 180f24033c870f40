#include "octo_slice_mapper/scan.h"

#include <cmath>
#include <cstring>
#include <sstream>

namespace octo_slice_mapper {

const char* readingKindName(ReadingKind kind) {
  switch (kind) {
    case ReadingKind::kHit: return "hit";
    case ReadingKind::kNoReturn: return "no_return";
    case ReadingKind::kNaN: return "nan";
    case ReadingKind::kInfinite: return "inf";
    case ReadingKind::kNegative: return "negative";
    case ReadingKind::kBelowMin: return "below_min";
    case ReadingKind::kFlyingPixel: return "flying_pixel";
  }
  return "unknown";
}

ReadingKind classifyReading(float range, float range_min, float range_max, const ReadingPolicy& policy) {
  if (std::isnan(range)) return ReadingKind::kNaN;
  if (std::isinf(range)) {
    return (range > 0 && policy.inf_is_no_return) ? ReadingKind::kNoReturn : ReadingKind::kInfinite;
  }
  if (range < 0.0f) return ReadingKind::kNegative;
  if (range < range_min) return ReadingKind::kBelowMin;
  if (range >= range_max) return ReadingKind::kNoReturn;
  return ReadingKind::kHit;
}

std::uint64_t ReadingCounts::skipped() const {
  return count[2] + count[3] + count[4] + count[5] + count[6];  // all but hits and no-returns
}

ReadingCounts& ReadingCounts::operator+=(const ReadingCounts& other) {
  for (int i = 0; i < kReadingKindCount; ++i) count[i] += other.count[i];
  return *this;
}

std::string ReadingCounts::summary() const {
  std::ostringstream out;
  for (int i = 0; i < kReadingKindCount; ++i) {
    if (i) out << ' ';
    out << readingKindName(static_cast<ReadingKind>(i)) << '=' << count[i];
  }
  return out.str();
}

std::string validateScanHeader(const Scan& scan, std::size_t max_beams) {
  if (scan.ranges.empty()) return "empty scan (no ranges)";
  if (scan.ranges.size() > max_beams) return "too many beams (" + std::to_string(scan.ranges.size()) + ")";
  if (!std::isfinite(scan.angle_min) || !std::isfinite(scan.angle_increment) || scan.angle_increment == 0.0f) {
    return "angle_increment must be finite and non-zero";
  }
  if (!std::isfinite(scan.range_min) || !std::isfinite(scan.range_max) || scan.range_min < 0.0f ||
      scan.range_max <= scan.range_min) {
    return "range_min/range_max must be finite with 0 <= range_min < range_max";
  }
  if (!scan.sensor_pose.matrix().allFinite()) return "sensor pose is not finite";
  return "";
}

const std::vector<Eigen::Vector2d>& BeamDirections::of(const Scan& scan) {
  // The angles compared bit for bit: with ==, a NaN angle would never match and the table would be
  // made anew for every scan.
  if (unit_.size() != scan.ranges.size() || std::memcmp(&angle_min_, &scan.angle_min, sizeof(float)) != 0 ||
      std::memcmp(&angle_increment_, &scan.angle_increment, sizeof(float)) != 0) {
    angle_min_ = scan.angle_min;
    angle_increment_ = scan.angle_increment;
    unit_.resize(scan.ranges.size());
    for (std::size_t i = 0; i < unit_.size(); ++i) {
      const double a = scan.beamAngle(i);
      unit_[i] = Eigen::Vector2d(std::cos(a), std::sin(a));
    }
  }
  return unit_;
}

}  // namespace octo_slice_mapper
