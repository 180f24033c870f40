#include "octo_slice_mapper/internal/floor_layer.h"

#include <algorithm>
#include <limits>
#include <unordered_set>
#include <utility>

namespace octo_slice_mapper {

const char* floorSourceName(FloorSource source) {
  switch (source) {
    case FloorSource::kFound:
      return "found in the frame";
    case FloorSource::kKept:
      return "kept from an earlier frame";
    default:
      return "assumed at the fixed frame's z = 0";
  }
}

namespace {

// A tile that knows no cell (its version's `since` is the caller's to set).
std::shared_ptr<FloorView::Tile> blankTile() {
  auto tile = std::make_shared<FloorView::Tile>();
  std::fill(std::begin(tile->height), std::end(tile->height), std::numeric_limits<float>::quiet_NaN());
  std::fill(std::begin(tile->weight), std::end(tile->weight), std::uint8_t{0});
  return tile;
}

}  // namespace

FloorLayer::FloorLayer(double resolution, const FloorOptions& options)
    : resolution_(resolution), inverse_resolution_(1.0 / resolution), options_(options) {
  known_[0] = Known();
}

void FloorLayer::reset(double resolution) {
  std::lock_guard<std::mutex> lock(mutex_);
  resolution_ = resolution;
  inverse_resolution_ = 1.0 / resolution;
  tiles_.clear();
  last_plane_.reset();
  fallback_found_ = false;
  fallback_height_ = 0.0;
  const bool moved = fallback_level_ != 0;
  fallback_level_ = 0;
  pending_ = LevelChanges();
  due_.clear();
  pending_.fallback_changed = moved;
  makeDue();
  status_ = FloorStatus();
  // Frames still to come keep their numbers and turns; they are measured against the empty layer.
  known_.clear();
  known_[folded_] = Known();
  reset_at_ = folded_;
}

void FloorLayer::restore(const std::vector<std::pair<std::uint32_t, float>>& cells, double fallback_height) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int level_before = fallback_level_;
  fallback_found_ = true;
  fallback_height_ = fallback_height;
  fallback_level_ = levelOf(fallback_height);
  // Level everywhere: where no cell is known, the floor stands at the fallback's height.
  FloorPlane level;
  level.d = -fallback_height;
  const double far = 1e9;
  last_plane_ = BoundedPlane{level, Eigen::Vector2d::Constant(-far), Eigen::Vector2d::Constant(far)};
  for (const auto& [cell, height] : cells) {
    if (!std::isfinite(height)) continue;
    const int kx = int(cell & 0xffff), ky = int(cell >> 16);
    std::shared_ptr<Tile>& tile = tiles_[tileId(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits)];
    if (!tile) {
      tile = blankTile();
      tile->since = folded_;  // what every frame to come is measured against
    }
    const int i = FloorView::indexInTile(kx, ky);
    if (std::isnan(tile->height[i])) status_.cells++;
    tile->height[i] = height;
    tile->weight[i] = 1;
  }
  pending_.cells.clear();
  pending_.fallback_changed = pending_.fallback_changed || fallback_level_ != level_before;
  relevel();
  makeDue();
  status_.source = FloorSource::kKept;
  status_.height = fallback_height;
  known_[folded_] = Known{last_plane_, fallback_found_, fallback_height_};
}

void FloorLayer::setOptions(const FloorOptions& options) {
  std::lock_guard<std::mutex> lock(mutex_);
  options_ = options;
}

double FloorLayer::resolution() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return resolution_;
}

FloorStatus FloorLayer::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}

double FloorLayer::fallbackHeight() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return fallback_found_ ? fallback_height_ : 0.0;
}

int FloorLayer::fallbackLevel() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return fallback_level_;
}

void FloorLayer::makeDue() {
  LevelChanges& due = due_[folded_];
  due.cells.insert(due.cells.end(), pending_.cells.begin(), pending_.cells.end());
  due.fallback_changed = due.fallback_changed || pending_.fallback_changed;
  due.fallback_level = fallback_level_;
  pending_ = LevelChanges();
}

