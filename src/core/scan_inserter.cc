#include "octo_slice_mapper/scan_inserter.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace octo_slice_mapper {
namespace {
// Above this many cells the dense window would cost more memory than it saves (e.g. 80 m returns
// at 0.02 m); such scans use a hash map instead.
constexpr std::size_t kMaxWindowCells = std::size_t{16} << 20;
// Visits, in order, the voxels the segment from `from` to `to` crosses (Amanatides & Woo), from
// the voxel of `from` to the voxel of `to`, both included. Inline, so nothing is stored per step.
template <typename Visit>
inline void traverseVoxels(const octomap::OcTree& tree, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                           const octomap::OcTreeKey& from_key, const octomap::OcTreeKey& to_key, Visit&& visit) {
  const double resolution = tree.getResolution();
  const Eigen::Vector3d delta = to - from;
  int key[3] = {from_key[0], from_key[1], from_key[2]};
  int step[3];
  double t_max[3], t_delta[3];
  int steps_left = 0;
  for (int i = 0; i < 3; ++i) {
    steps_left += std::abs(int(to_key[i]) - key[i]);
    if (delta[i] > 0.0) {
      step[i] = 1;
      t_delta[i] = resolution / delta[i];
      t_max[i] = (tree.keyToCoord(from_key[i]) + 0.5 * resolution - from[i]) / delta[i];
    } else if (delta[i] < 0.0) {
      step[i] = -1;
      t_delta[i] = -resolution / delta[i];
      t_max[i] = (tree.keyToCoord(from_key[i]) - 0.5 * resolution - from[i]) / delta[i];
    } else {
      step[i] = 0;
      t_delta[i] = t_max[i] = std::numeric_limits<double>::infinity();
    }
  }
  octomap::OcTreeKey current = from_key;
  visit(current);
  // Exactly one axis advances per step, so the end voxel is reached after steps_left steps.
  for (; steps_left > 0; --steps_left) {
    const int dim = t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
    key[dim] += step[dim];
    t_max[dim] += t_delta[dim];
    current[dim] = static_cast<octomap::key_type>(key[dim]);
    visit(current);
  }
  if (!(current == to_key)) visit(to_key);  // rounding took another route: still end at the return
}

}  // namespace

ScanInserter::ScanInserter(octomap::OcTree* tree, const InsertOptions& options)
    : tree_(tree), options_(options), model_(options.model, 0.5 * tree->getResolution()) {}

std::vector<Beam> ScanInserter::beamsOf(const Scan& scan, ReadingCounts* counts) const {
  std::vector<Beam> beams;
  beams.reserve(scan.ranges.size());
  const Eigen::Matrix3d rotation = scan.sensor_pose.linear();
  const double clear = std::min<double>(options_.model.no_return_clear_distance, scan.range_max);
  const double max_range = options_.max_range > 0.0 ? options_.max_range : 1e30;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const float r = scan.ranges[i];
    const ReadingKind kind = classifyReading(r, scan.range_min, scan.range_max, options_.readings);
    if (counts) (*counts)[kind]++;
    const double a = scan.beamAngle(i);
    const Eigen::Vector3d dir = rotation * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
    const Eigen::Vector3d across = rotation * Eigen::Vector3d(-std::sin(a), std::cos(a), 0.0);
    if (kind == ReadingKind::kHit) {
      if (r > max_range) {
        beams.push_back({dir, max_range, false, across});  // cut beam: seen free up to max_range
      } else {
        beams.push_back({dir, r, true, across});
      }
    } else if (kind == ReadingKind::kNoReturn && clear > 0.0) {
      beams.push_back({dir, std::min(clear, max_range), false, across});
    }
  }
  return beams;
}

InsertResult ScanInserter::insert(const Scan& scan) {
  InsertResult result;
  result.error = validateScanHeader(scan);
  if (!result.ok()) return result;
  const std::vector<Beam> beams = beamsOf(scan, &result.readings);
  const double half_angle = model_.halfAngleFor(scan.angle_increment);
  return apply(computeUpdates(scan.sensor_pose.translation(), beams, half_angle), result);
}

