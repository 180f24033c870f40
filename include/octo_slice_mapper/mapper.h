// The mapping session in core terms: octree + inverse-model insertion + incremental 2D slice.
#pragma once

#include <octomap/OcTree.h>

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "octo_slice_mapper/optimized_map.h"
#include "octo_slice_mapper/internal/floor_layer.h"
#include "octo_slice_mapper/internal/scan_inserter.h"
#include "octo_slice_mapper/internal/scan_store.h"
#include "octo_slice_mapper/slice_grid.h"

namespace octo_slice_mapper {

struct MapperOptions {
  double resolution = 0.05;  // m, octree leaf size
  // OctoMap clamping bounds (probabilities): a voxel never gets surer than this, so a person who
  // walked away is cleared again (from 0.997, 13 beams through it at p_free 0.4 take it below
  // map_server's 0.65). With OctoMap's own 0.12 / 0.97 and p_free 0.35, 5 grazing beams did that
  // to any wall, so walls seen at a grazing angle flickered between occupied and free.
  double clamp_min = 0.003;
  double clamp_max = 0.997;
  InsertOptions insert;
  // The slice's band (and the clouds' marking band) are heights above the floor found under
  // each cell (floor_layer.h); with no floor found, above the fixed frame's z = 0.
  SliceOptions slice;
  FloorOptions floor;
  // The global pass: scans are kept (compactly, bounded) for it unless keep_scans is false.
  bool keep_scans = true;
  ScanStoreOptions scan_store;
  // Its no_return_range and max_range are taken from `insert`, so both passes read a scan alike.
  GlobalOptimizerOptions optimizer;
  // At most this many voxels may wait in the insertion cache: beyond it the longest-waiting are
  // written into the octree after a scan (an eighth of it at a time), so that bringing the octree
  // up to date for a reader (a save, the voxel markers) stays bounded (~0.2-0.3 us per voxel
  // when all are new nodes, on a 2-core test machine).
  std::size_t max_unflushed_voxels = 100000;
};

// Gives `tree` the clamping bounds and occupancy threshold the mapper maps with (also for
// benchmarks and tests that must build the mapper's octree another way).
void useMapperThresholds(const MapperOptions& options, octomap::OcTree* tree);

// What saving and the global pass need, taken quickly (under the caller's lock) so that the slow
// work can run while mapping goes on. The octree is not copied but lent: it stays as it is until
// Mapper::endSnapshot() (meanwhile every insertion goes into the insertion cache only).
struct MapSnapshot {
  const octomap::OcTree* tree = nullptr;
  GridImage slice;                  // cropped to the known area
  unsigned band_lo = 0, band_hi = 0;  // the slice's z keys
  std::vector<StoredScan> scans;    // only when asked for
};

struct MapperStats {
  std::uint64_t scans_inserted = 0;
  std::uint64_t scans_rejected = 0;  // whole scans refused (bad header, ...)
  ReadingCounts readings;            // all readings of inserted scans, per reason
  std::uint64_t clouds_inserted = 0;
  std::uint64_t clouds_rejected = 0;  // whole clouds refused (origin outside the octree, ...)
  ReadingCounts cloud_points;         // all points of inserted clouds, per reason
  std::uint64_t voxel_updates = 0;    // of scans and clouds
  std::uint64_t beams_outside_octree = 0;  // of scans and clouds, dropped (InsertResult)
};

// Works out a depth frame's updates away from the Mapper (on another thread, outside the
// session's lock), for the map's geometry and options as they were when it was made
// (Mapper::cloudPreparer); Mapper::insertPrepared applies the result.
class CloudPreparer {
 public:
  // `floor`: the Mapper's floor layer, and how far from the sensor a frame's view of it reaches;
  // none: the floor is the fixed frame's z = 0.
  CloudPreparer(double resolution, const InsertOptions& options, std::uint64_t map_generation,
                FloorLayer* floor = nullptr, double floor_reach = 0.0);
  // `floor_frame`: the frame's number at the floor layer (FloorLayer::take(), in the order frames go
  // into the map), or none for the next one. The number is passed at the layer if the frame is
  // refused before its floor is asked for.
  PreparedCloud prepare(const SensorCloud& cloud, std::optional<std::uint64_t> floor_frame = {});
  const FlyingPixelOptions& flyingPixels() const { return inserter_.options().cloud_flying_pixels; }
  // The Mapper's inserterGeneration() it was made for.
  std::uint64_t mapGeneration() const { return map_generation_; }
  // Its own evidence window (the size of the largest frame's box) and cache.
  std::size_t memoryBytes() const { return inserter_.memoryBytes(); }
  // See ScanInserter::setGroupingThreads (the result is the same for any number).
  void setGroupingThreads(unsigned threads) { inserter_.setGroupingThreads(threads); }