FloorLayer::LevelChanges FloorLayer::takeLevelChanges(std::optional<std::uint64_t> folded) {
  std::lock_guard<std::mutex> lock(mutex_);
  LevelChanges taken;
  const auto end = folded ? due_.upper_bound(*folded) : due_.end();
  for (auto it = due_.begin(); it != end; ++it) {
    taken.cells.insert(taken.cells.end(), it->second.cells.begin(), it->second.cells.end());
    taken.fallback_changed = taken.fallback_changed || it->second.fallback_changed;
    taken_level_ = it->second.fallback_level;
  }
  due_.erase(due_.begin(), end);
  taken.fallback_level = taken_level_;
  return taken;
}

const FloorLayer::Tile* FloorLayer::tileAsOf(std::uint32_t id, std::uint64_t folded) const {
  const auto it = tiles_.find(id);
  const Tile* tile = it == tiles_.end() ? nullptr : it->second.get();
  while (tile && tile->since > folded) tile = tile->before.get();
  return tile;
}

std::shared_ptr<const FloorLayer::Tile> FloorLayer::sharedTileAsOf(std::uint32_t id, std::uint64_t folded) const {
  const auto it = tiles_.find(id);
  std::shared_ptr<const Tile> tile;
  if (it != tiles_.end()) tile = it->second;
  while (tile && tile->since > folded) tile = tile->before;
  return tile;
}

// A tile is written in a new version once per fold: views and frames still to be measured
// against an older layer keep theirs. Versions no frame to come can be measured against are let go.
FloorLayer::Tile& FloorLayer::writableTile(int tx, int ty) {
  std::shared_ptr<Tile>& tile = tiles_[tileId(tx, ty)];
  if (!tile) {
    tile = blankTile();
    tile->since = folded_ + 1;
  } else if (tile->since != folded_ + 1) {
    auto copy = std::make_shared<Tile>(*tile);
    copy->since = folded_ + 1;
    copy->before = std::move(tile);
    tile = std::move(copy);
    // The frames still to fold (folded_ + 1 on) are measured against the layer after at least
    // folded_ + 2 - kLag frames.
    const std::uint64_t oldest = folded_ + 2 >= kLag ? folded_ + 2 - kLag : 0;
    for (const Tile* v = tile.get(); v; v = v->before.get()) {
      if (v->since <= oldest) {
        v->before.reset();
        break;
      }
    }
  }
  return *tile;
}

void FloorLayer::setCell(int kx, int ky, const BoundedPlane& plane, bool seen, LastTile* last) {
  const int i = FloorView::indexInTile(kx, ky);
  const int tx = kx >> FloorView::kTileBits, ty = ky >> FloorView::kTileBits;
  const std::uint32_t id = tileId(tx, ty);
  if (last->id != id) {
    const auto it = tiles_.find(id);
    last->id = id;
    last->tile = it == tiles_.end() ? nullptr : it->second.get();
    last->writable = last->tile && last->tile->since == folded_ + 1;
  }
  if (!seen && last->tile && !std::isnan(last->tile->height[i])) return;  // only where nothing is known yet
  if (!last->writable) {
    last->tile = &writableTile(tx, ty);
    last->writable = true;
  }
  Tile& tile = *last->tile;
  const double measured = heightAtCell(plane, kx, ky);
  const float before = tile.height[i];
  float after;
  if (!seen) {
    after = static_cast<float>(measured);
    tile.weight[i] = 0;
    status_.cells++;
  } else {
    after = static_cast<float>(measuredMean(before, tile.weight[i], measured, options_));
    if (std::isnan(before)) status_.cells++;
    tile.weight[i] = replaces(before, tile.weight[i], measured, options_)
                         ? std::uint8_t{1}
                         : static_cast<std::uint8_t>(std::min(tile.weight[i] + 1, std::clamp(options_.memory_frames, 1, 255)));
  }
  tile.height[i] = after;
  if (std::isnan(before) || levelOf(before) != levelOf(after)) {
    pending_.cells.emplace_back(std::uint32_t(kx) | std::uint32_t(ky) << 16, levelOf(after));
  }
}

void FloorLayer::relevel() {
  for (const auto& [id, tile] : tiles_) {
    for (int i = 0; i < FloorView::kTileSize * FloorView::kTileSize; ++i) {
      if (std::isnan(tile->height[i])) continue;
      pending_.cells.emplace_back(std::uint32_t(keyXOf(id, i)) | std::uint32_t(keyYOf(id, i)) << 16,
                                  levelOf(tile->height[i]));
    }
  }
}

