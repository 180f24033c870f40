#include "octo_slice_mapper/internal/floor_layer.h"

#include <algorithm>
#include <limits>

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

double FloorView::heightAt(double x, double y) const {
  if (!tiles_.empty()) {
    const int kx = floorKeyOf(x, resolution_), ky = floorKeyOf(y, resolution_);
    const int tx = (kx >> kTileBits) - tx0_, ty = (ky >> kTileBits) - ty0_;
    if (kx >= 0 && ky >= 0 && tx >= 0 && ty >= 0 && tx < tiles_x_ && ty < tiles_y_) {
      if (const Tile* tile = tiles_[std::size_t(ty) * tiles_x_ + tx].get()) {
        const float h = tile->height[indexInTile(kx, ky)];
        if (!std::isnan(h)) return h;
      }
    }
  }
  return plane_ ? plane_->heightAt(x, y) : 0.0;
}

FloorLayer::FloorLayer(double resolution, const FloorOptions& options) : resolution_(resolution), options_(options) {}

void FloorLayer::reset(double resolution) {
  std::lock_guard<std::mutex> lock(mutex_);
  resolution_ = resolution;
  tiles_.clear();
  last_plane_.reset();
  fallback_found_ = false;
  fallback_height_ = 0.0;
  const bool moved = fallback_level_ != 0;
  fallback_level_ = 0;
  pending_ = LevelChanges();
  pending_.fallback_changed = moved;
  status_ = FloorStatus();
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

FloorLayer::LevelChanges FloorLayer::takeLevelChanges() {
  std::lock_guard<std::mutex> lock(mutex_);
  LevelChanges taken = std::move(pending_);
  pending_ = LevelChanges();
  taken.fallback_level = fallback_level_;
  return taken;
}

// A view holding a tile keeps it as it was: the layer writes into a copy (copy on write).
FloorLayer::Tile& FloorLayer::writableTile(int tx, int ty) {
  std::shared_ptr<Tile>& tile = tiles_[tileId(tx, ty)];
  if (!tile) {
    tile = std::make_shared<Tile>();
    std::fill(std::begin(tile->height), std::end(tile->height), std::numeric_limits<float>::quiet_NaN());
    std::fill(std::begin(tile->weight), std::end(tile->weight), std::uint8_t{0});
  } else if (tile.use_count() > 1) {
    tile = std::make_shared<Tile>(*tile);
  }
  return *tile;
}

void FloorLayer::setCell(int kx, int ky, double measured, bool seen) {
  const int i = FloorView::indexInTile(kx, ky);
  if (!seen) {  // only where nothing is known yet
    const auto it = tiles_.find(tileId(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits));
    if (it != tiles_.end() && !std::isnan(it->second->height[i])) return;
  }
  Tile& tile = writableTile(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits);
  const float before = tile.height[i];
  float after;
  if (!seen) {
    after = static_cast<float>(measured);
    tile.weight[i] = 0;
    status_.cells++;
  } else if (std::isnan(before) || tile.weight[i] == 0 || std::abs(measured - before) > options_.fit.seed_window) {
    after = static_cast<float>(measured);
    tile.weight[i] = 1;
    if (std::isnan(before)) status_.cells++;
  } else {
    const int w = tile.weight[i];
    after = static_cast<float>((before * w + measured) / (w + 1));
    tile.weight[i] = static_cast<std::uint8_t>(std::min(w + 1, std::clamp(options_.memory_frames, 1, 255)));
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

double FloorLayer::knownHeightAt(double x, double y, double otherwise) const {
  const int kx = floorKeyOf(x, resolution_), ky = floorKeyOf(y, resolution_);
  if (kx < 0 || ky < 0) return otherwise;
  const auto it = tiles_.find(tileId(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits));
  if (it == tiles_.end()) return otherwise;
  const float h = it->second->height[FloorView::indexInTile(kx, ky)];
  return std::isnan(h) ? otherwise : h;
}

FloorView FloorLayer::observe(const Eigen::Vector3d& sensor, const std::vector<Eigen::Vector3d>& samples,
                              double reach) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<FloorFit> fit;
  if (options_.find) {
    fit = fitFloor(samples, sensor, last_plane_ ? std::optional<FloorPlane>(last_plane_->plane) : std::nullopt, options_.fit);
  }
  if (fit && fallback_found_ && last_plane_) {
    // Once a floor is known, a level surface well above it is not the floor (FloorOptions::max_rise).
    const double known = knownHeightAt(sensor.x(), sensor.y(), last_plane_->heightAt(sensor.x(), sensor.y()));
    const double found = BoundedPlane::of(*fit, options_.extrapolation).heightAt(sensor.x(), sensor.y());
    if (found > known + options_.max_rise) fit.reset();
  }
  if (fit) {
    const BoundedPlane plane = BoundedPlane::of(*fit, options_.extrapolation);
    const double height = plane.heightAt(sensor.x(), sensor.y());
    // A floor found well below the one known: what was taken for the floor was a table or a bed.
    if (fallback_found_ && height < fallback_height_ - options_.fit.seed_window) {
      for (auto& [id, shared] : tiles_) {
        for (int i = 0; i < FloorView::kTileSize * FloorView::kTileSize; ++i) {
          if (std::isnan(shared->height[i])) continue;
          const int kx = keyXOf(id, i), ky = keyYOf(id, i);
          if (shared->height[i] <= heightAtCell(plane, kx, ky) + options_.fit.seed_window) continue;
          Tile& tile = writableTile(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits);
          tile.height[i] = std::numeric_limits<float>::quiet_NaN();
          tile.weight[i] = 0;
          status_.cells--;
          pending_.cells.emplace_back(std::uint32_t(kx) | std::uint32_t(ky) << 16, kNoLevel);
        }
      }
    }
    // The level where no cell is known, first: the cells' levels are taken against it.
    const int level = static_cast<int>(std::lround(height / resolution_));
    if (!fallback_found_ || std::abs(level - fallback_level_) >= 2) {
      if (level != fallback_level_) {
        fallback_level_ = level;
        pending_.fallback_changed = true;
        relevel();
      }
    }
    fallback_found_ = true;
    fallback_height_ = height;
    // One measurement per cell per frame: the plane's height at the cells its inliers lie in.
    std::vector<std::uint32_t> cells;
    cells.reserve(fit->inliers.size());
    for (std::size_t i : fit->inliers) {
      const int kx = floorKeyOf(samples[i].x(), resolution_), ky = floorKeyOf(samples[i].y(), resolution_);
      if (kx >= 0 && ky >= 0) cells.push_back(std::uint32_t(kx) | std::uint32_t(ky) << 16);
    }
    std::sort(cells.begin(), cells.end());
    cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
    for (std::uint32_t c : cells) {
      const int kx = int(c & 0xffff), ky = int(c >> 16);
      setCell(kx, ky, heightAtCell(plane, kx, ky), true);
    }
    // Columns the frame saw something else in (a wall, a step, a table's legs) and no floor was
    // ever seen under: the plane's height there, until a floor is seen (weight 0). Their slice
    // band then follows the floor around them, not the floor under the sensor.
    // Most columns are known after a few frames: the last tile looked up answers most samples
    // (they come in runs of neighbours) without a search of the tiles.
    std::uint32_t last_id = ~std::uint32_t{0};
    const Tile* last = nullptr;
    for (const Eigen::Vector3d& p : samples) {
      const int kx = floorKeyOf(p.x(), resolution_), ky = floorKeyOf(p.y(), resolution_);
      if (kx < 0 || ky < 0) continue;
      const std::uint32_t id = tileId(kx >> FloorView::kTileBits, ky >> FloorView::kTileBits);
      if (id != last_id) {
        const auto it = tiles_.find(id);
        last = it == tiles_.end() ? nullptr : it->second.get();
        last_id = id;
      }
      if (last && !std::isnan(last->height[FloorView::indexInTile(kx, ky)])) continue;
      setCell(kx, ky, heightAtCell(plane, kx, ky), false);
      last_id = ~std::uint32_t{0};  // the tile may be new, or a copy now
    }
    last_plane_ = plane;
    status_.source = FloorSource::kFound;
    status_.height = height;
    status_.tilt = plane.plane.tilt();
    status_.frames_found++;
  } else {
    status_.source = fallback_found_ ? FloorSource::kKept : FloorSource::kAssumed;
    status_.height = last_plane_ ? last_plane_->heightAt(sensor.x(), sensor.y()) : 0.0;
    status_.frames_without++;
  }

  FloorView view;
  view.resolution_ = resolution_;
  view.plane_ = last_plane_;  // this frame's, or the last one found
  if (!tiles_.empty() && reach > 0.0) {
    const double r = std::min(reach, 1000.0);
    const int kx0 = floorKeyOf(sensor.x() - r, resolution_), kx1 = floorKeyOf(sensor.x() + r, resolution_);
    const int ky0 = floorKeyOf(sensor.y() - r, resolution_), ky1 = floorKeyOf(sensor.y() + r, resolution_);
    if (kx0 >= 0 && kx1 >= 0 && ky0 >= 0 && ky1 >= 0) {
      view.tx0_ = kx0 >> FloorView::kTileBits, view.ty0_ = ky0 >> FloorView::kTileBits;
      view.tiles_x_ = (kx1 >> FloorView::kTileBits) - view.tx0_ + 1;
      view.tiles_y_ = (ky1 >> FloorView::kTileBits) - view.ty0_ + 1;
      view.tiles_.resize(std::size_t(view.tiles_x_) * view.tiles_y_);
      for (int ty = 0; ty < view.tiles_y_; ++ty) {
        for (int tx = 0; tx < view.tiles_x_; ++tx) {
          const auto it = tiles_.find(tileId(view.tx0_ + tx, view.ty0_ + ty));
          if (it != tiles_.end()) view.tiles_[std::size_t(ty) * view.tiles_x_ + tx] = it->second;
        }
      }
    }
  }
  return view;
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