 private:
  octomap::OcTree geometry_;  // empty: only its key geometry is read
  ScanInserter inserter_;
  std::uint64_t map_generation_;
  FloorLayer* floor_;
  double floor_reach_;
};

class Mapper {
 public:
  explicit Mapper(const MapperOptions& options = {});

  InsertResult insert(const Scan& scan);
  InsertResult insertPoints(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points);
  // A converted cloud: its points, and the ones its conversion left out counted with them.
  // `floor_frame`: its number at the floor layer if it has one (takeFloorFrame()), else the next.
  InsertResult insert(const SensorCloud& cloud, std::optional<std::uint64_t> floor_frame = {});
  // insertPoints in two steps, the first away from the Mapper: a preparer for the map as it is
  // now, and its result applied. insertPrepared refuses (false, nothing changed) a result made
  // before a reset, load or reconfigure (another geometry or model): insert that cloud anew.
  std::unique_ptr<CloudPreparer> cloudPreparer() const;
  bool insertPrepared(PreparedCloud prepared, std::uint64_t map_generation, InsertResult* result);
  // A depth frame's number at the floor layer, in the order frames go into the map (a pipeline
  // takes it when a frame is submitted); every number taken must reach the layer: inserted,
  // prepared (CloudPreparer::prepare) or passed. Both are safe without the lock that guards the
  // Mapper: the layer lives as long as the Mapper and guards itself.
  std::uint64_t takeFloorFrame() { return floor_->take(); }
  void passFloorFrame(std::uint64_t frame) { floor_->pass(frame); }
  const FloorLayer& floor() const { return *floor_; }
  // Changes whenever the inserter is replaced (reset, load, reconfigure). May be read without the
  // lock that guards the Mapper (a preparer's check, MappingSession::refreshCloudPreparer).
  std::uint64_t inserterGeneration() const { return inserter_generation_.load(std::memory_order_acquire); }
  void reset();
  // Replaces the map by a saved .bt/.ot (resolution taken from the file), with the floor it was
  // found with where the save wrote one (PREFIX_heights.yaml/.bin of the same save id; without
  // it the floor is the fixed frame's z = 0 until frames find one). On failure (the map or its
  // height map unreadable) the current map is kept and false is returned with the reason.
  bool load(const std::string& path, std::string* error);
  // Writes PREFIX.{bt,ot,pcd,pgm,yaml,png} and PREFIX_incremental.{pgm,yaml,png}: both the incremental
  // map here (MappingSession::save runs the global pass for PREFIX.*).
  bool save(const std::string& prefix, std::vector<std::string>* written, std::string* error);