double FloorLayer::highestFloorAt(double x, double y, std::uint64_t folded, double otherwise,
                                  const FloorOptions& options) const {
  const int kx = floorKeyScaled(x, inverse_resolution_), ky = floorKeyScaled(y, inverse_resolution_);
  const Tile* tile =
      kx < 0 || ky < 0 ? nullptr : tileAsOf(tileId(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits), folded);
  const int i = FloorView::indexInTile(kx, ky);
  if (!tile || std::isnan(tile->height[i])) return otherwise + options.max_rise;
  // A floor only followed from a plane (weight 0) is known no better than that plane, which a fit
  // a few degrees off level puts centimetres off at the sensor: there max_rise holds.
  return tile->height[i] + (tile->weight[i] > 0 ? std::min(options.max_rise, options.max_step) : options.max_rise);
}

bool FloorLayer::aboveKnownFloor(const BoundedPlane& plane, bool grounded, bool reached, const Eigen::Vector3d& sensor,
                                 const Known& known, std::uint64_t folded, const FloorOptions& options) const {
  if (grounded || reached || !known.fallback_found || !known.last_plane) return false;
  const double highest =
      highestFloorAt(sensor.x(), sensor.y(), folded, known.last_plane->heightAt(sensor.x(), sensor.y()), options);
  return plane.heightAt(sensor.x(), sensor.y()) > highest;
}

bool FloorLayer::belowKnownFloor(const BoundedPlane& plane, bool grounded, const Eigen::Vector3d& sensor,
                                 const Known& known, const FloorOptions& options) {
  return !grounded && known.fallback_found &&
         plane.heightAt(sensor.x(), sensor.y()) < known.fallback_height - options.fit.seed_window;
}

std::uint64_t FloorLayer::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  return taken_++;
}

void FloorLayer::pass(std::uint64_t frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (frame < folded_ || waiting_.count(frame)) return;
  waiting_.emplace(frame, Fold());
  foldReady();
}

