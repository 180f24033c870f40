// A planar range scan in core terms: where the sensor was, and what each beam read.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "octo_slice_mapper/internal/flying_pixels.h"

namespace octo_slice_mapper {

// One 2D lidar sweep. Beams lie in the sensor frame's x-y plane; the sensor pose is
// full 3D (from tf), so a tilted robot yields tilted rays.
struct Scan {
  Eigen::Isometry3d sensor_pose = Eigen::Isometry3d::Identity();  // sensor frame -> map frame
  double stamp = 0.0;                                              // seconds
  float angle_min = 0.0f;                                          // rad, angle of ranges[0]
  float angle_increment = 0.0f;                                    // rad between beams
  float range_min = 0.0f;                                          // m, readings below are invalid
  float range_max = 0.0f;                                          // m, readings at/above mean "no return"
  std::vector<float> ranges;                                       // m

  double beamAngle(std::size_t i) const { return angle_min + static_cast<double>(i) * angle_increment; }
};

// cos and sin of each beam's angle (Scan::beamAngle), kept while the scans' geometry stays the
// same: a lidar's does, and four calls per beam are a measurable share of a scan's insertion.
class BeamDirections {
 public:
  // The table for `scan`'s angle_min, angle_increment and number of beams, made anew only when
  // they differ from the last scan's. Entry i is {cos, sin} of beamAngle(i), the same doubles
  // std::cos / std::sin give for it.
  const std::vector<Eigen::Vector2d>& of(const Scan& scan);

 private:
  float angle_min_ = 0.0f, angle_increment_ = 0.0f;
  std::vector<Eigen::Vector2d> unit_;
};

// How one reading is interpreted. Invalid readings carry no information and are counted.
enum class ReadingKind : std::uint8_t {
  kHit,          // a return inside (range_min, range_max)
  kNoReturn,     // at or beyond range_max: free space up to a clearing distance, nothing occupied
  kNaN,          // driver error
  kInfinite,     // -inf ("too close", REP 117), and +inf when ReadingPolicy::inf_is_no_return is off
  kNegative,     // < 0
  kBelowMin,     // in [0, range_min)
  kFlyingPixel,  // a depth camera's mixed pixel at a depth edge, floating in free air (flying_pixels.h)
};
constexpr int kReadingKindCount = 7;
const char* readingKindName(ReadingKind kind);

struct ReadingPolicy {
  // REP 117: +inf is "nothing within range" (a no-return), -inf "too close" (counted as kInfinite,
  // no update), NaN invalid. false: +inf is invalid too, as some older drivers emit it on errors.
  bool inf_is_no_return = true;
};

ReadingKind classifyReading(float range, float range_min, float range_max, const ReadingPolicy& policy);

// Per-reason counters for readings of one or many scans.
struct ReadingCounts {
  std::uint64_t count[kReadingKindCount] = {};
  std::uint64_t& operator[](ReadingKind k) { return count[static_cast<int>(k)]; }
  std::uint64_t operator[](ReadingKind k) const { return count[static_cast<int>(k)]; }
  std::uint64_t skipped() const;  // readings left out: all but hits and no-returns
  ReadingCounts& operator+=(const ReadingCounts& other);
  std::string summary() const;  // "hit=.. no_return=.. nan=.." for logs
};

// How a non-finite point is counted: NaN if any coordinate is, else infinite.
inline ReadingKind nonFiniteKind(const Eigen::Vector3f& p) {
  return p.array().isNaN().any() ? ReadingKind::kNaN : ReadingKind::kInfinite;
}

// A 3D sensor's points in the map frame, with the sensor origin they were seen from.
struct SensorCloud {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  // A point on the floor the sensor's carrier stands on (a robot's base_footprint), in the map
  // frame: the frame's floor is then the one through it (FloorLayer::observe). Empty for a
  // hand-held camera, whose floor is found from the points alone.
  std::optional<Eigen::Vector3d> ground;
  std::vector<Eigen::Vector3f> points;  // may hold non-finite points too: the core counts them
  // Points the conversion left out because a coordinate was NaN or infinite, counted per reason
  // (kNaN, kInfinite): an organized frame is 40 % NaN, and each such point cost the grouping
  // as much as a finite one.
  ReadingCounts left_out;
};

// A cloud whose points are made where it is prepared (a CloudPipeline's worker), so that the
// thread that received it only hands it on: converting a 640 x 480 PointCloud2 into the map frame
// is 1-2.5 ms that the node's scan thread no longer spends.
struct DeferredCloud {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> ground;  // as SensorCloud's
  // Fills in the points (map frame) and the count of those left out; an organized frame's
  // flying pixels are left out by `flying`'s rule (flying_pixels.h).
  std::function<void(std::vector<Eigen::Vector3f>*, ReadingCounts*, const FlyingPixelOptions& flying)> points;
  // The cloud, its points made now (what `points` throws goes to the caller).
  SensorCloud made(const FlyingPixelOptions& flying) const {
    SensorCloud cloud;
    cloud.origin = origin;
    cloud.ground = ground;
    points(&cloud.points, &cloud.left_out, flying);
    return cloud;
  }
};

// Structural problems that make a whole scan unusable (as opposed to single bad readings).
// Returns an empty string when the scan is usable.
std::string validateScanHeader(const Scan& scan, std::size_t max_beams = 100000);

}  // namespace octo_slice_mapper
