#include "octo_slice_mapper/mapper.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <utility>

#include "octo_slice_mapper/internal/height_map.h"
#include "octo_slice_mapper/map_io.h"

namespace octo_slice_mapper {

void useMapperThresholds(const MapperOptions& options, octomap::OcTree* tree) {
  tree->setClampingThresMin(options.clamp_min);
  tree->setClampingThresMax(options.clamp_max);
  tree->setOccupancyThres(0.5);
}

Mapper::Mapper(const MapperOptions& options) : options_(options), store_(options.scan_store) {
  if (!(options.resolution > 0.0)) throw std::invalid_argument("mapper: resolution must be > 0");
  if (!(0.0 < options.clamp_min && options.clamp_min < 0.5 && 0.5 < options.clamp_max && options.clamp_max < 1.0)) {
    throw std::invalid_argument("mapper: need 0 < clamp_min < 0.5 < clamp_max < 1");
  }
  followInsertion(&options_);
  floor_ = std::make_unique<FloorLayer>(options_.resolution, options_.floor);
  adopt(std::make_unique<octomap::OcTree>(options.resolution));
}

void Mapper::followInsertion(MapperOptions* options) {
  options->optimizer.no_return_range = options->insert.model.no_return_clear_distance;
  options->optimizer.readings = options->insert.readings;
  options->floor.max_step = options->insert.cloud_mark_min_z;  // a surface that would mark is no floor
}

void Mapper::adopt(std::unique_ptr<octomap::OcTree> tree) {
  useMapperThresholds(options_, tree.get());
  install(std::move(tree), options_);
}

void Mapper::install(std::unique_ptr<octomap::OcTree> tree, const MapperOptions& options) {
  octomap::OcTree* target = tree ? tree.get() : tree_.get();
  // Build the new parts before swapping, so a bad option or a slice too big leaves the old map in place.
  auto inserter = std::make_unique<ScanInserter>(target, options.insert);
  auto slice = std::make_unique<SliceGrid>(*target, sliceBand(options.slice), &inserter->cache());
  slice->shiftColumns(columnShifts());
  // The options are valid. On the same octree the new inserter starts with an empty cache and the
  // new slice reads the octree: it must hold what the old cache holds. (Flushed before the
  // options were checked, a refused reconfigure wrote into the octree.)
  if (!tree && inserter_) inserter_->flush();
  slice->rebuild();
  options_ = options;
  options_.resolution = target->getResolution();
  if (tree) tree_ = std::move(tree);
  inserter_ = std::move(inserter);
  slice_ = std::move(slice);
  inserter_generation_.fetch_add(1, std::memory_order_release);
}

InsertResult Mapper::insert(const Scan& scan) {
  InsertResult result = record(inserter_->insert(scan), /*cloud=*/false);
  if (result.ok() && options_.keep_scans) store_.add(scan);
  return result;
}

// Above the bound, the voxels that have waited longest are written (whole tiles: at most one
// tile's 4 096 more), an eighth of the bound at a time: a flush per scan stays about as short as
// one of 12 500 voxels, while a voxel stays in the cache long enough for the many scans that keep
// changing it to cost one write (a tilted scan changes 2 000 voxels, many of them again and
// again).
void Mapper::boundUnflushed() {
  if (lent_) return;
  LayerCache& cache = inserter_->cache();
  const std::size_t bound = options_.max_unflushed_voxels;
  if (cache.dirtyCount() > bound) cache.flushOldest(cache.dirtyCount() - (bound - bound / 8));
}

namespace {

// What frame `frame` is measured against: its floor found and folded into the layer in its turn.
FloorStage floorStageOf(FloorLayer* layer, std::uint64_t frame, double reach,
                        const std::optional<Eigen::Vector3d>& ground) {
  return [layer, frame, reach, ground](const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples,
                                       const std::vector<std::uint32_t>* cells) {
    return layer->observe(frame, sensor, samples, reach, cells, ground);
  };
}

// Passes a frame's turn at the floor layer on every way out, unless its floor was asked for.
class FloorTurn {
 public:
  FloorTurn(FloorLayer* layer, std::uint64_t frame) : layer_(layer), frame_(frame) {}
  ~FloorTurn() { layer_->pass(frame_); }
  FloorTurn(const FloorTurn&) = delete;
  FloorTurn& operator=(const FloorTurn&) = delete;

