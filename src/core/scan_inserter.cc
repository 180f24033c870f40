#include "octo_slice_mapper/internal/scan_inserter.h"

#include "core/internal/end_voxel_grouping.h"
#include "core/internal/voxel_traversal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <unordered_map>

namespace octo_slice_mapper {
ScanInserter::ScanInserter(octomap::OcTree* tree, const InsertOptions& options)
    : tree_(tree),
      options_(options),
      model_(options.model, tree->getResolution()),
      evidence_(options.combining),
      cache_(tree) {}

namespace {

// How far a return at `end`, `range` from the sensor, is traced: whole up to `max_range`, cut there
// beyond it (seen free up to it). A return the octree cannot hold is broken, not far: it keeps its
// length, so that it is dropped whole and counted (beams_outside_octree) instead of clearing.
double tracedLength(const octomap::OcTree& tree, const Eigen::Vector3d& end, double range, double max_range) {
  if (range <= max_range) return range;
  octomap::OcTreeKey key;
  return coordToKeySafe(tree, end.x(), end.y(), end.z(), &key) ? max_range : range;
}

}  // namespace

std::vector<Beam> ScanInserter::beamsOf(const Scan& scan, ReadingCounts* counts) {
  std::vector<Beam> beams;
  beams.reserve(scan.ranges.size());
  const Eigen::Matrix3d rotation = scan.sensor_pose.linear();
  const double clear = std::min<double>(options_.model.no_return_clear_distance, scan.range_max);
  const double max_range = options_.max_range > 0.0 ? options_.max_range : 1e30;
  const std::vector<Eigen::Vector2d>& unit = directions_.of(scan);
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const float r = scan.ranges[i];
    const ReadingKind kind = classifyReading(r, scan.range_min, scan.range_max, options_.readings);
    if (counts) (*counts)[kind]++;
    const double c = unit[i].x(), s = unit[i].y();
    const Eigen::Vector3d dir = rotation * Eigen::Vector3d(c, s, 0.0);
    const Eigen::Vector3d across = rotation * Eigen::Vector3d(-s, c, 0.0);
    if (kind == ReadingKind::kHit) {
      if (r > max_range) {
        const Eigen::Vector3d end = scan.sensor_pose.translation() + dir * static_cast<double>(r);
        beams.push_back({dir, tracedLength(*tree_, end, r, max_range), false, across});
      } else {
        beams.push_back({dir, r, true, across});
      }
    } else if (kind == ReadingKind::kNoReturn && clear > 0.0) {
      beams.push_back({dir, std::min(clear, max_range), false, across});
    }
  }
  return beams;
}

namespace {

// Empty, or why the octree cannot hold a sensor at `origin` (a CARMEN pose of 1e30): such a scan is
// refused, not counted as inserted with nothing inserted.
std::string originError(const octomap::OcTree& tree, const Eigen::Vector3d& origin) {
  octomap::OcTreeKey key;
  if (!origin.allFinite()) return "sensor origin is not finite";
  if (coordToKeySafe(tree, origin.x(), origin.y(), origin.z(), &key)) return "";
  const double reach = tree.getResolution() * double(1 << (tree.getTreeDepth() - 1));
  char text[160];
  std::snprintf(text, sizeof text, "sensor origin (%.6g, %.6g, %.6g) is outside what the octree holds (+-%.0f m)",
                origin.x(), origin.y(), origin.z(), reach);
  return text;
}

}  // namespace

InsertResult ScanInserter::insert(const Scan& scan) {
  InsertResult result;
  result.error = validateScanHeader(scan);
  if (result.ok()) result.error = originError(*tree_, scan.sensor_pose.translation());
  if (!result.ok()) return result;
  const std::vector<Beam> beams = beamsOf(scan, &result.readings);
  const double half_angle = model_.halfAngleFor(scan.angle_increment);
  return insertIntoLayers(scan.sensor_pose.translation(), beams, half_angle, result);
}

InsertResult ScanInserter::insertPoints(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                                        double half_angle) {
  return applyCloud(prepareCloud(origin, points, half_angle));
}