namespace {

// The keys (floorKeyScaled: -1 outside the key range) of the square within `reach` (m, at most
// 1 km) of the sensor: a frame's view, and the columns its floor speaks for.
struct KeyWindow {
  int x0, y0, x1, y1;
};
KeyWindow reachWindow(const Eigen::Vector3d& sensor, double reach, double inverse_resolution) {
  const double r = std::min(reach, 1000.0);
  return {floorKeyScaled(sensor.x() - r, inverse_resolution), floorKeyScaled(sensor.y() - r, inverse_resolution),
          floorKeyScaled(sensor.x() + r, inverse_resolution), floorKeyScaled(sensor.y() + r, inverse_resolution)};
}

// Which cells of a box (cover() every cell first, then allocate()) were taken: a grid of flags,
// cheaper than sorting a frame's cells to take each once; a set where the box is too large for a
// grid (kMaxCells: a reach beyond about 50 m at 5 cm).
struct CellSet {
  static constexpr std::size_t kMaxCells = std::size_t(1) << 22;  // 4 MB of flags: 100 m square at 5 cm
  int x0 = 65535, y0 = 65535, x1 = -1, y1 = -1;
  bool clamped = false;  // keys outside the box may come, and are left out
  bool far = false;      // the set, not the grid
  std::vector<std::uint8_t> taken;
  std::unordered_set<std::uint32_t> taken_far;
  void cover(int kx, int ky) {
    x0 = std::min(x0, kx), x1 = std::max(x1, kx), y0 = std::min(y0, ky), y1 = std::max(y1, ky);
  }
  // Keeps the box within [wx0, wx1] x [wy0, wy1].
  void clamp(int wx0, int wy0, int wx1, int wy1) {
    if (x0 >= wx0 && y0 >= wy0 && x1 <= wx1 && y1 <= wy1) return;
    x0 = std::max(x0, wx0), y0 = std::max(y0, wy0), x1 = std::min(x1, wx1), y1 = std::min(y1, wy1);
    clamped = true;
  }
  std::size_t area() const {
    return x1 < x0 || y1 < y0 ? 0 : std::size_t(x1 - x0 + 1) * std::size_t(y1 - y0 + 1);
  }
  void allocate() {
    far = area() > kMaxCells;
    taken.assign(far ? 0 : area(), 0);
  }
  // Appends the cells (key x | key y << 16; kNone: none) keys[index(0)], ..., keys[index(count -
  // 1)] in the box and not taken yet to `out`, in order, and takes them. Without a branch on
  // whether a cell is new where the box holds every key: a frame's voxels come back to a column at
  // no predictable step.
  template <typename Index>
  void takeNew(const std::vector<std::uint32_t>& keys, std::size_t count, Index index, std::vector<std::uint32_t>* out) {
    if (far || clamped) {
      for (std::size_t c = 0; c < count; ++c) {
        const std::uint32_t k = keys[index(c)];
        const int kx = int(k & 0xffff), ky = int(k >> 16);
        if (k == kNone || kx < x0 || kx > x1 || ky < y0 || ky > y1) continue;
        const bool fresh = far ? taken_far.insert(k).second : !std::exchange(taken[index2(kx, ky)], std::uint8_t{1});
        if (fresh) out->push_back(k);
      }
      return;
    }
    out->resize(count);
    std::size_t n = 0;
    // (The box in locals: a store through the flags' bytes may alias the members.)
    const int bx = x0, by = y0;
    const std::size_t width = std::size_t(x1 - x0 + 1);
    std::uint8_t* flags = taken.data();
    for (std::size_t c = 0; c < count; ++c) {
      const std::uint32_t k = keys[index(c)];
      if (k == kNone) continue;
      std::uint8_t& t = flags[std::size_t(int(k >> 16) - by) * width + std::size_t(int(k & 0xffff) - bx)];
      (*out)[n] = k;
      n += t ^ 1;
      t = 1;
    }
    out->resize(n);
  }
  std::size_t index2(int kx, int ky) const {
    return std::size_t(ky - y0) * std::size_t(x1 - x0 + 1) + std::size_t(kx - x0);
  }
  static constexpr std::uint32_t kNone = 0xffffffff;
};

// Whether the frame's returns climb from the floor known (`base`) up to `raised` without a step:
// per cell of the frame, its lowest return; from the cells on `base` (within `band`), a cell is
// reached from a neighbour reached when their lowest returns differ by at most `climb`. A ramp is
// such a surface; a table's, a box's or a step's top is not (its edge rises at once). True when a
// cell on `raised` and more than `rise` above `base` is reached.
bool climbsTo(const std::vector<Eigen::Vector3d>& samples, const std::vector<std::uint32_t>& keys, const CellSet& box,
              const BoundedPlane& base, const FloorPlane& raised, double band, double climb, double rise,
              double resolution) {
  // A frame whose returns spread over more than CellSet::kMaxCells (stray far returns) is not
  // searched: the table rule then holds as without the search.
  if (box.area() == 0 || box.area() > CellSet::kMaxCells) return false;
  const int w = box.x1 - box.x0 + 1, h = box.y1 - box.y0 + 1;
  std::vector<float> lowest(std::size_t(w) * std::size_t(h), std::numeric_limits<float>::infinity());
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const std::uint32_t k = keys[i];
    const int kx = int(k & 0xffff), ky = int(k >> 16);
    if (k == CellSet::kNone || kx < box.x0 || kx > box.x1 || ky < box.y0 || ky > box.y1) continue;
    float& z = lowest[box.index2(kx, ky)];
    z = std::min(z, static_cast<float>(samples[i].z()));
  }
  std::vector<std::uint8_t> reached(lowest.size(), 0);
  std::vector<int> queue;
  const auto xOf = [&](int x) { return floorCentreOf(box.x0 + x, resolution); };
  const auto yOf = [&](int y) { return floorCentreOf(box.y0 + y, resolution); };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t c = std::size_t(y) * w + x;
      if (!std::isfinite(lowest[c])) continue;
      if (std::abs(lowest[c] - base.heightAt(xOf(x), yOf(y))) <= band) {
        reached[c] = 1;
        queue.push_back(int(c));
      }
    }
  }
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const int c = queue[q], x = c % w, y = c / w;
    const double px = xOf(x), py = yOf(y);
    if (std::abs(raised.heightAt(px, py) - lowest[std::size_t(c)]) <= band &&
        lowest[std::size_t(c)] - base.heightAt(px, py) > rise) {
      return true;
    }
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const std::size_t n = std::size_t(ny) * w + nx;
        if (reached[n] || !std::isfinite(lowest[n]) || std::abs(lowest[n] - lowest[std::size_t(c)]) > climb) continue;
        reached[n] = 1;
        queue.push_back(int(n));
      }
    }
  }
  return false;
}

}  // namespace