 private:
  FloorLayer* layer_;
  std::uint64_t frame_;
};

// A cloud prepared by `inserter` against the floor layer as frame `floor_frame` (or the next),
// the points its conversion left out counted with it.
PreparedCloud prepareOnFloor(ScanInserter& inserter, FloorLayer* floor, double reach, const Eigen::Vector3d& origin,
                             const std::vector<Eigen::Vector3f>& points, const ReadingCounts& left_out,
                             std::optional<std::uint64_t> floor_frame, const std::optional<Eigen::Vector3d>& ground) {
  const std::uint64_t frame = floor_frame ? *floor_frame : floor->take();
  const FloorTurn turn(floor, frame);
  PreparedCloud prepared = inserter.prepareCloud(origin, points, inserter.model().halfAngleFor(0.0),
                                                 floorStageOf(floor, frame, reach, ground));
  prepared.result.readings += left_out;
  prepared.floor_frame = frame;
  return prepared;
}

}  // namespace

InsertResult Mapper::insertPoints(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points) {
  return insertCloud(origin, points, std::nullopt, ReadingCounts(), std::nullopt);
}

InsertResult Mapper::insert(const SensorCloud& cloud, std::optional<std::uint64_t> floor_frame) {
  return insertCloud(cloud.origin, cloud.points, floor_frame, cloud.left_out, cloud.ground);
}

InsertResult Mapper::insertCloud(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points,
                                 std::optional<std::uint64_t> floor_frame, const ReadingCounts& left_out,
                                 const std::optional<Eigen::Vector3d>& ground) {
  PreparedCloud prepared =
      prepareOnFloor(*inserter_, floor_.get(), floorReach(), origin, points, left_out, floor_frame, ground);
  const std::optional<std::uint64_t> frame = prepared.floor_frame;
  return record(inserter_->applyCloud(std::move(prepared)), /*cloud=*/true, frame);
}

double Mapper::floorReach() const {
  const InsertOptions& o = options_.insert;
  return o.cloud_max_range > 0.0 ? o.cloud_max_range : o.max_range > 0.0 ? o.max_range : 30.0;
}

SliceOptions Mapper::sliceBand(const SliceOptions& band) const {
  if (slice_level_ == 0) return band;
  // Whole voxel layers: the centres of the layers the band's ends are in, moved. (Moving the ends
  // themselves could take one across a layer boundary by rounding: 0.05 m + 30 layers is
  // -1.45 m, a boundary.)
  SliceOptions moved = band;
  const auto shifted = [&](double z) {
    octomap::OcTreeKey key;
    if (!coordToKeySafe(*tree_, 0.0, 0.0, z, &key)) return z;  // SliceGrid refuses it
    return tree_->keyToCoord(static_cast<octomap::key_type>(int(key[2]) + slice_level_));
  };
  moved.min_z = shifted(band.min_z);
  moved.max_z = shifted(band.max_z);
  return moved;
}

std::vector<std::pair<std::uint32_t, int>> Mapper::columnShifts() const {
  std::vector<std::pair<std::uint32_t, int>> shifts;
  for (const auto& [column, level] : floor_levels_) {
    if (level != slice_level_) shifts.emplace_back(column, level - slice_level_);
  }
  return shifts;
}

void Mapper::followFloor(std::optional<std::uint64_t> frame) {
  FloorLayer::LevelChanges changes = floor_->takeLevelChanges(frame ? std::optional<std::uint64_t>(*frame + 1) : std::nullopt);
  std::vector<std::pair<std::uint32_t, int>> shifts;
  shifts.reserve(changes.cells.size());
  for (const auto& [column, level] : changes.cells) {
    if (level == FloorLayer::kNoLevel) floor_levels_.erase(column);
    else floor_levels_[column] = level;
    shifts.emplace_back(column, level == FloorLayer::kNoLevel ? 0 : level - slice_level_);
  }
  if (changes.fallback_level != slice_level_) {
    // The band moves whole: a slice built anew (as reconfigure's), the inserter kept.
    slice_level_ = changes.fallback_level;
    auto slice = std::make_unique<SliceGrid>(*tree_, sliceBand(options_.slice), &inserter_->cache());
    slice->shiftColumns(columnShifts());
    slice->rebuild();
    slice_ = std::move(slice);
  } else {
    slice_->shiftColumns(shifts);
  }
}

CloudPreparer::CloudPreparer(double resolution, const InsertOptions& options, std::uint64_t map_generation,
                             FloorLayer* floor, double floor_reach)
    : geometry_(resolution),
      inserter_(&geometry_, options),
      map_generation_(map_generation),
      floor_(floor),
      floor_reach_(floor_reach) {}

PreparedCloud CloudPreparer::prepare(const SensorCloud& cloud, std::optional<std::uint64_t> floor_frame) {
  if (!floor_) {
    PreparedCloud prepared = inserter_.prepareCloud(cloud.origin, cloud.points, inserter_.model().halfAngleFor(0.0));
    prepared.result.readings += cloud.left_out;
    return prepared;
  }
  return prepareOnFloor(inserter_, floor_, floor_reach_, cloud.origin, cloud.points, cloud.left_out, floor_frame,
                        cloud.ground);
}

std::unique_ptr<CloudPreparer> Mapper::cloudPreparer() const {
  return std::make_unique<CloudPreparer>(tree_->getResolution(), options_.insert, inserterGeneration(), floor_.get(),
                                         floorReach());
}

bool Mapper::insertPrepared(PreparedCloud prepared, std::uint64_t map_generation, InsertResult* result) {
  if (map_generation != inserterGeneration()) return false;
  const std::optional<std::uint64_t> frame = prepared.floor_frame;
  *result = record(inserter_->applyCloud(std::move(prepared)), /*cloud=*/true, frame);
  return true;
}

InsertResult Mapper::record(InsertResult result, bool cloud, std::optional<std::uint64_t> floor_frame) {
  if (!result.ok()) {
    (cloud ? stats_.clouds_rejected : stats_.scans_rejected)++;
    return result;
  }
  slice_->updateColumns(result.updated_keys, result.touched, result.changes);
  if (cloud) followFloor(floor_frame);
  boundUnflushed();  // after clouds too: a camera alone was never flushed before
  (cloud ? stats_.clouds_inserted : stats_.scans_inserted)++;
  (cloud ? stats_.cloud_points : stats_.readings) += result.readings;
  stats_.voxel_updates += result.voxels_updated;
  stats_.beams_outside_octree += result.beams_outside_octree;
  return result;
}

PassBand Mapper::passBand() const {
  return PassBand::of(store_.scans(), *tree_, slice_->bandMinKey(), slice_->bandMaxKey());
}

std::vector<std::size_t> Mapper::cellsBesidePass(const GridImage& frame) const {
  // The saved optimized set's rule (obstaclesBesidePass): a column with an occupied voxel in a band
  // layer the pass does not speak for, read through the insertion cache (the tree lags behind it).
  std::vector<std::size_t> cells;
  const PassBand band = passBand();
  if (band.scans_lo > band.scans_hi) return cells;  // no kept scans: no pass
  const float occupied = tree_->getOccupancyThresLog();
  const LayerCache& cache = inserter_->cache();
  for (int j = 0; j < frame.height; ++j) {
    for (int i = 0; i < frame.width; ++i) {
      // The slice shows a column's most occupied voxel when it is occupied: below 50, none is.
      if (frame.at(i, j) < 50) continue;
      octomap::OcTreeKey key;
      if (!coordToKeySafe(*tree_, frame.origin_x + (i + 0.5) * frame.resolution,
                          frame.origin_y + (j + 0.5) * frame.resolution, 0.0, &key)) {
        continue;
      }
      bool beside = false;
      for (unsigned kz = band.band_lo; kz <= band.band_hi && !beside; ++kz) {
        if (band.passSpeaksFor(kz)) continue;
        key[2] = static_cast<octomap::key_type>(kz);
        float value = 0.0f;
        switch (cache.lookup(key[0], key[1], kz, &value)) {
          case LayerCache::Lookup::kKnown:
            beside = value >= occupied;
            break;
          case LayerCache::Lookup::kUnknown:
            break;
          case LayerCache::Lookup::kNotCached:
            if (const octomap::OcTreeNode* node = tree_->search(key)) beside = node->getLogOdds() >= occupied;
            break;
        }
      }
      if (beside) cells.push_back(std::size_t(j) * frame.width + i);
    }
  }
  return cells;
}

void Mapper::reset() {
  if (lent_) throw std::logic_error("mapper: reset while the octree is lent");
  floor_levels_.clear();
  slice_level_ = 0;
  floor_->reset(options_.resolution);
  floor_->takeLevelChanges();
  adopt(std::make_unique<octomap::OcTree>(options_.resolution));
  store_.clear();
  stats_ = MapperStats();
}

bool Mapper::load(const std::string& path, std::string* error) {
  if (lent_) {
    *error = "the map is being saved or optimized";
    return false;
  }
  std::unique_ptr<octomap::OcTree> tree = loadTree(path, error);
  if (!tree) return false;
  // The floor the map was found with: its height map, saved beside it with the same save id (one
  // with another id is an older save's under the same name). Without one the map is sliced from
  // the fixed frame's z = 0 until frames find a floor again. Read first: a height map that cannot
  // be read refuses the load, and the current map and floor stay.
  HeightMap heights;
  const bool saved_name = path.size() > 3 && (path.compare(path.size() - 3, 3, ".bt") == 0 ||
                                               path.compare(path.size() - 3, 3, ".ot") == 0);
  const std::string heights_path = path.substr(0, saved_name ? path.size() - 3 : path.size()) + "_heights.yaml";
  const std::string id = readSaveId(path);
  if (!id.empty() && readSaveId(heights_path) == id) {
    if (!readHeightMap(heights_path, &heights, error)) {
      *error = "the map's floor: " + *error;
      return false;
    }
    // (The .yaml holds six significant digits.)
    if (std::abs(heights.resolution - tree->getResolution()) > 1e-5 * tree->getResolution()) {
      *error = heights_path + ": resolution " + std::to_string(heights.resolution) + ", the map's is " +
               std::to_string(tree->getResolution());
      return false;
    }
  }
  std::unordered_map<std::uint32_t, int> levels;
  levels.swap(floor_levels_);
  const int level = std::exchange(slice_level_, 0);
  try {
    adopt(std::move(tree));
  } catch (const std::exception& e) {
    floor_levels_.swap(levels);
    slice_level_ = level;
    *error = path + ": " + e.what();
    return false;
  }
  floor_->reset(options_.resolution);
  floor_->takeLevelChanges();
  if (!heights.empty()) {
    std::vector<std::pair<std::uint32_t, float>> cells;
    double fallback = heights.fallback_floor;
    std::vector<float> known;
    for (int j = 0; j < heights.height; ++j) {
      for (int i = 0; i < heights.width; ++i) {
        const float h = heights.floor[std::size_t(j) * heights.width + i];
        if (!std::isfinite(h)) continue;
        const int kx = floorKeyOf(heights.origin_x + (i + 0.5) * heights.resolution, heights.resolution);
        const int ky = floorKeyOf(heights.origin_y + (j + 0.5) * heights.resolution, heights.resolution);
        if (kx < 0 || ky < 0) continue;
        cells.emplace_back(std::uint32_t(kx) | std::uint32_t(ky) << 16, h);
        known.push_back(h);
      }
    }
    if (!std::isfinite(fallback) && !known.empty()) {  // not saved: the cells' median
      std::nth_element(known.begin(), known.begin() + known.size() / 2, known.end());
      fallback = known[known.size() / 2];
    }
    if (!cells.empty()) {
      floor_->restore(cells, fallback);
      followFloor();
    }
  }
  return true;
}

const octomap::OcTree& Mapper::tree() {
  if (!lent_) inserter_->flush();  // a lent tree must not change; it is current as lent
  return *tree_;
}

bool Mapper::save(const std::string& prefix, std::vector<std::string>* written, std::string* error) {
  const GridImage grid = gridImageOf(*slice_);
  const HeightMap heights = heightMapOf(tree(), *floor_, grid);
  return saveMapSet(tree(), grid, prefix, written, error, &grid, &heights);
}

OptimizedMap Mapper::optimize(bool warm_start, const ProgressFn& progress) const {
  const GridImage incremental = warm_start ? gridImageOf(*slice_) : GridImage();
  return optimizeScans(store_.scans(), options_.optimizer, options_.resolution, warm_start ? &incremental : nullptr,
                       progress);
}

MapSnapshot Mapper::snapshot(bool with_scans, bool with_slice) {
  if (lent_) throw std::logic_error("mapper: the octree is already lent");
  MapSnapshot snap;
  if (with_slice) {
    snap = sliceAndScans(with_scans);
  } else if (with_scans) {
    snap.scans = store_.scans();
  }
  snap.tree = &tree();
  lent_ = true;
  inserter_->cache().holdEverything(true);  // the lent octree must not change
  return snap;
}

MapSnapshot Mapper::optimizationInput() const { return sliceAndScans(/*with_scans=*/true); }

MapSnapshot Mapper::sliceAndScans(bool with_scans) const {
  MapSnapshot copy;
  copy.slice = gridImageOf(*slice_);
  copy.band_lo = slice_->bandMinKey();
  copy.band_hi = slice_->bandMaxKey();
  if (with_scans) copy.scans = store_.scans();
  return copy;
}

void Mapper::endSnapshot() {
  lent_ = false;
  inserter_->cache().holdEverything(false);
}

namespace {

// Whether the segment from `a` to `b` meets the box [lo, hi] (slabs).
bool segmentMeetsBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& lo,
                     const Eigen::Vector3d& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector3d d = b - a;
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) {
      if (a[i] < lo[i] || a[i] > hi[i]) return false;
      continue;
    }
    double ta = (lo[i] - a[i]) / d[i], tb = (hi[i] - a[i]) / d[i];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// OctoMap's deleteNode cannot be used here: when a deletion empties a node, it deletes that node
// with its (now empty) child array still allocated, which the node's destructor asserts against
// (Debian's liboctomap 1.9 is built with asserts: the process aborts). A subtree is removed here
// only after it was collapsed into a leaf (its child arrays freed by pruneNode).

// Turns the subtree under `node` into a single leaf: every missing child created, every child
// collapsed and given the same value, then pruned (which frees the child array). Returns how many
// of the tree's leaves it held: `node` itself when `is_leaf`, else those below it.
std::size_t collapseIntoLeaf(octomap::OcTree* tree, octomap::OcTreeNode* node, bool is_leaf) {
  std::size_t leaves = is_leaf ? 1 : 0;
  for (unsigned c = 0; c < 8; ++c) {
    octomap::OcTreeNode* child = nullptr;
    if (tree->nodeChildExists(node, c)) {
      child = tree->getNodeChild(node, c);
      if (tree->nodeHasChildren(child)) leaves += collapseIntoLeaf(tree, child, false);
      else if (!is_leaf) leaves += 1;
    } else {
      child = tree->createNodeChild(node, c);
    }
    child->setLogOdds(0.0f);
  }
  tree->pruneNode(node);
  return leaves;
}

// What clearInside left of a subtree.
enum class Left { kAll, kPart, kNothing };

// Removes what lies inside keys [lo, hi] from the subtree under `node` (depth `depth`, first key
// `base`); `removed` counts the leaves removed. kNothing: the whole subtree is to go (the caller
// removes it; its leaves are not counted yet when it lies wholly inside).
Left clearInside(octomap::OcTree* tree, octomap::OcTreeNode* node, const octomap::OcTreeKey& base, unsigned depth,
                 const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi, bool* wholly_inside, std::size_t* removed) {
  const unsigned span = 1u << (tree->getTreeDepth() - depth);
  bool inside = true;
  for (int i = 0; i < 3; ++i) {
    if (base[i] + span - 1 < lo[i] || base[i] > hi[i]) return Left::kAll;
    inside = inside && base[i] >= lo[i] && base[i] + span - 1 <= hi[i];
  }
  *wholly_inside = inside;
  if (inside) return Left::kNothing;
  if (!tree->nodeHasChildren(node)) tree->expandNode(node);  // a pruned leaf partly inside: split
  bool left = false;
  const unsigned half = span / 2;
  for (unsigned c = 0; c < 8; ++c) {
    if (!tree->nodeChildExists(node, c)) continue;
    octomap::OcTreeNode* child = tree->getNodeChild(node, c);
    const octomap::OcTreeKey child_base(base[0] + (c & 1 ? half : 0), base[1] + (c & 2 ? half : 0),
                                        base[2] + (c & 4 ? half : 0));
    const bool was_leaf = !tree->nodeHasChildren(child);
    bool child_inside = false;
    if (clearInside(tree, child, child_base, depth + 1, lo, hi, &child_inside, removed) == Left::kNothing) {
      // Wholly inside: its leaves are counted as it collapses; emptied part by part: counted already.
      const std::size_t leaves = collapseIntoLeaf(tree, child, was_leaf);
      if (child_inside) *removed += leaves;
      tree->deleteNodeChild(node, c);
    } else {
      left = true;
    }
  }
  if (left) node->updateOccupancyChildren();
  return left ? Left::kPart : Left::kNothing;
}

// Removes every voxel of `tree` inside keys [lo, hi]; returns how many leaves went.
std::size_t clearKeyBox(octomap::OcTree* tree, const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi) {
  octomap::OcTreeNode* root = tree->getRoot();
  if (!root) return 0;
  std::size_t removed = 0;
  bool inside = false;
  if (clearInside(tree, root, octomap::OcTreeKey(0, 0, 0), 0, lo, hi, &inside, &removed) == Left::kNothing) {
    if (inside) removed += tree->getNumLeafNodes();
    tree->clear();  // frees the root's subtree properly
  }
  return removed;
}

}  // namespace