PreparedCloud ScanInserter::prepareCloud(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                                         double half_angle, const FloorStage& floor) {
  PreparedCloud prepared;
  prepared.result.error = originError(*tree_, origin);
  if (!prepared.result.ok()) return prepared;
  const std::vector<Beam> beams = cloudBeams(origin, points, &prepared.result.readings, floor);
  evidence_.setCombining(options_.cloud_combining);
  // Summed evidence counts every ray: none may stop early.
  const int shared_free_run =
      options_.cloud_combining == EvidenceCombining::kOccupiedWins ? std::max(0, options_.cloud_shared_free_run) : 0;
  // In tree order here, not when applied: a pipeline prepares frames in parallel but applies them
  // one at a time, under the map's lock (the sort was a quarter of a room frame's applying).
  prepared.updates = computeUpdates(origin, beams, half_angle, shared_free_run, /*in_tree_order=*/true);
  prepared.result.beams_outside_octree = beams_outside_;
  evidence_.setCombining(options_.combining);
  return prepared;
}

InsertResult ScanInserter::applyCloud(PreparedCloud prepared) {
  if (!prepared.result.ok()) return prepared.result;
  return apply(std::move(prepared.updates), std::move(prepared.result), /*in_tree_order=*/true);
}

std::vector<Beam> ScanInserter::cloudBeams(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                                           ReadingCounts* counts, const FloorStage& floor) const {
  ReadingCounts ignored;
  ReadingCounts& c = counts ? *counts : ignored;
  const double max_range = options_.cloud_max_range > 0.0 ? options_.cloud_max_range
                           : options_.max_range > 0.0     ? options_.max_range
                                                          : 1e30;
  std::vector<Beam> beams;
  // The beam to a return at `p`, standing for `n` points: summed, it counts n times; where
  // occupied wins, once (as each of the n rays would).
  const bool summed = options_.cloud_combining == EvidenceCombining::kSum;
  FloorView ground;  // the fixed frame's z = 0 until asked
  // `cell`: the keys of p's octree column (key x | key y << 16), where known.
  const auto beamTo = [&](const Eigen::Vector3d& p, std::uint64_t n, std::optional<std::uint32_t> cell) {
    const Eigen::Vector3d v = p - origin;
    const double r = v.norm();
    if (r < 1e-6) {
      c[ReadingKind::kBelowMin] += n;
      return;
    }
    c[ReadingKind::kHit] += n;
    const double floor_height = cell ? ground.heightAtKeys(int(*cell & 0xffff), int(*cell >> 16), p.x(), p.y())
                                     : ground.heightAt(p.x(), p.y());
    const double height = p.z() - floor_height;
    const double near = std::max(0.0, r - options_.cloud_noise_near);
    const double sigma = options_.cloud_noise_base + options_.cloud_noise_quadratic * near * near;
    const bool marks = r <= max_range && height >= options_.cloud_mark_min_z &&
                       height > options_.cloud_mark_sigmas * sigma && height <= options_.cloud_mark_max_z;
    beams.push_back({v / r, tracedLength(*tree_, p, r, max_range), marks, Eigen::Vector3d::Zero(),
                     summed ? static_cast<float>(n) : 1.0f});
  };
  if (!options_.cloud_one_ray_per_voxel) {
    if (floor) {  // every 16th point: a sample as dense as a frame's end voxels
      std::vector<Eigen::Vector3d> samples;
      for (std::size_t i = 0; i < points.size(); i += 16) {
        if (points[i].allFinite()) samples.push_back(points[i].cast<double>());
      }
      ground = floor(origin, samples, nullptr);
    }
    beams.reserve(points.size());
    for (const Eigen::Vector3f& p : points) {
      if (p.allFinite()) beamTo(p.cast<double>(), 1, std::nullopt);
      else c[nonFiniteKind(p)]++;
    }
    return beams;
  }
  const EndVoxels grouped =
      groupByEndVoxel(points, tree_->getResolution(), tree_->getTreeDepth(), grouping_threads_,
                      origin.cast<float>());
  c += grouped.non_finite;
  // Each voxel's mean, and its column: the floor is kept per octree column, and the grouping
  // already has the keys.
  std::vector<Eigen::Vector3d> means;
  std::vector<std::uint32_t> cells;
  means.reserve(grouped.voxels.size());
  cells.reserve(grouped.voxels.size());
  for (const EndVoxel& g : grouped.voxels) {
    means.push_back(meanInVoxel(g, tree_->getResolution(), tree_->getTreeDepth()));
    cells.push_back(static_cast<std::uint32_t>(g.key));  // key x | key y << 16
  }
  if (floor) ground = floor(origin, means, &cells);
  for (const Eigen::Vector3d& q : grouped.outside) beamTo(q, 1, std::nullopt);  // its own beam (dropped where it leaves)
  beams.reserve(beams.size() + grouped.voxels.size());
  for (std::size_t i = 0; i < means.size(); ++i) beamTo(means[i], grouped.voxels[i].n, cells[i]);
  return beams;
}