FloorLayer::Fold FloorLayer::measure(const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples,
                                     const std::vector<std::uint32_t>* cells_given, const Known& known,
                                     const FloorOptions& options, double inverse_resolution, double reach,
                                     const std::optional<Eigen::Vector3d>& ground) const {
  Fold fold;
  fold.observed = true;
  fold.sensor = sensor;
  if (!options.find) return fold;
  const std::optional<FloorFit> fit =
      fitFloor(samples, sensor, known.last_plane ? std::optional<FloorPlane>(known.last_plane->plane) : std::nullopt,
               options.fit, ground, options.max_step);
  if (!fit) return fold;
  fold.plane = BoundedPlane::of(*fit, options.extrapolation);
  fold.grounded = ground.has_value();
  // The cells it speaks for: where its floor returns lie, and every other column it saw.
  constexpr std::uint32_t kNone = CellSet::kNone;
  const bool given = cells_given && cells_given->size() == samples.size();
  std::vector<std::uint32_t> computed;
  if (!given) {
    computed.resize(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const int kx = floorKeyScaled(samples[i].x(), inverse_resolution), ky = floorKeyScaled(samples[i].y(), inverse_resolution);
      computed[i] = kx >= 0 && ky >= 0 ? std::uint32_t(kx) | std::uint32_t(ky) << 16 : kNone;
    }
  }
  const std::vector<std::uint32_t>& keys = given ? *cells_given : computed;
  // Only the columns within `reach` of the sensor (the view's window): returns beyond the sensor's
  // range are cut, and one stray return a kilometre off would otherwise give the slice a column
  // there.
  CellSet cells;
  for (std::uint32_t k : keys) {
    if (k != kNone) cells.cover(int(k & 0xffff), int(k >> 16));
  }
  if (reach > 0.0) {
    const KeyWindow w = reachWindow(sensor, reach, inverse_resolution);
    cells.clamp(std::max(0, w.x0), std::max(0, w.y0), w.x1 < 0 ? 65535 : w.x1, w.y1 < 0 ? 65535 : w.y1);
  }
  cells.allocate();
  cells.takeNew(keys, fit->inliers.size(), [&](std::size_t c) { return fit->inliers[c]; }, &fold.floor_cells);
  cells.takeNew(keys, keys.size(), [](std::size_t c) { return c; }, &fold.other_cells);
  // A plane above the last floor found may be a platform the frame sees a ramp climb to: the table
  // rule spares it then. Only such frames pay for the search. The climb allowed per cell is half a
  // step: a rise that would mark cannot be climbed in one cell, nor in two across an edge's mixed
  // column (its lowest return halfway up). A ramp of 1 in 12 climbs 0.4 cm per 5 cm cell.
  if (known.last_plane && !fold.grounded &&
      fold.plane->heightAt(sensor.x(), sensor.y()) >
          known.last_plane->heightAt(sensor.x(), sensor.y()) + options.fit.inlier_distance) {
    fold.reached = climbsTo(samples, keys, cells, *known.last_plane, fit->plane, options.fit.inlier_distance,
                            0.5 * options.max_step, options.max_step, 1.0 / inverse_resolution);
  }
  return fold;
}

