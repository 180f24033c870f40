// Inserts scans into an OctoMap log-odds octree with the inverse sensor model.
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "octo_slice_mapper/inverse_sensor_model.h"
#include "octo_slice_mapper/internal/floor_layer.h"
#include "octo_slice_mapper/internal/key_box.h"
#include "octo_slice_mapper/internal/layer_cache.h"
#include "octo_slice_mapper/internal/octree_batch_update.h"
#include "octo_slice_mapper/scan.h"
#include "octo_slice_mapper/internal/scan_evidence.h"

namespace octo_slice_mapper {

struct InsertOptions {
  InverseSensorModelOptions model;
  ReadingPolicy readings;
  // Returns farther than this (m) are cut: space up to max_range is cleared, nothing marked
  // occupied. 0 = use only the sensor's own range_max. Far returns are placed with the pose's
  // heading error times their range (0.5 deg: 26 cm at 30 m), so they mark and clear the wrong
  // cells; 30 m kept every shared log's incremental map ahead of octomap_server's rule.
  double max_range = 30.0;
  // How the beams of one scan combine per voxel (see ScanEvidence).
  EvidenceCombining combining = EvidenceCombining::kSum;

  // Point clouds (a depth camera).
  // One ray per voxel that returns end in, aimed at their mean point (as OctoMap's discretize
  // mode: one ray per end voxel), instead of one per point: a 640 x 480 frame has 300 000 points
  // but a few thousand end voxels. false: one ray per point.
  bool cloud_one_ray_per_voxel = true;
  // Returns farther than this are cut like max_range's: cleared up to it, nothing marked
  // (0 = max_range). A depth camera's far depth is noisy (Kinect: 4 cm at 4.5 m).
  double cloud_max_range = 0.0;
  // Only returns within this band of heights above the floor under them (m; the floor found,
  // see floor_layer.h, else the fixed frame's z = 0) mark a voxel occupied; those outside (the
  // floor, the ceiling) clear up to themselves and mark nothing, so the floor stays out of the
  // slice and a person walking away leaves no trail.
  double cloud_mark_min_z = 0.05;
  double cloud_mark_max_z = 1e9;
  // A depth camera's noise along the ray at range r: sigma = base + quadratic (r - near)^2 (m),
  // a Kinect v1's axial noise (Nguyen, Izadi, Lovell 2012; measured on depth, taken here on the
  // range, which is no shorter). A return marks only when it stands more than
  // cloud_mark_sigmas sigmas above the floor as well: a far floor return's noise (5 cm at 4 m)
  // would cross cloud_mark_min_z, while a 5 cm step 1.5 m away (sigma 3.5 mm) still marks.
  double cloud_noise_base = 0.0012;
  double cloud_noise_quadratic = 0.0019;
  double cloud_noise_near = 0.4;
  double cloud_mark_sigmas = 3.0;
  // An organized frame's flying pixels are left out where the points are made (DeferredCloud).
  FlyingPixelOptions cloud_flying_pixels;
  // How a cloud's rays combine per voxel. Occupied wins (as octomap_server's insertScan): a
  // frame's rays graze the surfaces they end beside, and summed, the free evidence of hundreds of
  // them erased a table top's underside seen from below (cloud_insertion_test). With kSum each
  // end-voxel ray counts as many rays as points end in its voxel.
  EvidenceCombining cloud_combining = EvidenceCombining::kOccupiedWins;
  // Free space that a frame's rays share is walked about once (kOccupiedWins only; 0 = off): each
  // ray is walked from its end back towards the sensor, and in its free valley it stops after this
  // many voxels in a row that earlier rays of the frame already gave the whole free valley. Near
  // the sensor a frame's rays cross each voxel dozens of times. An approximation: a voxel that only
  // the rest of a stopped ray would have reached misses this frame's update (bench_cloud_insertion
  // prints how many; with 16, a fraction of a percent of the voxels, none of the occupied).
  int cloud_shared_free_run = 16;
};

struct InsertResult {
  ReadingCounts readings;          // per-reason reading counts of this scan
  std::uint64_t voxels_updated = 0;
  // Beams whose end lies beyond what the octree holds (a reading of 3e38 m, a cloud point at
  // 1e30): dropped whole, nothing traced (their reading is still counted by its kind).
  std::uint64_t beams_outside_octree = 0;
  // The keys whose log-odds changed (some of the general path's may not have), and their bounding
  // box: what the slice and the published map update must follow. A voxel updated without a
  // change (at its clamping bound) was known before, so its column is in the slice already.
  std::vector<octomap::OcTreeKey> updated_keys;
  // Each updated key's values before and after, where the insertion knew them (a scan through the
  // layer cache); else empty. The slice then follows most changes without reading their columns.
  std::vector<VoxelChange> changes;
  KeyBox touched;
  std::string error;               // non-empty: the whole scan was rejected, map untouched
  bool ok() const { return error.empty(); }
};

// The floor a depth frame's returns are measured against, asked for with the sensor's position
// and a sample of the frame's returns (map frame), with each sample's octree column (key x | key
// y << 16) where the caller knows it (null: from the samples' x and y). Called once per frame, in
// the frames' order where that matters (FloorLayer::observe).
using FloorStage = std::function<FloorView(const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples,
                                           const std::vector<std::uint32_t>* cells)>;

// A cloud's per-voxel updates, worked out before they are applied (ScanInserter::prepareCloud).
struct PreparedCloud {
  InsertResult result;             // its readings counted; error set: refused, nothing to apply
  std::vector<KeyUpdate> updates;  // combined per voxel, in tree order (sortInTreeOrder)
  std::optional<std::uint64_t> floor_frame;  // its number at the floor layer (FloorLayer::take)
};

// One ray with its interpretation, in the map frame.
struct Beam {
  Eigen::Vector3d direction;  // unit
  double length;              // hit: measured range; no-return: clearing distance
  bool hit;                   // false = clear only
  // Unit vector across the cone in the scan plane (zero for point-cloud beams, traced on axis).
  Eigen::Vector3d across = Eigen::Vector3d::Zero();
  // How many returns the beam stands for (a cloud's ray to an end voxel: the points ending there):
  // its evidence counts that many times, as that many rays along nearly the same path would.
  float weight = 1.0f;
};

// Which voxels a beam reaches: the voxels its axis crosses (judged as on the axis), plus, where
// the cone is wider than a voxel (long ranges), those crossed by extra rays fanned across the
// cone in the scan plane, at most one voxel apart, each weighted by the model at the angle
// between the beam axis and the voxel's centre.
//
// How overlapping beams combine inside one scan: every voxel gets one update per scan, the sum
// of its beams' evidence (InsertOptions::combining; or the strongest occupied evidence, else the
// strongest free one).
class ScanInserter {
 public:
  // A scan whose rays span at most this many z layers (a level one, or one tilted by a degree or
  // two) has its updates cached (LayerCache) layer by layer; one spanning more goes into the octree.
  static constexpr unsigned kMaxCachedLayersPerScan = 16;