double ScanInserter::traceLength(const Beam& beam) const {
  return beam.hit ? beam.length + model_.traceMargin(beam.length) : beam.length;
}

// The rays traced for one beam: its axis and, where the cone is wider than a voxel, rays fanned
// across the cone in the scan plane, at most one voxel apart at the far end. A fanned ray starts
// where it is half a voxel off the axis: closer in, the axis' voxels cover the cone.
void ScanInserter::fanOf(const Beam& beam, double length, double tan_half, std::vector<Ray>* rays) const {
  const double resolution = tree_->getResolution();
  const double half_width = length * tan_half;
  // Bounded: an absurd reading (3e38 m under range_max = FLT_MAX) must not overflow the count;
  // such a beam leaves the tree and is dropped anyway.
  constexpr double kMaxFan = 4096.0;
  const double cells = half_width / resolution;
  const int fan = (beam.across.isZero() || half_width <= resolution) ? 0
                  : static_cast<int>(cells < kMaxFan ? std::ceil(cells) : kMaxFan);
  for (int k = -fan; k <= fan; ++k) {
    const double t = fan ? tan_half * k / fan : 0.0;
    const double start = k == 0 ? 0.0 : 0.5 * resolution * std::sqrt(1.0 + t * t) / std::abs(t);
    // far_key is set by the caller.
    rays->push_back({(beam.direction + t * beam.across).normalized(), start, k == 0, octomap::OcTreeKey(0, 0, 0)});
  }
}

// First pass over a scan's beams: their trace lengths (trace_length_), their rays with the keys of
// their far ends (rays_, beam b's from ray_begin_[b] to ray_begin_[b + 1]; none for a beam that
// leaves the octree's key range), and the key box of all ray ends (rays are straight, so the box
// of the origin and the ends holds every voxel they cross).
KeyBox ScanInserter::prepareBeams(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key,
                                  const std::vector<Beam>& beams, double tan_half) {
  rays_.clear();
  ray_begin_.assign(1, 0);
  trace_length_.clear();
  max_visits_ = 0;
  beams_outside_ = 0;
  KeyBox box;
  box.add(origin_key);
  for (const Beam& beam : beams) {
    const std::size_t first = rays_.size();
    const double length = traceLength(beam);
    trace_length_.push_back(length);
    fanOf(beam, length, tan_half, &rays_);
    bool inside = true;
    // Every ray's end: the arc of ends bulges past the outer rays' chord.
    for (std::size_t r = first; r < rays_.size() && inside; ++r) {
      const Eigen::Vector3d end = origin + rays_[r].direction * length;
      inside = coordToKeySafe(*tree_, end.x(), end.y(), end.z(), &rays_[r].far_key);
    }
    if (inside) {
      // A ray starting at the origin visits its key distance + 1 voxels; a fanned ray, starting
      // between the origin and its end, no more.
      for (std::size_t r = first; r < rays_.size(); ++r) {
        box.add(rays_[r].far_key);  // only once every ray of the beam is known to be inside
        for (int d = 0; d < 3; ++d) max_visits_ += std::abs(int(rays_[r].far_key[d]) - int(origin_key[d]));
        max_visits_ += 1;
      }
    } else {
      rays_.resize(first);
      ++beams_outside_;
    }
    ray_begin_.push_back(rays_.size());
  }
  return box;
}

// Where along `ray` (distances from the origin, in (s_lo, s_hi)) every voxel the ray leaves is
// in the beam's free valley with full weight, so that judging it would give exactly l_free: the
// voxel's centre c is within half_diagonal (h) of p, the point where the ray leaves it, at
// distance s from the origin and angle a off the axis. Then c lies at most s + h along the axis,
// at most s sin(a) + h off it, and at least s cos(a) - h along:
//  - the axis' own voxels are judged as on the axis: s + h < pure_free_until suffices;
//  - off it, s sin(a) + h < tan_full (s cos(a) - h) puts the centre inside the full-weight part
//    of the cone, and s + h < off_axis_free_until before the end of the free valley there.
// (1e-6 m of slack covers rounding in the walk's exit distances.)
void ScanInserter::freeStretch(const Ray& ray, const Eigen::Vector3d& axis, double pure_free_until,
                               double off_axis_free_until, double tan_full, double half_diagonal, double* s_lo,
                               double* s_hi) {
  constexpr double kSlack = 1e-6;
  const double h = half_diagonal + kSlack;
  if (ray.axis) {
    *s_lo = -1.0;
    *s_hi = pure_free_until - h;
    return;
  }
  const double cos_a = std::min(1.0, ray.direction.dot(axis));
  const double sin_a = std::sqrt(std::max(0.0, 1.0 - cos_a * cos_a));
  const double g = tan_full * cos_a - sin_a;  // s * g > (1 + tan_full) * h: inside the full-weight part
  if (!(g > 0.0)) return;                     // never: the ray runs in the cone's taper
  *s_lo = (1.0 + tan_full) * h / g + kSlack;
  *s_hi = off_axis_free_until - h;
}