FloorView FloorLayer::observe(std::uint64_t frame, const Eigen::Vector3d& sensor,
                              const std::vector<Eigen::Vector3d>& samples, double reach,
                              const std::vector<std::uint32_t>* cells,
                              const std::optional<Eigen::Vector3d>& ground) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool fresh = frame >= folded_ && !waiting_.count(frame);
  std::uint64_t folded = folded_;
  if (fresh) {
    // (After a reset, as in a new layer: the frames before it are not waited for.)
    folded = std::max(frame + 1 >= kLag ? frame + 1 - kLag : 0, reset_at_);
    folded_more_.wait(lock, [&] { return folded_ >= folded; });
  }
  auto known_it = known_.find(folded);
  if (known_it == known_.end()) {  // reset meanwhile: the layer as it is
    folded = folded_;
    known_it = known_.find(folded);
  }
  const Known known = known_it->second;
  const FloorOptions options = options_;
  const double inverse_resolution = inverse_resolution_;
  lock.unlock();

  Fold measured = measure(sensor, samples, cells, known, options, inverse_resolution, reach, ground);

  lock.lock();
  // Once a floor is known, a level surface well above it is not the floor (FloorOptions::max_rise,
  // max_step).
  if (measured.plane &&
      aboveKnownFloor(*measured.plane, measured.grounded, measured.reached, sensor, known, folded, options)) {
    measured.plane.reset();
    measured.floor_cells.clear();
    measured.other_cells.clear();
  }
  FloorView view;
  view.inverse_resolution_ = inverse_resolution;
  view.plane_ = measured.plane ? measured.plane : known.last_plane;  // this frame's, or the last one found
  // A floor found well below the one known (what was taken for the floor was a table): the
  // cells known are not this frame's floor.
  const bool lower = measured.plane && belowKnownFloor(*measured.plane, measured.grounded, sensor, known, options);
  // The rectangle even where nothing is known: the frame's own measurements go into it below.
  if (reach > 0.0) {
    const KeyWindow w = reachWindow(sensor, reach, inverse_resolution);
    const int kx0 = w.x0, kx1 = w.x1, ky0 = w.y0, ky1 = w.y1;
    if (kx0 >= 0 && kx1 >= 0 && ky0 >= 0 && ky1 >= 0) {
      view.tx0_ = kx0 >> FloorView::kTileBits, view.ty0_ = ky0 >> FloorView::kTileBits;
      view.tiles_x_ = (kx1 >> FloorView::kTileBits) - view.tx0_ + 1;
      view.tiles_y_ = (ky1 >> FloorView::kTileBits) - view.ty0_ + 1;
      view.tiles_.resize(std::size_t(view.tiles_x_) * view.tiles_y_);
      for (int ty = 0; ty < view.tiles_y_; ++ty) {
        for (int tx = 0; tx < view.tiles_x_; ++tx) {
          if (!lower) view.tiles_[std::size_t(ty) * view.tiles_x_ + tx] = sharedTileAsOf(tileId(view.tx0_ + tx, view.ty0_ + ty), folded);
        }
      }
    }
  }
  const double resolution = resolution_;
  lock.unlock();

  // The frame's own floor measurements, as its fold will make them, in copies of the view's
  // tiles: where it sees the floor it is measured against what it sees.
  if (measured.plane && !view.tiles_.empty()) {
    std::vector<std::shared_ptr<Tile>> own(view.tiles_.size());
    const int window_x = view.tiles_x_ << FloorView::kTileBits, window_y = view.tiles_y_ << FloorView::kTileBits;
    const int kx0 = view.tx0_ << FloorView::kTileBits, ky0 = view.ty0_ << FloorView::kTileBits;
    for (std::uint32_t c : measured.floor_cells) {
      const int kx = int(c & 0xffff), ky = int(c >> 16);
      if (kx < kx0 || ky < ky0 || kx >= kx0 + window_x || ky >= ky0 + window_y) continue;
      const std::size_t t = std::size_t((ky >> FloorView::kTileBits) - view.ty0_) * view.tiles_x_ +
                            std::size_t((kx >> FloorView::kTileBits) - view.tx0_);
      if (!own[t]) {
        own[t] = view.tiles_[t] ? std::make_shared<Tile>(*view.tiles_[t]) : blankTile();
        own[t]->before.reset();  // the data only: no versions
        view.tiles_[t] = own[t];
      }
      Tile& tile = *own[t];
      const int i = FloorView::indexInTile(kx, ky);
      const double h = measured.plane->heightAt(floorCentreOf(kx, resolution), floorCentreOf(ky, resolution));
      tile.height[i] = static_cast<float>(measuredMean(tile.height[i], tile.weight[i], h, options));
    }
  }
  if (fresh) {
    lock.lock();
    if (frame >= folded_ && !waiting_.count(frame)) {  // (not passed meanwhile)
      waiting_.emplace(frame, std::move(measured));
      foldReady();
    }
  }
  return view;
}