  // The global pass over the kept scans (from all-free, or warm from the slice's max-likelihood
  // state). Does not change the map; see applyOptimized().
  OptimizedMap optimize(bool warm_start, const ProgressFn& progress = {}) const;
  // Takes new sensor models and slice band from `wanted` (insert.model, insert.max_range,
  // slice.min_z/max_z, optimizer.model; the rest of `wanted` is ignored): the following scans
  // are inserted with them, and the slice is rebuilt for the band. The octree stays as it is.
  // False with the reason for impossible values (a live tuner's input: the map and the models
  // in place are kept); std::logic_error while the octree is lent (a caller's bug).
  bool reconfigure(const MapperOptions& wanted, std::string* error);
  // Makes every voxel inside the box (map frame, m) unknown again, as octomap_server's clear_bbx;
  // the slice follows, and the kept scans with a beam crossing the box are dropped (else the
  // global pass would bring it back). False with the reason for a box outside what the octree
  // holds (nothing changed); std::logic_error while the octree is lent.
  struct Cleared {
    std::size_t voxels = 0, scans = 0;
  };
  bool clearBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Cleared* cleared, std::string* error);
  // Writes an optimized grid into the octree's slice-band voxels (but the obstacles beside the
  // pass, see PassBand) and refreshes the slice. `band`: passBand(), found once for all strips.
  void applyOptimized(const GridImage& grid, const PassBand& band);
  PassBand passBand() const;
  // Cells of `frame` (the slice as gridImageOf draws it) whose column has an occupied voxel in a
  // band layer the pass does not speak for: other sensors' obstacles, which the optimized map
  // shows too. The same cells as obstaclesBesidePass gives the saved optimized set.
  std::vector<std::size_t> cellsBesidePass(const GridImage& frame) const;
  // Brings the octree up to date and lends it (see MapSnapshot) until endSnapshot(). Reading the
  // lent octree from another thread is safe while this thread keeps inserting; reset(), load()
  // and applyOptimized() are refused meanwhile.
  // Without `with_slice`, the snapshot's slice and band stay empty (a reader of the octree alone).
  MapSnapshot snapshot(bool with_scans, bool with_slice = true);
  void endSnapshot();
  // What the global pass reads (the slice, its band, the kept scans), copied without the octree:
  // unlike snapshot() it neither flushes the insertion cache nor lends anything (tree is null).
  MapSnapshot optimizationInput() const;
  bool lent() const { return lent_; }

  // The octree, brought up to date with the insertion cache first: a write to the octree, so not
  // const (a lent octree is current as lent and is not touched).
  const octomap::OcTree& tree();
  // The octree as of the last flush (cheap; lags behind the cache by unflushedVoxels()).
  const octomap::OcTree& flushedTree() const { return *tree_; }
  std::size_t unflushedVoxels() const { return inserter_->cache().dirtyCount(); }
  const SliceGrid& slice() const { return *slice_; }
  const MapperStats& stats() const { return stats_; }
  const MapperOptions& options() const { return options_; }
  const ScanInserter& inserter() const { return *inserter_; }
  const ScanStore& scanStore() const { return store_; }

 private:
  void adopt(std::unique_ptr<octomap::OcTree> tree);
  // A new inserter and slice for `tree` (null: the current one) with `options`, swapped in only
  // when both could be built.
  void install(std::unique_ptr<octomap::OcTree> tree, const MapperOptions& options);
  // The global pass reads scans as insertion does: its reading rules, no-return range and range
  // cut follow `insert`.
  static void followInsertion(MapperOptions* options);
  // Slice update + statistics; a cloud's slice follows the floor as of its frame `floor_frame`.
  InsertResult record(InsertResult result, bool cloud, std::optional<std::uint64_t> floor_frame = std::nullopt);
  // How far from the sensor a frame's view of the floor reaches: as far as a return may mark.
  double floorReach() const;
  // A cloud's points prepared and applied, its floor frame `floor_frame` (or the next), its floor
  // through `ground` when given (SensorCloud::ground).
  InsertResult insertCloud(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                           std::optional<std::uint64_t> floor_frame, const ReadingCounts& left_out,
                           const std::optional<Eigen::Vector3d>& ground);
  // The slice follows the floor layer's new levels as of frame `frame`'s fold (none: all so far):
  // shifted columns, or a band moved whole.
  void followFloor(std::optional<std::uint64_t> frame = std::nullopt);
  // The user's band moved to the floor level the slice stands on.
  SliceOptions sliceBand(const SliceOptions& band) const;
  std::vector<std::pair<std::uint32_t, int>> columnShifts() const;
  void boundUnflushed();  // keeps the insertion cache's backlog within max_unflushed_voxels
  // A snapshot's copies (the slice, its band, the kept scans if asked), without the octree.
  MapSnapshot sliceAndScans(bool with_scans) const;

  MapperOptions options_;
  std::unique_ptr<octomap::OcTree> tree_;
  std::unique_ptr<ScanInserter> inserter_;
  std::unique_ptr<SliceGrid> slice_;
  ScanStore store_;
  MapperStats stats_;
  std::unique_ptr<FloorLayer> floor_;
  std::unordered_map<std::uint32_t, int> floor_levels_;  // per known floor cell, as the slice last took it
  int slice_level_ = 0;                                  // the floor level the slice's band is set for
  bool lent_ = false;
  std::atomic<std::uint64_t> inserter_generation_{0};
};

}  // namespace octo_slice_mapper