namespace {

// The inverse model's evidence for the voxels of one beam's cone, from where a voxel's centre
// lies: `along` the axis and sqrt(lateral_sq) off it. The per-beam constants are worked out once.
class BeamEvidence {
 public:
  BeamEvidence(const InverseSensorModel& model, const InverseSensorModel::ConeTable& cone, const Beam& beam,
               double half_angle, double tan_full, double resolution)
      : model_(model),
        cone_(cone),
        beam_(beam),
        tan_half_(cone.tanHalf()),
        tan_full_(tan_full),
        l_free_(model.logOddsFree()),
        // On the axis, closer than this the model is exactly the free valley (see hitUpdate).
        pure_free_until_(beam.length - model.pureFreeMargin(beam.length)),
        // Off the axis, where the weight is still 1, the free valley ends sooner (sigma widens).
        off_axis_free_until_(beam.length +
                             InverseSensorModel::kPureFreeBelow * model.sigmaAt(beam.length, half_angle, half_angle)),
        axis_(model.axisProfile(beam.length, cone, beam.hit ? 1.0 : -1.0)) {
    // One return is one obstacle somewhere across the cone: a voxel off the axis holds its width's
    // share of a cross-section wider than a voxel (the axis' voxels hold the most likely part).
    const double cross_section = 2.0 * beam.length * tan_half_;
    off_axis_share_ = cross_section > resolution ? resolution / cross_section : 1.0;
  }
  double pureFreeUntil() const { return pure_free_until_; }
  double offAxisFreeUntil() const { return off_axis_free_until_; }

  // The evidence (0: none, outside the cone). `axis_ray`: the voxel is one the beam's axis crosses.
  __attribute__((always_inline)) float at(double along, double lateral_sq, bool axis_ray) const {
    along = std::max(0.0, along);
    // The voxels the axis passes through are judged on the axis; the others by the angle of
    // their centre (judging them by their part nearest the axis, a beam grazing a wall cleared
    // wall voxels it never entered).
    const bool on_axis = axis_ray || along <= 0.0;
    if (on_axis) return along < pure_free_until_ ? l_free_ : model_.onAxis(axis_, along);
    // tan of the angle between the axis and the voxel's centre; the model only when the voxel is
    // in the cone's taper or near the return.
    // (Compared as products: a division only for the voxels that need the model.)
    const double reach = std::sqrt(lateral_sq);
    if (reach >= tan_half_ * along) return 0.0f;  // outside the cone
    if (reach <= tan_full_ * along && along < off_axis_free_until_) return l_free_;
    const double q = reach / (along * tan_half_);  // tan(angle off the axis) / tan(half-angle)
    return beam_.hit ? model_.hitUpdateInCone(beam_.length, along, q, cone_, off_axis_share_)
                     : model_.noReturnUpdateInCone(beam_.length, along, q, cone_);
  }

 private:
  const InverseSensorModel& model_;
  const InverseSensorModel::ConeTable& cone_;
  const Beam& beam_;
  double tan_half_, tan_full_;
  float l_free_;
  double pure_free_until_, off_axis_free_until_, off_axis_share_ = 1.0;
  InverseSensorModel::AxisProfile axis_;  // the model along the axis, for this beam
};

// Voxel centres relative to a sensor origin, as OcTree::keyToCoord gives them, with the tree's
// constants in registers (through the tree they are reloaded per voxel).
class VoxelCentres {
 public:
  VoxelCentres(const octomap::OcTree& tree, const Eigen::Vector3d& origin)
      : resolution_(tree.getResolution()),
        center_(1 << (tree.getTreeDepth() - 1)),  // the key of coordinate 0 (OctoMap's tree_max_val)
        origin_(origin) {}

