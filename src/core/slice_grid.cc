#include "octo_slice_mapper/slice_grid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/internal/occupancy_percent.h"

namespace octo_slice_mapper {
namespace {

// Geometry ids are unique across grids: a Mapper reset makes a new grid, and a consumer must not
// take its first geometry for the old grid's.
std::uint64_t nextGeometry() {
  static std::atomic<std::uint64_t> next{1};
  return next++;
}

// SliceGrid::columnAfter, inline for updateColumns' loop. The column's rule (columnValue): its
// most occupied voxel when that is 50 % or more, else its freest. The percent is monotonic in the
// log-odds and 50 at 0, so a column below 50 has every known voxel below 0 (the freest counts),
// one above 50 has an occupied voxel (the most occupied counts). The changed voxel then either
// takes over (it is now the extreme that counts, or the first voxel >= 0) or, if it moved away
// from the extreme, leaves the column as it was unless it was that extreme itself: when its old
// percent equals the column's, that cannot be told here.
inline std::int8_t followChange(std::int8_t value, const VoxelChange& change, const OccupancyPercent& percent) {
  const std::int8_t after = percent.lookup(change.after);
  if (value == kUnknownCell) return after;  // its first known voxel
  const bool was_known = LayerCache::isKnown(change.before);
  if (value < 50) {
    if (change.after >= 0.0f) return after;  // the only voxel >= 0: the most occupied now counts
    if (!was_known || change.after < change.before) return std::min(value, after);
    return percent.lookup(change.before) > value ? value : kPendingCell;  // was it the freest?
  }
  if (value > 50) {
    if (!was_known || change.after > change.before) return std::max(value, after);
    return percent.lookup(change.before) < value ? value : kPendingCell;  // the most occupied?
  }
  return kPendingCell;  // 50: either rule may be the one that holds
}

}  // namespace

SliceGrid::SliceGrid(const octomap::OcTree& tree, const SliceOptions& options, const LayerCache* cache)
    : tree_(tree), cache_(cache), options_(options), resolution_(tree.getResolution()) {
  if (!(options.min_z <= options.max_z)) throw std::invalid_argument("slice: min_z must be <= max_z");
  octomap::OcTreeKey lo, hi;
  if (!coordToKeySafe(tree, 0, 0, options.min_z, &lo) || !coordToKeySafe(tree, 0, 0, options.max_z, &hi)) {
    throw std::invalid_argument("slice: z band outside the octree");
  }
  band_lo_ = lo[2];
  band_hi_ = hi[2];
  layer_may_be_known_.assign(band_hi_ - band_lo_ + 1, false);
}

void SliceGrid::noteLayers(unsigned kz0, unsigned kz1) {
  for (unsigned kz = std::max<unsigned>(kz0, band_lo_); kz <= std::min<unsigned>(kz1, band_hi_); ++kz) {
    layer_may_be_known_[kz - band_lo_] = true;
  }
}

double SliceGrid::originX() const { return tree_.keyToCoord(origin_key_x_) - 0.5 * resolution_; }
double SliceGrid::originY() const { return tree_.keyToCoord(origin_key_y_) - 0.5 * resolution_; }

bool SliceGrid::cellOf(double x, double y, int* i, int* j) const {
  if (width_ == 0) return false;
  const int ci = static_cast<int>(std::floor((x - originX()) / resolution_));
  const int cj = static_cast<int>(std::floor((y - originY()) / resolution_));
  if (ci < 0 || cj < 0 || ci >= width_ || cj >= height_) return false;
  *i = ci;
  *j = cj;
  return true;
}

std::int8_t SliceGrid::valueAt(double x, double y) const {
  int i, j;
  return cellOf(x, y, &i, &j) ? at(i, j) : kUnknownCell;
}

std::size_t SliceGrid::knownCells() const {
  return static_cast<std::size_t>(
      std::count_if(data_.begin(), data_.end(), [](std::int8_t v) { return v != kUnknownCell; }));
}

void SliceGrid::clear() {
  geometry_ = nextGeometry();
  width_ = height_ = 0;
  data_.clear();
  shift_grid_.clear();
  layer_may_be_known_.assign(layer_may_be_known_.size(), false);
}

// One voxel's value from the tree: a descent from `top`, the deepest node holding the column's band.
const octomap::OcTreeNode* SliceGrid::bandVoxel(const octomap::OcTreeNode* top, std::uint16_t kx, std::uint16_t ky,
                                                unsigned kz, unsigned top_depth) const {
  const unsigned depth = tree_.getTreeDepth();
  const octomap::OcTreeKey key(kx, ky, static_cast<std::uint16_t>(kz));
  const octomap::OcTreeNode* node = top;
  for (unsigned d = top_depth; d < depth && node && tree_.nodeHasChildren(node); ++d) {
    const unsigned pos = octomap::computeChildIdx(key, static_cast<int>(depth - 1 - d));
    node = tree_.nodeChildExists(node, pos) ? tree_.getNodeChild(node, pos) : nullptr;
  }
  return node;
}

namespace {
unsigned bitLength(unsigned v) {
  unsigned bits = 0;
  while (v) v >>= 1, ++bits;
  return bits;
}
}  // namespace

// The deepest nodes holding a column's layers [lo, hi], each found when first needed: one, or
// one per half where the layers straddle a boundary high in the tree (z = 0 is the root's own),
// so that no layer is read from the root down. A part's keys share at least their top bit, so
// its depth is at least 1 (OctoMap's search reads depth 0 as "all the way down").
class SliceGrid::ColumnDescent {
 public:
  ColumnDescent(const SliceGrid& grid, std::uint16_t kx, std::uint16_t ky, unsigned lo, unsigned hi)
      : grid_(grid), kx_(kx), ky_(ky) {
    const unsigned bits = bitLength(lo ^ hi);
    mid_ = bits == 0 ? hi + 1 : (hi >> (bits - 1)) << (bits - 1);  // the upper half's first key
    parts_[0] = partOf(lo, std::min(hi, mid_ - 1));
    if (bits > 0) parts_[1] = partOf(mid_, hi);  // else no key reaches it
  }
  const octomap::OcTreeNode* voxel(unsigned kz) {
    Part& part = parts_[kz < mid_ ? 0 : 1];
    if (!part.searched) {
      part.top = grid_.tree_.search(octomap::OcTreeKey(kx_, ky_, std::uint16_t(part.lo)), part.depth);
      part.searched = true;
    }
    return part.top ? grid_.bandVoxel(part.top, kx_, ky_, kz, part.depth) : nullptr;
  }