bool Mapper::reconfigure(const MapperOptions& wanted, std::string* error) {
  if (lent_) throw std::logic_error("mapper: reconfigure while the octree is lent");
  MapperOptions next = options_;
  next.insert.model = wanted.insert.model;
  next.insert.max_range = wanted.insert.max_range;
  next.slice.min_z = wanted.slice.min_z;
  next.slice.max_z = wanted.slice.max_z;
  next.optimizer.model = wanted.optimizer.model;
  followInsertion(&next);
  try {
    install(nullptr, next);  // builds the new model and slice before it swaps anything in
  } catch (const std::invalid_argument& e) {
    *error = e.what();  // the options' constructors are their one validation
    return false;
  }
  return true;
}

bool Mapper::clearBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, Cleared* out, std::string* error) {
  if (lent_) throw std::logic_error("mapper: clearBox while the octree is lent");
  octomap::OcTreeKey lo, hi;
  const Eigen::Vector3d a = min.cwiseMin(max), b = min.cwiseMax(max);
  if (!coordToKeySafe(*tree_, a.x(), a.y(), a.z(), &lo) || !coordToKeySafe(*tree_, b.x(), b.y(), b.z(), &hi)) {
    *error = "the box is outside what the octree holds";
    return false;
  }
  inserter_->flush();
  Cleared& cleared = *out;
  cleared = Cleared{};
  cleared.voxels = clearKeyBox(tree_.get(), lo, hi);
  inserter_->cache().clear();  // flushed above: the octree holds all it had
  KeyBox box;
  box.add(lo);
  box.add(hi);
  slice_->update(box);
  cleared.scans = store_.removeIf([&](const StoredScan& s) {
    const Scan scan = s.toScan();
    const Eigen::Vector3d origin = scan.sensor_pose.translation();
    for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
      const float r = scan.ranges[i];
      if (!(r > scan.range_min) || !std::isfinite(r)) continue;
      const double length = std::min<double>(r, scan.range_max);
      const double angle = scan.beamAngle(i);
      const Eigen::Vector3d end = scan.sensor_pose * Eigen::Vector3d(length * std::cos(angle), length * std::sin(angle), 0.0);
      if (segmentMeetsBox(origin, end, a, b)) return true;
    }
    return false;
  });
  return true;
}

void Mapper::applyOptimized(const GridImage& grid, const PassBand& band) {
  if (lent_) throw std::logic_error("mapper: applyOptimized while the octree is lent");
  inserter_->flush();
  const std::vector<octomap::OcTreeKey> keys = writeGridIntoBand(grid, band, tree_.get());
  for (const octomap::OcTreeKey& k : keys) inserter_->cache().forget(k);  // it holds the values from before
  slice_->updateColumns(keys, KeyBox::of(keys));
}

}  // namespace octo_slice_mapper