  // Along `direction` and the squared distance off it (from its nearest point ahead of the origin).
  // The centre in double, as keyToCoord(key_type) has it: not rounded through float as
  // keyToCoord(OcTreeKey) does, which GCC 12.2 at -O2 vectorizes for x and y together, dropping
  // their rounding but keeping z's.
  __attribute__((always_inline)) void place(const octomap::OcTreeKey& key, const Eigen::Vector3d& direction,
                                            double* along, double* lateral_sq) const {
    const Eigen::Vector3d v(coord(key[0]) - origin_.x(), coord(key[1]) - origin_.y(), coord(key[2]) - origin_.z());
    *along = v.dot(direction);
    *lateral_sq = (v - std::max(0.0, *along) * direction).squaredNorm();
  }

 private:
  double coord(octomap::key_type k) const { return (double(int(k) - center_) + 0.5) * resolution_; }
  double resolution_;
  int center_;
  Eigen::Vector3d origin_;
};

}  // namespace

// Second pass: every voxel each beam kept by prepareBeams reaches, with the model's evidence for it, handed to
// `sink(index, value)` with the voxel's index in `cells` (PackedKeys or the evidence window; zero
// evidence is not handed on).
// Not inlined: each instantiation a function of its own (see Walks).
template <ScanInserter::Walks kWalks, typename Cells, typename Sink>
__attribute__((noinline)) void ScanInserter::traceBeams(const Eigen::Vector3d& origin,
                                                        const octomap::OcTreeKey& origin_key,
                                                        const std::vector<Beam>& beams, double half_angle,
                                                        const Cells& cells, Sink&& sink, bool shortcuts,
                                                        int shared_free_run) {
  using Index = typename Cells::Index;
  if (!cone_ || cone_->halfAngle() != half_angle) cone_.emplace(model_, half_angle);
  const double tan_full = std::tan(model_.fullWeightAngle(half_angle));
  // A voxel's centre is at most half its diagonal from any point inside it.
  const double half_diagonal = 0.5 * std::sqrt(3.0) * tree_->getResolution();
  const float l_free = model_.logOddsFree();
  const VoxelCentres centres(*tree_, origin);
  for (std::size_t b = 0; b < beams.size(); ++b) {
    if (ray_begin_[b] == ray_begin_[b + 1]) continue;  // left the octree
    const Beam& beam = beams[b];
    const BeamEvidence evidence(model_, *cone_, beam, half_angle, tan_full, tree_->getResolution());
    // A beam's fanned rays cross some voxels of the axis and of each other: its evidence is
    // gathered first, so that each voxel gets the beam's evidence once (the strongest occupied,
    // else the strongest free) however many of its rays cross it.
    const bool fanned = ray_begin_[b + 1] - ray_begin_[b] > 1;
    beam_evidence_.clear();
    const float weight = beam.weight;  // 1 but for a cloud's end-voxel rays (x * 1.0f is x)
    // Evidence already multiplied by the beam's weight.
    auto emit = [&](Index index, float weighted) __attribute__((always_inline)) {
      if (fanned) {
        beam_evidence_.push_back({cells.keyOf(index), weighted});
      } else {
        sink(index, weighted);
      }
    };
    // The free valley's value, weighted once per beam rather than per voxel (the same product).
    const float weighted_free = l_free * weight;
    bool axis_ray = false;  // whether the ray being walked is the beam's axis
    // Per voxel of a ray: voxels the ray leaves at a fraction t_exit in (t_lo, t_hi) of its length
    // are the free valley without the model; the others are placed by `place` and judged.
    auto visitor = [&](double t_lo, double t_hi, const auto& place) {
      return [&, place, t_lo, t_hi](Index index, double t_exit) __attribute__((always_inline)) {
        if (t_exit > t_lo && t_exit < t_hi) {
          emit(index, weighted_free);
          return;
        }
        double along, lateral_sq;
        place(cells.keyOf(index), &along, &lateral_sq);
        const float value = evidence.at(along, lateral_sq, axis_ray);
        if (value != 0.0f) emit(index, value * weight);
      };
    };
    const auto in_3d = [&](const octomap::OcTreeKey& k, double* along, double* lateral_sq) __attribute__((
                           always_inline)) { centres.place(k, beam.direction, along, lateral_sq); };
    const double length = trace_length_[b];
    for (std::size_t r = ray_begin_[b]; r < ray_begin_[b + 1]; ++r) {
      const Ray& ray = rays_[r];
      axis_ray = ray.axis;
      if (ray.start >= length) continue;
      const Eigen::Vector3d from = origin + ray.direction * ray.start;
      const Eigen::Vector3d far = origin + ray.direction * length;
      octomap::OcTreeKey from_key = origin_key;
      if (ray.start > 0.0 && !coordToKeySafe(*tree_, from.x(), from.y(), from.z(), &from_key)) continue;
      double s_lo = 0.0, s_hi = -1.0;  // the ray's stretch (distance from the origin) known free
      if (shortcuts) {
        freeStretch(ray, beam.direction, evidence.pureFreeUntil(), evidence.offAxisFreeUntil(), tan_full,
                    half_diagonal, &s_lo, &s_hi);
      }
      const double t_lo = (s_lo - ray.start) / (length - ray.start), t_hi = (s_hi - ray.start) / (length - ray.start);
      if constexpr (std::is_same_v<Cells, ScanEvidence> && kWalks == Walks::kAll) {
        if (shared_free_run > 0 && !fanned) {
          // From the end back to the sensor: the end's evidence first, then the free valley until
          // `shared_free_run` voxels in a row already hold it. Each voxel is judged as the forward
          // walk judges it: going forward, a voxel is left where the backward walk entered it.
          const std::uint32_t free_word = ScanEvidence::code(weighted_free);
          const auto judge = visitor(t_lo, t_hi, in_3d);
          // A voxel that holds the free valley already keeps it against any evidence not above
          // zero (the strongest free wins, and none is stronger: weight 1, the valley the
          // deepest): the model is not asked there. Before the return, where earlier rays of the
          // frame passed, it was asked in vain for most voxels (64 % of a room frame's calls).
          const bool free_is_strongest = skip_settled_voxels_ && weighted_free < 0.0f && weight == 1.0f;
          // Voxels whose centres lie closer than this along the axis get no evidence above zero
          // (none of a no-return beam's does); a voxel further for margin.
          const double never_occupied_until = beam.hit
                                                  ? beam.length - model_.occupiedMargin(beam.length) - tree_->getResolution()
                                                  : std::numeric_limits<double>::infinity();
          const double h = half_diagonal + 1e-6;
          double entered = 0.0;
          int run = 0;
          traverseVoxels(*tree_, far, from, ray.far_key, from_key, cells,
                         [&](Index index, double t_exit) __attribute__((always_inline)) {
                           const double forward_exit = 1.0 - entered;
                           entered = t_exit;
                           const bool free_valley = forward_exit > t_lo && forward_exit < t_hi;
                           const bool holds_free = cells.wordAt(index) == free_word;
                           if (free_valley && holds_free) return ++run < shared_free_run;
                           run = 0;
                           // The voxel's centre lies within h of where the walk leaves it.
                           if (holds_free && free_is_strongest &&
                               ray.start + forward_exit * (length - ray.start) + h < never_occupied_until) {
                             return true;
                           }
                           judge(index, forward_exit);
                           return true;
                         });
          continue;
        }
      }
      traverseVoxels(*tree_, from, far, from_key, ray.far_key, cells, visitor(t_lo, t_hi, in_3d));
    }
    if (fanned) {
      handOnOncePerVoxel(&beam_evidence_, [&](const octomap::OcTreeKey& key, float value) {
        sink(cells.indexOf(key), value);
      });
    }
  }
}