  ScanInserter(octomap::OcTree* tree, const InsertOptions& options);

  InsertResult insert(const Scan& scan);
  // Points from a 3D sensor: each is a return seen from `origin`; `half_angle` is the cone.
  // Non-finite points are counted (nan / inf) and skipped.
  InsertResult insertPoints(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                            double half_angle);
  // insertPoints in two steps. The first reads only the octree's key geometry (resolution,
  // depth), never its contents or the cache, so an inserter over an empty octree of the same
  // resolution gives the same result: a frame can be prepared away from the map (and its lock)
  // while scans go on; applyCloud() then puts the updates into this inserter's map.
  // `floor`, when given, is asked once per frame for the floor its returns stand on, with the
  // frame's sample of returns (its end-voxel means); without it the floor is the fixed frame's z = 0.
  PreparedCloud prepareCloud(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                             double half_angle, const FloorStage& floor = {});
  InsertResult applyCloud(PreparedCloud prepared);

  const InverseSensorModel& model() const { return model_; }
  const InsertOptions& options() const { return options_; }
  // Threads that group a cloud's points by end voxel (0: one per core). A preparer on one of a
  // pipeline's workers takes 1: the other workers keep the cores busy with other frames.
  void setGroupingThreads(unsigned threads) { grouping_threads_ = threads; }

  // Scans update a write-back cache of the octree's layers (see LayerCache): the octree itself is
  // up to date only after flush(). What the cache does around other changes of the octree (a
  // loan to a reader, a load, the global pass's result) is its owner's policy (Mapper), through
  // cache(): LayerCache::holdEverything, clear, forget.
  void flush() { cache_.flush(); }
  LayerCache& cache() { return cache_; }
  const LayerCache& cache() const { return cache_; }
  // What the inserter holds besides the octree: the layer cache and the per-scan evidence window.
  std::size_t memoryBytes() const { return cache_.memoryBytes() + evidence_.memoryBytes(); }

 private:
  // The fast path's intermediate results are read through ScanInserterInspection (tests,
  // benchmarks, reference implementations), not by the mapper's callers.
  friend class ScanInserterInspection;