InsertResult ScanInserter::insertPoints(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                                        double half_angle) {
  InsertResult result;
  if (!origin.allFinite()) {
    result.error = "sensor origin is not finite";
    return result;
  }
  std::vector<Beam> beams;
  beams.reserve(points.size());
  const double max_range = options_.max_range > 0.0 ? options_.max_range : 1e30;
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector3d v = p.cast<double>() - origin;
    const double r = v.norm();
    if (!std::isfinite(r)) {
      result.readings[ReadingKind::kNaN]++;
      continue;
    }
    if (r < 1e-6) {
      result.readings[ReadingKind::kBelowMin]++;
      continue;
    }
    result.readings[ReadingKind::kHit]++;
    beams.push_back({v / r, std::min(r, max_range), r <= max_range});
  }
  return apply(computeUpdates(origin, beams, half_angle), result);
}

double ScanInserter::traceLength(const Beam& beam) const {
  return beam.hit ? beam.length + model_.traceMargin(beam.length) : beam.length;
}

void ScanInserter::prepareWindow(const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi) {
  window_lo_ = lo;
  window_nx_ = hi[0] - lo[0] + 1;
  window_ny_ = hi[1] - lo[1] + 1;
  window_nz_ = hi[2] - lo[2] + 1;
  const std::size_t cells = std::size_t(window_nx_) * window_ny_ * window_nz_;
  if (cells > kMaxWindowCells) {
    window_nx_ = 0;  // sparse mode
    return;
  }
  if (window_.size() < cells) window_.assign(cells, -1);
}

// Per visited voxel: forced inline, a call each costs more than the work (measured with callgrind).
__attribute__((always_inline)) inline bool ScanInserter::inWindow(const octomap::OcTreeKey& key) const {
  return window_nx_ > 0 && key[0] >= window_lo_[0] && key[1] >= window_lo_[1] && key[2] >= window_lo_[2] &&
         key[0] - window_lo_[0] < window_nx_ && key[1] - window_lo_[1] < window_ny_ && key[2] - window_lo_[2] < window_nz_;
}

__attribute__((always_inline)) inline std::size_t ScanInserter::windowIndex(const octomap::OcTreeKey& key) const {
  return (std::size_t(key[2] - window_lo_[2]) * window_ny_ + (key[1] - window_lo_[1])) * window_nx_ +
         (key[0] - window_lo_[0]);
}

__attribute__((always_inline)) inline void ScanInserter::accumulate(const octomap::OcTreeKey& key, float value) {
  std::int32_t* slot_ref = nullptr;
  if (inWindow(key)) {
    slot_ref = &window_[windowIndex(key)];
  } else {
    slot_ref = &sparse_.emplace(key, -1).first->second;
  }
  if (*slot_ref < 0) {
    *slot_ref = static_cast<std::int32_t>(slots_.size());
    slots_.push_back({key, 0.0f, 0.0f});
  }
  Slot& slot = slots_[*slot_ref];
  if (value > slot.positive) slot.positive = value;
  if (value < slot.negative) slot.negative = value;
}

// The rays traced for one beam: its axis and, where the cone is wider than a voxel, rays fanned
// across the cone in the scan plane, at most one voxel apart at the far end.
void ScanInserter::fanOf(const Beam& beam, double tan_half, std::vector<Eigen::Vector3d>* directions) const {
  directions->clear();
  const double resolution = tree_->getResolution();
  const double half_width = traceLength(beam) * tan_half;
  // Bounded: an absurd reading (3e38 m under range_max = FLT_MAX) must not overflow the count;
  // such a beam leaves the tree and is dropped anyway.
  constexpr double kMaxFan = 4096.0;
  const double cells = half_width / resolution;
  const int fan = (beam.across.isZero() || half_width <= resolution) ? 0
                  : static_cast<int>(cells < kMaxFan ? std::ceil(cells) : kMaxFan);
  for (int k = -fan; k <= fan; ++k) {
    const double t = fan ? tan_half * k / fan : 0.0;
    directions->push_back((beam.direction + t * beam.across).normalized());
  }
}