// Hands on each voxel of `evidence` once, with the strongest occupied (else free) value it has.
template <typename Sink>
void ScanInserter::handOnOncePerVoxel(std::vector<KeyUpdate>* evidence, Sink&& sink) {
  auto by_key = [](const KeyUpdate& a, const KeyUpdate& b) {
    return a.key[2] != b.key[2] ? a.key[2] < b.key[2] : a.key[1] != b.key[1] ? a.key[1] < b.key[1] : a.key[0] < b.key[0];
  };
  std::sort(evidence->begin(), evidence->end(), by_key);
  for (std::size_t i = 0; i < evidence->size();) {
    std::uint32_t word = 0;
    std::size_t j = i;
    for (; j < evidence->size() && (*evidence)[j].key == (*evidence)[i].key; ++j) {
      word = ScanEvidence::combine(EvidenceCombining::kOccupiedWins, word, (*evidence)[j].log_odds);
    }
    sink((*evidence)[i].key, ScanEvidence::value(word));
    i = j;
  }
}

std::vector<KeyUpdate> ScanInserter::computeUpdates(const Eigen::Vector3d& origin, const std::vector<Beam>& beams,
                                                    double half_angle, int shared_free_run, bool in_tree_order) {
  octomap::OcTreeKey origin_key;
  if (!coordToKeySafe(*tree_, origin.x(), origin.y(), origin.z(), &origin_key)) return {};
  const KeyBox box = prepareBeams(origin, origin_key, beams, std::tan(half_angle));
  if (!evidence_.begin(box, max_visits_)) {
    std::vector<KeyUpdate> updates = sparseUpdates(origin, origin_key, beams, half_angle);
    if (in_tree_order) sortInTreeOrder(&updates);
    return updates;
  }
  std::vector<KeyUpdate> updates;
  traceIntoWindow(origin, origin_key, beams, half_angle, shared_free_run);
  // The window's bucket sort: a room frame's 36 000 updates in a fraction of a radix sort's time.
  if (in_tree_order) evidence_.orderInTree();
  updates.reserve(evidence_.listed());
  evidence_.drain([&updates](const octomap::OcTreeKey& key, float update) { updates.push_back({key, update}); });
  return updates;
}