 private:
  struct Part {
    unsigned lo = 0, depth = 0;
    const octomap::OcTreeNode* top = nullptr;
    bool searched = false;
  };
  Part partOf(unsigned lo, unsigned hi) const {
    Part part;
    part.lo = lo;
    part.depth = grid_.tree_.getTreeDepth() - bitLength(lo ^ hi);  // the deepest node holding both ends
    return part;
  }
  const SliceGrid& grid_;
  std::uint16_t kx_, ky_;
  unsigned mid_;
  Part parts_[2];
};

void SliceGrid::findBandLayers() {
  band_layers_.clear();
  for (unsigned kz = band_lo_; kz <= band_hi_; ++kz) {
    if (!layer_may_be_known_[kz - band_lo_]) continue;
    band_layers_.push_back({kz, cache_ ? cache_->findLayer(std::uint16_t(kz)) : nullptr});
  }
}

// One descent to the deepest node holding the whole band of this column (ColumnDescent), then a
// few levels down per layer: 5 layers cost ~1.5 root-to-leaf walks instead of 5. Voxels of cached layers are read
// from the cache (band_layers_, found once per update), which the tree may lag behind. Compared
// as log-odds, one percent at the end (OccupancyPercent, a table: no exp()): it is monotonic in
// them, and a tilted scan's columns have several known layers (two exp() per layer were a quarter
// of its slice update).
std::int8_t SliceGrid::columnValue(std::uint16_t kx, std::uint16_t ky) const {
  if (!shift_.empty()) {
    if (const int shift = columnShift(kx, ky)) return shiftedColumnValue(kx, ky, shift);
  }
  ColumnDescent descent(*this, kx, ky, band_lo_, band_hi_);  // only when a layer needs the tree
  bool known = false;
  // Log-odds of the most and the least occupied known voxel.
  float most = -std::numeric_limits<float>::infinity(), least = std::numeric_limits<float>::infinity();
  const auto take = [&](float log_odds) {
    most = std::max(most, log_odds);
    least = std::min(least, log_odds);
    known = true;
  };
  const unsigned cell = LayerCache::cellIndex(kx, ky);
  for (const BandLayer& band_layer : band_layers_) {
    const unsigned kz = band_layer.kz;
    const LayerCache::Tile* tile = band_layer.cached ? band_layer.cached->tile(kx, ky) : nullptr;
    const float cached = tile ? tile->value[cell] : LayerCache::unloadedValue();
    if (LayerCache::isKnown(cached)) {
      take(cached);
    } else if (LayerCache::isUnloaded(cached)) {  // the tree is current for it (a pruned leaf may hold the whole band)
      if (const octomap::OcTreeNode* node = descent.voxel(kz)) take(node->getLogOdds());
    }
  }
  if (!known) return kUnknownCell;
  // An obstacle more likely than not in any layer blocks the column. Else the column is as free as
  // its best-observed layer: a tilted scan's beams graze the layers beside theirs with the cone's
  // edge, and the weak evidence there (45 %, say) must not hide the layer they crossed (else a
  // degree of tilt turns many free cells grey, unknown to map_server).
  return OccupancyPercent::of(most >= 0.0f ? most : least);
}

std::int8_t SliceGrid::shiftedColumnValue(std::uint16_t kx, std::uint16_t ky, int shift) const {
  bool known = false;
  float most = -std::numeric_limits<float>::infinity(), least = std::numeric_limits<float>::infinity();
  const unsigned cell = LayerCache::cellIndex(kx, ky);
  const int lo = std::max(0, int(band_lo_) + shift), hi = std::min(0xFFFF, int(band_hi_) + shift);
  ColumnDescent descent(*this, kx, ky, unsigned(lo), unsigned(hi));  // as columnValue's
  for (int kz = lo; kz <= hi; ++kz) {
    const LayerCache::Layer* layer = cache_ ? cache_->findLayer(std::uint16_t(kz)) : nullptr;
    const LayerCache::Tile* tile = layer ? layer->tile(kx, ky) : nullptr;
    float value = tile ? tile->value[cell] : LayerCache::unloadedValue();
    if (LayerCache::isUnloaded(value)) {
      const octomap::OcTreeNode* node = descent.voxel(unsigned(kz));
      if (!node) continue;
      value = node->getLogOdds();
    }
    if (!LayerCache::isKnown(value)) continue;
    most = std::max(most, value);
    least = std::min(least, value);
    known = true;
  }
  if (!known) return kUnknownCell;
  return OccupancyPercent::of(most >= 0.0f ? most : least);  // columnValue's rule
}

int SliceGrid::columnShift(std::uint16_t kx, std::uint16_t ky) const {
  if (shift_.empty()) return 0;
  const int i = int(kx) - origin_key_x_, j = int(ky) - origin_key_y_;
  if (!shift_grid_.empty() && i >= 0 && j >= 0 && i < width_ && j < height_) {
    return shift_grid_[std::size_t(j) * width_ + i];
  }
  const auto it = shift_.find(std::uint32_t(kx) | std::uint32_t(ky) << 16);
  return it == shift_.end() ? 0 : std::clamp(it->second, -127, 127);
}

void SliceGrid::fillShiftGrid() {
  if (shift_.empty() || width_ == 0) {
    shift_grid_.clear();
    return;
  }
  shift_grid_.assign(data_.size(), 0);
  for (const auto& [column, shift] : shift_) {
    const int i = int(column & 0xFFFF) - origin_key_x_, j = int(column >> 16) - origin_key_y_;
    if (i >= 0 && j >= 0 && i < width_ && j < height_) {
      shift_grid_[std::size_t(j) * width_ + i] = static_cast<std::int8_t>(std::clamp(shift, -127, 127));
    }
  }
}

void SliceGrid::shiftColumns(const std::vector<std::pair<std::uint32_t, int>>& shifts) {
  if (shifts.empty()) return;
  KeyBox box;
  const auto slot = [](int shift) { return std::size_t(std::clamp(shift, -127, 127) + 127); };
  // A column keeps its value where its shift stays (most of a frame's floor cells: newly known at
  // the fallback's level): only the others are read again.
  std::vector<std::pair<std::uint32_t, int>>& moved = columns_moved_;
  moved.clear();
  for (const auto& [column, shift] : shifts) {
    box.add(octomap::OcTreeKey(std::uint16_t(column & 0xFFFF), std::uint16_t(column >> 16), 0));
    const auto it = shift_.find(column);
    if ((it == shift_.end() ? 0 : it->second) == shift) continue;
    if (it != shift_.end()) {
      --shift_counts_[slot(it->second)];
      if (shift == 0) shift_.erase(it);
      else it->second = shift;
    } else {
      shift_.emplace(column, shift);
    }
    if (shift != 0) ++shift_counts_[slot(shift)];
    moved.emplace_back(column, shift);
  }
  // The bounds from the counts per shift: the shifted columns are many, a batch's changes few.
  shift_min_ = shift_max_ = 0;
  for (std::size_t k = 0; k < shift_counts_.size(); ++k) {
    if (shift_counts_[k] == 0) continue;
    shift_min_ = std::min(shift_min_, int(k) - 127);
    shift_max_ = std::max(shift_max_, int(k) - 127);
  }
  ensureCovers(box.min[0], box.min[1], box.max[0], box.max[1]);
  if (shift_.empty()) {
    shift_grid_.clear();
  } else {
    if (shift_grid_.size() != data_.size()) fillShiftGrid();
    for (const auto& [column, shift] : moved) {
      const int i = int(column & 0xFFFF) - origin_key_x_, j = int(column >> 16) - origin_key_y_;
      shift_grid_[std::size_t(j) * width_ + i] = static_cast<std::int8_t>(std::clamp(shift, -127, 127));
    }
  }
  findBandLayers();
  for (const auto& [column, shift] : moved) {
    const std::uint16_t kx = std::uint16_t(column & 0xFFFF), ky = std::uint16_t(column >> 16);
    data_[std::size_t(ky - origin_key_y_) * width_ + (kx - origin_key_x_)] = columnValue(kx, ky);
  }
}

// Grows the grid (keeping its contents) so that it covers the key rectangle. Growth adds a
// margin proportional to the current size so that a map growing at its edge is re-allocated
// only O(log n) times.
void SliceGrid::ensureCovers(std::uint16_t kx0, std::uint16_t ky0, std::uint16_t kx1, std::uint16_t ky1) {
  if (width_ > 0 && kx0 >= origin_key_x_ && ky0 >= origin_key_y_ && kx1 < origin_key_x_ + width_ &&
      ky1 < origin_key_y_ + height_) {
    return;
  }
  int nx0 = kx0, ny0 = ky0, nx1 = kx1, ny1 = ky1;
  if (width_ > 0) {
    const int margin_x = std::max(16, width_ / 2), margin_y = std::max(16, height_ / 2);
    const int ox0 = origin_key_x_, oy0 = origin_key_y_, ox1 = ox0 + width_ - 1, oy1 = oy0 + height_ - 1;
    nx0 = kx0 < ox0 ? kx0 - margin_x : ox0;
    ny0 = ky0 < oy0 ? ky0 - margin_y : oy0;
    nx1 = kx1 > ox1 ? kx1 + margin_x : ox1;
    ny1 = ky1 > oy1 ? ky1 + margin_y : oy1;
  } else {
    nx0 -= 16, ny0 -= 16, nx1 += 16, ny1 += 16;
  }
  nx0 = std::max(nx0, 0), ny0 = std::max(ny0, 0);
  nx1 = std::min(nx1, 0xFFFF), ny1 = std::min(ny1, 0xFFFF);
  const int new_w = nx1 - nx0 + 1, new_h = ny1 - ny0 + 1;
  std::vector<std::int8_t> grown(std::size_t(new_w) * new_h, kUnknownCell);
  for (int j = 0; j < height_; ++j) {
    const int dst_j = origin_key_y_ + j - ny0;
    std::copy_n(&data_[std::size_t(j) * width_], width_, &grown[std::size_t(dst_j) * new_w + (origin_key_x_ - nx0)]);
  }
  data_.swap(grown);
  geometry_ = nextGeometry();
  origin_key_x_ = static_cast<std::uint16_t>(nx0);
  origin_key_y_ = static_cast<std::uint16_t>(ny0);
  width_ = new_w;
  height_ = new_h;
  fillShiftGrid();
}

void SliceGrid::update(const KeyBox& box) {
  if (box.empty() || !meetsBands(box.min[2], box.max[2])) return;
  ensureCovers(box.min[0], box.min[1], box.max[0], box.max[1]);
  noteLayers(box.min[2], box.max[2]);  // what changed there is not known: read those layers
  recompute(box);
}

void SliceGrid::recompute(const KeyBox& box) {
  findBandLayers();
  for (unsigned ky = box.min[1]; ky <= box.max[1]; ++ky) {
    std::int8_t* row = &data_[std::size_t(ky - origin_key_y_) * width_];
    for (unsigned kx = box.min[0]; kx <= box.max[0]; ++kx) {
      row[kx - origin_key_x_] = columnValue(static_cast<std::uint16_t>(kx), static_cast<std::uint16_t>(ky));
    }
  }
}

void SliceGrid::updateColumns(const std::vector<octomap::OcTreeKey>& keys, const KeyBox& box,
                              const std::vector<VoxelChange>& changes) {
  if (box.empty() || !meetsBands(box.min[2], box.max[2])) return;
  ensureCovers(box.min[0], box.min[1], box.max[0], box.max[1]);
  const bool with_changes = changes.size() == keys.size();
  const OccupancyPercent& percent = OccupancyPercent::table();
  // Each column read once, however many of its voxels changed (a tilted scan's or a cloud's keys
  // lie in several layers; a depth frame changes up to all 16 layers of the navigation band in a
  // column): a column is listed when first met and its cell marked kPendingCell until recomputed (a
  // sort of the columns was a sixth of a tilted scan's slice update). A column that follows a
  // change from its own cell is not read at all: the changes are taken in order, each from the
  // value the ones before it left (each voxel changes once per call), and a column that must be
  // read is read at the end, when all its voxels hold their new values.
  std::vector<std::uint32_t>& columns = columns_;  // reused: no allocation per scan
  columns.clear();
  // The box's layers, once: per key, a tilted scan's 2 000 changed voxels marked them 2 000
  // times. (A layer of the box no key reached is read in vain, never wrongly: it may be known.)
  noteLayers(box.min[2], box.max[2]);
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const octomap::OcTreeKey& k = keys[i];
    const int shift = shift_.empty() ? 0 : columnShift(k[0], k[1]);
    if (int(k[2]) < int(band_lo_) + shift || int(k[2]) > int(band_hi_) + shift) continue;
    const std::uint32_t index = std::uint32_t(k[1] - origin_key_y_) * std::uint32_t(width_) + (k[0] - origin_key_x_);
    std::int8_t& cell = data_[index];
    if (cell == kPendingCell) continue;
    if (with_changes) {
      const std::int8_t after = followChange(cell, changes[i], percent);
      if (after != kPendingCell) {
        cell = after;
        continue;
      }
    }
    cell = kPendingCell;
    columns.push_back(index);
  }
  findBandLayers();
  for (std::uint32_t index : columns) {
    const std::uint16_t kx = std::uint16_t(origin_key_x_ + index % std::uint32_t(width_));
    const std::uint16_t ky = std::uint16_t(origin_key_y_ + index / std::uint32_t(width_));
    data_[index] = columnValue(kx, ky);
  }
}