void FloorLayer::foldReady() {
  bool any = false;
  for (auto it = waiting_.find(folded_); it != waiting_.end(); it = waiting_.find(folded_)) {
    fold(it->second);
    waiting_.erase(it);
    ++folded_;
    if (!pending_.cells.empty() || pending_.fallback_changed) makeDue();
    known_[folded_] = Known{last_plane_, fallback_found_, fallback_height_};
    // Frames from folded_ on are measured against the layer after folded_ + 1 - kLag frames or more.
    const std::uint64_t oldest = folded_ + 1 >= kLag ? folded_ + 1 - kLag : 0;
    known_.erase(known_.begin(), known_.lower_bound(oldest));
    any = true;
  }
  if (any) folded_more_.notify_all();
}

void FloorLayer::fold(const Fold& frame) {
  if (!frame.observed) return;
  const Eigen::Vector3d& sensor = frame.sensor;
  std::optional<BoundedPlane> found = frame.plane;
  const Known now{last_plane_, fallback_found_, fallback_height_};
  // The table rule again, against the layer now: frames folded in since it was measured may have
  // found the floor.
  if (found && aboveKnownFloor(*found, frame.grounded, frame.reached, sensor, now, ~std::uint64_t{0}, options_)) {
    found.reset();
  }
  if (!found) {
    status_.source = fallback_found_ ? FloorSource::kKept : FloorSource::kAssumed;
    status_.height = last_plane_ ? last_plane_->heightAt(sensor.x(), sensor.y()) : 0.0;
    status_.frames_without++;
    return;
  }
  const BoundedPlane& plane = *found;
  const double height = plane.heightAt(sensor.x(), sensor.y());
  // A floor found well below the one known: what was taken for the floor was a table or a bed.
  if (belowKnownFloor(plane, frame.grounded, sensor, now, options_)) {
    std::vector<std::uint32_t> ids;
    for (const auto& entry : tiles_) ids.push_back(entry.first);
    for (std::uint32_t id : ids) {
      for (int i = 0; i < FloorView::kTileSize * FloorView::kTileSize; ++i) {
        const float h = tiles_[id]->height[i];
        if (std::isnan(h)) continue;
        const int kx = keyXOf(id, i), ky = keyYOf(id, i);
        if (h <= heightAtCell(plane, kx, ky) + options_.fit.seed_window) continue;
        Tile& tile = writableTile(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits);
        tile.height[i] = std::numeric_limits<float>::quiet_NaN();
        tile.weight[i] = 0;
        status_.cells--;
        pending_.cells.emplace_back(std::uint32_t(kx) | std::uint32_t(ky) << 16, kNoLevel);
      }
    }
  }
  // The level where no cell is known. Known cells keep theirs: a cell's level is its own floor's
  // (levelOf), and the map shifts its columns against the new fallback itself.
  const int level = levelOf(height);
  if (!fallback_found_ || std::abs(level - fallback_level_) >= 2) {
    if (level != fallback_level_) {
      fallback_level_ = level;
      pending_.fallback_changed = true;
    }
  }
  fallback_found_ = true;
  fallback_height_ = height;
  // One measurement per cell per frame: the plane's height at the cells its inliers lie in.
  LastTile last;
  for (std::uint32_t c : frame.floor_cells) setCell(int(c & 0xffff), int(c >> 16), plane, true, &last);
  // Columns the frame saw something else in (a wall, a step, a table's legs) and no floor was
  // ever seen under: the plane's height there, until a floor is seen (weight 0). Their slice
  // band then follows the floor around them, not the floor under the sensor.
  for (std::uint32_t c : frame.other_cells) setCell(int(c & 0xffff), int(c >> 16), plane, false, &last);
  last_plane_ = plane;
  status_.source = FloorSource::kFound;
  status_.height = height;
  status_.tilt = plane.plane.tilt();
  status_.frames_found++;
}

void FloorLayer::forEachCell(const std::function<void(std::uint16_t, std::uint16_t, float)>& fn) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, tile] : tiles_) {
    for (int i = 0; i < FloorView::kTileSize * FloorView::kTileSize; ++i) {
      if (!std::isnan(tile->height[i])) fn(std::uint16_t(keyXOf(id, i)), std::uint16_t(keyYOf(id, i)), tile->height[i]);
    }
  }
}

}  // namespace octo_slice_mapper