// The evidence of the beams prepareBeams kept, into the window begun over their box.
void ScanInserter::traceIntoWindow(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key,
                                   const std::vector<Beam>& beams, double half_angle, int shared_free_run) {
  // Each kind of input through the tracer compiled for its walks alone (Walks).
  const bool shared_free_space = evidence_.combining() == EvidenceCombining::kOccupiedWins && shared_free_run > 0;
  const Walks walks = shared_free_space ? Walks::kAll : Walks::kSpace;
  // The tracer instantiated per rule (scans sum, clouds by default keep the occupied).
  evidence_.withCombining([&](auto rule) {
    const auto sink = [this](ScanEvidence::Index index, float value)
                          __attribute__((always_inline)) { evidence_.addAtAs<decltype(rule)::value>(index, value); };
    const int run = decltype(rule)::value == EvidenceCombining::kOccupiedWins ? shared_free_run : 0;
    switch (walks) {
      case Walks::kSpace:
        traceBeams<Walks::kSpace>(origin, origin_key, beams, half_angle, evidence_, sink, /*shortcuts=*/true);
        break;
      case Walks::kAll:
        traceBeams<Walks::kAll>(origin, origin_key, beams, half_angle, evidence_, sink, /*shortcuts=*/true, run);
        break;
    }
  });
}

// The same combining as the window's, in a hash map: for a scan whose box is too large for one.
std::vector<KeyUpdate> ScanInserter::sparseUpdates(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key,
                                                   const std::vector<Beam>& beams, double half_angle) {
  std::unordered_map<octomap::OcTreeKey, std::uint32_t, octomap::OcTreeKey::KeyHash> sparse;
  const EvidenceCombining combining = evidence_.combining();  // a scan's or a cloud's
  traceBeams(
      origin, origin_key, beams, half_angle, PackedKeys{},
      [&sparse, combining](PackedKeys::Index index, float value) {
        std::uint32_t& word = sparse[PackedKeys::keyOf(index)];
        word = ScanEvidence::combine(combining, word, value);
      },
      /*shortcuts=*/true);
  std::vector<KeyUpdate> updates;
  for (const auto& [key, word] : sparse) {
    const float value = ScanEvidence::decode(combining, word);
    if (value != 0.0f) updates.push_back({key, value});
  }
  return updates;
}

void ScanInserter::traceEvidence(const Scan& scan, const std::function<void(const octomap::OcTreeKey&, float)>& fn,
                                 bool shortcuts) {
  if (!validateScanHeader(scan).empty()) return;
  const std::vector<Beam> beams = beamsOf(scan, nullptr);
  const Eigen::Vector3d origin = scan.sensor_pose.translation();
  octomap::OcTreeKey origin_key;
  if (!coordToKeySafe(*tree_, origin.x(), origin.y(), origin.z(), &origin_key)) return;
  traceEvidence(origin, beams, model_.halfAngleFor(scan.angle_increment), fn, shortcuts);
}

void ScanInserter::traceEvidence(const Eigen::Vector3d& origin, const std::vector<Beam>& beams, double half_angle,
                                 const std::function<void(const octomap::OcTreeKey&, float)>& fn, bool shortcuts) {
  octomap::OcTreeKey origin_key;
  if (!coordToKeySafe(*tree_, origin.x(), origin.y(), origin.z(), &origin_key)) return;
  prepareBeams(origin, origin_key, beams, std::tan(half_angle));
  traceBeams(
      origin, origin_key, beams, half_angle, PackedKeys{},
      [&fn](PackedKeys::Index index, float value) { fn(PackedKeys::keyOf(index), value); }, shortcuts);
}