std::vector<KeyUpdate> ScanInserter::computeUpdates(const Eigen::Vector3d& origin,
                                                                    const std::vector<Beam>& beams,
                                                                    double half_angle) {
  std::vector<KeyUpdate> updates;
  octomap::OcTreeKey origin_key;
  if (!coordToKeySafe(*tree_, origin.x(), origin.y(), origin.z(), &origin_key)) return updates;
  const double tan_half = std::tan(half_angle);

  // First pass: the key box of all ray ends (rays are straight, so the box of the origin and the
  // ends holds every voxel they cross). Beams leaving the octree's key range are dropped.
  std::vector<char> usable(beams.size(), 0);
  std::vector<Eigen::Vector3d> fan;
  KeyBox box;
  box.add(origin_key);
  for (std::size_t b = 0; b < beams.size(); ++b) {
    fanOf(beams[b], tan_half, &fan);
    KeyBox beam_box;
    bool inside = true;
    for (const Eigen::Vector3d& dir : fan) {  // the arc of ends bulges past the outer rays' chord
      const Eigen::Vector3d end = origin + dir * traceLength(beams[b]);
      octomap::OcTreeKey key;
      inside = inside && coordToKeySafe(*tree_, end.x(), end.y(), end.z(), &key);
      if (inside) beam_box.add(key);
    }
    if (!inside) continue;
    usable[b] = 1;
    box.add(beam_box);
  }
  prepareWindow(box.min, box.max);
  slots_.clear();
  sparse_.clear();

  // A voxel's centre is at most half its diagonal from any point inside it.
  const double half_diagonal = 0.5 * std::sqrt(3.0) * tree_->getResolution();
  const double half_diagonal_sq = half_diagonal * half_diagonal;
  for (std::size_t b = 0; b < beams.size(); ++b) {
    if (!usable[b]) continue;
    const Beam& beam = beams[b];
    // On the axis, closer than this the model is exactly the free valley (see hitUpdate).
    const double pure_free_until = beam.length - model_.pureFreeMargin(beam.length);
    const float l_free = model_.logOddsFree();
    auto visit = [&](const octomap::OcTreeKey& key) __attribute__((always_inline)) {
      const octomap::point3d c = tree_->keyToCoord(key);
      const Eigen::Vector3d v(c.x() - origin.x(), c.y() - origin.y(), c.z() - origin.z());
      const double along = std::max(0.0, v.dot(beam.direction));
      const double lateral_sq = (v - along * beam.direction).squaredNorm();
      // Voxels the axis passes through (most of them) are squarely inside the cone.
      const bool on_axis = lateral_sq <= half_diagonal_sq || along <= 0.0;
      if (on_axis && along < pure_free_until) {
        accumulate(key, l_free);
        return;
      }
      const double off_axis = on_axis ? 0.0 : std::atan((std::sqrt(lateral_sq) - half_diagonal) / along);
      const float value = beam.hit ? model_.hitUpdate(beam.length, along, off_axis, half_angle)
                                   : model_.noReturnUpdate(beam.length, along, off_axis, half_angle);
      if (value != 0.0f) accumulate(key, value);
    };
    fanOf(beam, tan_half, &fan);
    for (const Eigen::Vector3d& dir : fan) {
      const Eigen::Vector3d far = origin + dir * traceLength(beam);
      octomap::OcTreeKey far_key;
      if (!coordToKeySafe(*tree_, far.x(), far.y(), far.z(), &far_key)) continue;  // checked in the first pass
      traverseVoxels(*tree_, origin, far, origin_key, far_key, visit);
    }
  }

  updates.reserve(slots_.size());
  for (const Slot& slot : slots_) {
    const float value = slot.positive > 0.0f ? slot.positive : slot.negative;
    if (value != 0.0f) updates.push_back({slot.key, value});
    if (inWindow(slot.key)) window_[windowIndex(slot.key)] = -1;
  }
  return updates;
}

InsertResult ScanInserter::apply(std::vector<KeyUpdate> updates, InsertResult result) {
  result.updated_keys.reserve(updates.size());
  for (const KeyUpdate& u : updates) {
    result.touched.add(u.key);
    result.updated_keys.push_back(u.key);
  }
  applyUpdatesInTreeOrder(tree_, &updates);
  result.voxels_updated = updates.size();
  return result;
}

}  // namespace octo_slice_mapper
