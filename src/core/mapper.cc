#include "octo_slice_mapper/mapper.h"

#include <stdexcept>

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
  options_.optimizer.no_return_range = options.insert.model.no_return_clear_distance;
  options_.optimizer.readings = options.insert.readings;
  options_.optimizer.max_range = options.insert.max_range;
  adopt(std::make_unique<octomap::OcTree>(options.resolution));
}

void Mapper::adopt(std::unique_ptr<octomap::OcTree> tree) {
  useMapperThresholds(options_, tree.get());
  // Build the new parts before swapping, so a bad option or a slice too big leaves the old map in place.
  auto inserter = std::make_unique<ScanInserter>(tree.get(), options_.insert);
  auto slice = std::make_unique<SliceGrid>(*tree, options_.slice, &inserter->cache());
  slice->rebuild();
  options_.resolution = tree->getResolution();
  tree_ = std::move(tree);
  inserter_ = std::move(inserter);
  slice_ = std::move(slice);
}

InsertResult Mapper::insert(const Scan& scan) {
  InsertResult result = record(inserter_->insert(scan));
  if (result.ok() && options_.keep_scans) store_.add(scan);
  if (!lent_ && inserter_->cache().dirtyCount() > options_.max_unflushed_voxels) inserter_->flush();
  return result;
}

InsertResult Mapper::insertPoints(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3f>& points) {
  return record(inserter_->insertPoints(origin, points, inserter_->model().halfAngleFor(0.0)));
}

InsertResult Mapper::record(InsertResult result) {
  if (!result.ok()) {
    stats_.scans_rejected++;
    return result;
  }
  slice_->updateColumns(result.updated_keys, result.touched);
  stats_.scans_inserted++;
  stats_.readings += result.readings;
  stats_.voxel_updates += result.voxels_updated;
  return result;
}

void Mapper::reset() {
  if (lent_) throw std::logic_error("mapper: reset while the octree is lent");
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
  try {
    adopt(std::move(tree));
  } catch (const std::exception& e) {
    *error = path + ": " + e.what();
    return false;
  }
  return true;
}

const octomap::OcTree& Mapper::tree() {
  if (!lent_) inserter_->flush();  // a lent tree must not change; it is current as lent
  return *tree_;
}

bool Mapper::save(const std::string& prefix, std::vector<std::string>* written, std::string* error) {
  return saveMapSet(tree(), gridImageOf(*slice_), prefix, written, error);
}

OptimizedMap Mapper::optimize(bool warm_start, const ProgressFn& progress) const {
  const GridImage incremental = warm_start ? gridImageOf(*slice_) : GridImage();
  return optimizeScans(store_.scans(), options_.optimizer, options_.resolution, warm_start ? &incremental : nullptr,
                       progress);
}

MapSnapshot Mapper::snapshot(bool with_scans) {
  if (lent_) throw std::logic_error("mapper: the octree is already lent");
  MapSnapshot snap = sliceAndScans(with_scans);
  snap.tree = &tree();
  lent_ = true;
  inserter_->setOctreeLent(true);
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
  inserter_->setOctreeLent(false);
}

void Mapper::applyOptimized(const GridImage& grid) {
  if (lent_) throw std::logic_error("mapper: applyOptimized while the octree is lent");
  inserter_->flush();
  const std::vector<octomap::OcTreeKey> keys = writeGridIntoBand(grid, slice_->bandMinKey(), slice_->bandMaxKey(), tree_.get());
  KeyBox box;
  for (const octomap::OcTreeKey& k : keys) {
    inserter_->forgetCached(k);  // it holds the values from before
    box.add(k);
  }
  slice_->updateColumns(keys, box);
}

}  // namespace octo_slice_mapper