// A scan's rays reach few voxel layers: a level scan (the sensor's x-y plane horizontal) only
// its origin's, one tilted by a degree or two (real odometry's pitch and roll) a few.
// Then its combined evidence goes straight into the layer cache, layer by layer, as fast for a
// tilted scan as for a level one; a scan reaching more layers goes into the octree.
InsertResult ScanInserter::insertIntoLayers(const Eigen::Vector3d& origin, const std::vector<Beam>& beams,
                                            double half_angle, InsertResult result) {
  octomap::OcTreeKey origin_key;
  if (!coordToKeySafe(*tree_, origin.x(), origin.y(), origin.z(), &origin_key)) return result;
  const KeyBox box = prepareBeams(origin, origin_key, beams, std::tan(half_angle));
  result.beams_outside_octree = beams_outside_;
  if (!evidence_.begin(box, max_visits_)) {
    return apply(sparseUpdates(origin, origin_key, beams, half_angle), result);  // too large a box
  }
  traceIntoWindow(origin, origin_key, beams, half_angle);
  const unsigned z0 = box.empty() ? origin_key[2] : box.min[2], z1 = box.empty() ? origin_key[2] : box.max[2];
  if (z1 - z0 + 1 > kMaxCachedLayersPerScan) {
    std::vector<KeyUpdate> updates;
    evidence_.drain([&updates](const octomap::OcTreeKey& key, float update) { updates.push_back({key, update}); });
    return apply(std::move(updates), result);
  }
  LayerCache::Layer* layers[kMaxCachedLayersPerScan];
  for (unsigned z = z0; z <= z1; ++z) {
    layers[z - z0] = &cache_.layer(static_cast<std::uint16_t>(z));
    cache_.cover(layers[z - z0], box.min[0], box.min[1], box.max[0], box.max[1]);
  }
  std::size_t updates = 0;
  // A changed voxel, with its values for the slice (SliceGrid::updateColumns).
  const auto changed = [&result](const octomap::OcTreeKey& key,
                                 const VoxelChange& change) __attribute__((always_inline)) {
    result.updated_keys.push_back(key);
    result.changes.push_back(change);
  };
  if (z0 == z1) {
    // A level scan, the common case: one layer, no per-voxel layer lookup (9 % of its time).
    LayerCache::Layer& layer = *layers[0];
    evidence_.drain([&](const octomap::OcTreeKey& key, float update) __attribute__((always_inline)) {
      ++updates;
      VoxelChange change;
      if (cache_.apply(layer, key[0], key[1], update, &change)) changed(key, change);
    });
  } else {
    evidence_.drain([&](const octomap::OcTreeKey& key, float update) __attribute__((always_inline)) {
      ++updates;
      VoxelChange change;
      if (cache_.apply(*layers[key[2] - z0], key[0], key[1], update, &change)) changed(key, change);
    });
  }
  result.voxels_updated = updates;
  // The box of the changed keys only: most updates change nothing (free space seen again), and
  // bounding all of them cost 2-5 % of a scan's instructions.
  result.touched = KeyBox::of(result.updated_keys);
  return result;
}

// Updates of voxels in cached layers go through the cache (which holds their current values),
// the rest straight into the octree.
// Each changed voxel goes into the result with its change, so that the slice follows most columns
// without reading them (a depth frame's columns were read from the octree: a fifth of applying it).
InsertResult ScanInserter::apply(std::vector<KeyUpdate> updates, InsertResult result, bool in_tree_order) {
  result.voxels_updated = updates.size();
  result.updated_keys.reserve(result.updated_keys.size() + updates.size());
  result.changes.reserve(result.changes.size() + updates.size());
  if (!in_tree_order) sortInTreeOrder(&updates);
  std::vector<KeyUpdate> direct;  // in tree order, as `updates`
  direct.reserve(updates.size());
  for (const KeyUpdate& u : updates) {
    if (!cache_.holds(u.key[2])) {
      direct.push_back(u);
      continue;
    }
    VoxelChange change;
    if (!cache_.apply(u.key, u.log_odds, &change)) continue;
    result.updated_keys.push_back(u.key);
    result.changes.push_back(change);
  }
  std::vector<VoxelChange> changes;
  applySortedUpdates(tree_, direct, &changes);
  for (std::size_t i = 0; i < direct.size(); ++i) {
    const VoxelChange& c = changes[i];
    if (c.before == c.after) continue;  // at its bound already (a NaN before: new, never equal)
    result.updated_keys.push_back(direct[i].key);
    result.changes.push_back(c);
  }
  result.touched = KeyBox::of(result.updated_keys);
  return result;
}

}  // namespace octo_slice_mapper