std::int8_t SliceGrid::columnAfter(std::int8_t value, const VoxelChange& change) {
  return followChange(value, change, OccupancyPercent::table());
}

void SliceGrid::rebuild() {
  clear();
  // Each band leaf's column rectangle (a pruned leaf spans several keys: its whole extent).
  std::vector<KeyBox> columns;
  KeyBox box;
  for (auto it = tree_.begin_leafs(), end = tree_.end_leafs(); it != end; ++it) {
    const octomap::OcTreeKey k = it.getKey();
    const unsigned span = 1u << (tree_.getTreeDepth() - it.getDepth());
    const unsigned base_mask = ~(span - 1);
    octomap::OcTreeKey lo(k[0] & base_mask, k[1] & base_mask, k[2] & base_mask);
    if (!meetsBands(lo[2], lo[2] + span - 1)) continue;
    noteLayers(lo[2], lo[2] + span - 1);
    KeyBox leaf;
    leaf.add(lo);
    leaf.add(octomap::OcTreeKey(lo[0] + span - 1, lo[1] + span - 1, lo[2] + span - 1));
    box.add(leaf.min);
    box.add(leaf.max);
    columns.push_back(leaf);
  }
  // The cache's layers may hold voxels the tree doesn't have yet.
  bool cached_layers = false;
  for (unsigned kz = band_lo_; kz <= band_hi_; ++kz) {
    if (cache_ && cache_->findLayer(static_cast<std::uint16_t>(kz))) noteLayers(kz, kz), cached_layers = true;
  }
  if (box.empty()) return;
  const std::size_t cells = std::size_t(box.max[0] - box.min[0] + 1) * std::size_t(box.max[1] - box.min[1] + 1);
  if (cells > options_.max_cells) {
    // A loaded map whose band spans kilometres (or a damaged one) would take gigabytes and minutes.
    throw std::length_error("the slice would need " + std::to_string(cells) + " cells (" +
                            std::to_string(int((box.max[0] - box.min[0] + 1) * resolution_)) + " x " +
                            std::to_string(int((box.max[1] - box.min[1] + 1) * resolution_)) +
                            " m), more than the limit of " + std::to_string(options_.max_cells));
  }
  ensureCovers(box.min[0], box.min[1], box.max[0], box.max[1]);
  if (cached_layers) {
    recompute(box);
    return;
  }
  // Only the columns some leaf reaches: sparse maps far apart cost their leaves, not their area.
  findBandLayers();
  for (const KeyBox& leaf : columns) {
    for (unsigned ky = leaf.min[1]; ky <= leaf.max[1]; ++ky) {
      std::int8_t* row = &data_[std::size_t(ky - origin_key_y_) * width_];
      std::fill(row + (leaf.min[0] - origin_key_x_), row + (leaf.max[0] - origin_key_x_) + 1, kPendingCell);
    }
  }
  for (unsigned ky = box.min[1]; ky <= box.max[1]; ++ky) {
    std::int8_t* row = &data_[std::size_t(ky - origin_key_y_) * width_];
    for (unsigned kx = box.min[0]; kx <= box.max[0]; ++kx) {
      std::int8_t& cell = row[kx - origin_key_x_];
      if (cell == kPendingCell) cell = columnValue(static_cast<std::uint16_t>(kx), static_cast<std::uint16_t>(ky));
    }
  }
}

}  // namespace octo_slice_mapper