  // A cloud's beams (InsertOptions' cloud_* rules), in a deterministic order.
  std::vector<Beam> cloudBeams(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                               ReadingCounts* counts, const FloorStage& floor = {}) const;
  // A scan's beams.
  std::vector<Beam> beamsOf(const Scan& scan, ReadingCounts* counts);
  // Every (voxel, evidence) pair the model gives, each beam's once per voxel, before the beams
  // are combined per voxel; with `shortcuts`, as the fast path traces.
  void traceEvidence(const Scan& scan, const std::function<void(const octomap::OcTreeKey&, float)>& fn,
                     bool shortcuts);
  void traceEvidence(const Eigen::Vector3d& origin, const std::vector<Beam>& beams, double half_angle,
                     const std::function<void(const octomap::OcTreeKey&, float)>& fn, bool shortcuts);
  // Per-voxel log-odds updates of beams before they are applied, in traversal order, or with
  // `in_tree_order` in the octree's (sortInTreeOrder's).
  // `shared_free_run` > 0: a cloud's rays stop in free space earlier rays gave (cloud_shared_free_run).
  std::vector<KeyUpdate> computeUpdates(const Eigen::Vector3d& origin, const std::vector<Beam>& beams,
                                        double half_angle, int shared_free_run = 0, bool in_tree_order = false);

  // `in_tree_order`: the updates are sorted already (sortInTreeOrder).
  InsertResult apply(std::vector<KeyUpdate> updates, InsertResult result, bool in_tree_order = false);
  InsertResult insertIntoLayers(const Eigen::Vector3d& origin, const std::vector<Beam>& beams, double half_angle,
                                InsertResult result);
  KeyBox prepareBeams(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key,
                      const std::vector<Beam>& beams, double tan_half);
  // A scan's combined updates through a hash map, for a box too large for the evidence window.
  std::vector<KeyUpdate> sparseUpdates(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key,
                                       const std::vector<Beam>& beams, double half_angle);
  void traceIntoWindow(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key,
                       const std::vector<Beam>& beams, double half_angle, int shared_free_run = 0);
  // Which walks an instantiation of traceBeams holds. Each walk's loop is best compiled alone:
  // compiled beside a cloud's backward walk, the forward walk keeps less in registers and runs
  // more instructions per voxel.
  enum class Walks {
    kAll,    // rays walked backwards for a frame's shared free space, or forwards
    kSpace,  // rays walked forwards
  };
  // With `shortcuts`, voxels that are surely in a beam's free valley get l_free without the
  // model being evaluated; without, every voxel is judged (the reference for tests).
  template <Walks kWalks = Walks::kAll, typename Cells, typename Sink>
  void traceBeams(const Eigen::Vector3d& origin, const octomap::OcTreeKey& origin_key, const std::vector<Beam>& beams,
                  double half_angle, const Cells& cells, Sink&& sink, bool shortcuts, int shared_free_run = 0);
  template <typename Sink>
  static void handOnOncePerVoxel(std::vector<KeyUpdate>* evidence, Sink&& sink);
  double traceLength(const Beam& beam) const;
  struct Ray {
    Eigen::Vector3d direction;
    double start;  // distance from the origin where it starts
    bool axis;
    octomap::OcTreeKey far_key;  // of its end, where the beam's trace ends
  };
  // `half_diagonal`: half a voxel's diagonal, as traceBeams has it.
  static void freeStretch(const Ray& ray, const Eigen::Vector3d& axis, double pure_free_until,
                          double off_axis_free_until, double tan_full, double half_diagonal, double* s_lo,
                          double* s_hi);
  // Appends the beam's rays, traced to `length` (traceLength), to `rays`.
  void fanOf(const Beam& beam, double length, double tan_half, std::vector<Ray>* rays) const;

  octomap::OcTree* tree_;
  InsertOptions options_;
  InverseSensorModel model_;

  ScanEvidence evidence_;               // the current scan's combined evidence
  std::vector<Ray> rays_;               // the current scan's rays (prepareBeams)
  std::vector<std::size_t> ray_begin_;  // beam b's are rays_[ray_begin_[b], ray_begin_[b + 1])
  std::vector<double> trace_length_;    // beam b's traceLength, worked out once (prepareBeams)
  std::size_t max_visits_ = 0;          // bounds how many voxels the rays visit
  std::uint64_t beams_outside_ = 0;     // the current scan's beams ending outside the octree
  std::vector<KeyUpdate> beam_evidence_;  // a fanned beam's evidence before it is combined
  // A cloud ray walked backwards does not ask the model for a voxel that holds the free valley
  // already where no evidence above zero can come (traceBeams); off only to check that it changes nothing.
  bool skip_settled_voxels_ = true;
  unsigned grouping_threads_ = 0;
  std::optional<InverseSensorModel::ConeTable> cone_;  // for the last half-angle seen
  BeamDirections directions_;  // for the last scan geometry seen

  LayerCache cache_;
};

}  // namespace octo_slice_mapper
