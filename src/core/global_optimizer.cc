#include "octo_slice_mapper/global_optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/internal/parallel_chunks.h"
#include "core/internal/voxel_traversal.h"

namespace octo_slice_mapper {
namespace {

// Below this a gain counts as a tie: no flip (guards against rounding ping-pong).
constexpr double kMinGain = 1e-9;
constexpr float kNone = std::numeric_limits<float>::infinity();

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

GlobalOptimizer::GlobalOptimizer(const GlobalOptimizerOptions& options, double resolution)
    : options_(options), resolution_(resolution), model_(options.model, resolution, 1.0) {}

// Visits the cells of a beam: those its axis crosses up to its traced length, or for a cone, those
// any of its fanned rays crosses, each once, nearest first. Stops early when `visit` returns false.
template <typename Visit>
void GlobalOptimizer::walk(const Beam& beam, Visit&& visit) const {
  if (beam.fan == 0) {
    walkRay(beam, beam.dx, beam.dy, visit);
    return;
  }
  // A cone's cells, each once and nearest first, were listed by build().
  const std::size_t index = beam.id;
  const std::size_t* cells = &cone_cells_[cone_begin_[index]];
  const std::size_t* cells_end = &cone_cells_[0] + cone_begin_[index + 1];
  for (; cells != cells_end; ++cells) {
    if (!visit(*cells)) return;
  }
}

void GlobalOptimizer::listConeCells(const Beam& beam, std::vector<std::size_t>* cells) const {
  cells->clear();
  const double half = 0.5 * options_.beam_opening_angle;
  for (int k = -int(beam.fan); k <= int(beam.fan); ++k) {
    const double a = half * k / beam.fan, c = std::cos(a), s = std::sin(a);
    walkRay(beam, static_cast<float>(c * beam.dx - s * beam.dy), static_cast<float>(s * beam.dx + c * beam.dy),
            [&](std::size_t cell) {
              cells->push_back(cell);
              return true;
            });
  }
  const auto by_range = [&](std::size_t a, std::size_t b) {
    const double ra = along(beam, centre(a)), rb = along(beam, centre(b));
    return ra < rb || (ra == rb && a < b);
  };
  std::sort(cells->begin(), cells->end(), by_range);
  cells->erase(std::unique(cells->begin(), cells->end()), cells->end());
}

// The grid's cells along one ray from the beam's origin, nearest first, through the project's
// one grid walk (voxel_traversal.h), in cells of travel; cells outside the grid are skipped.
template <typename Visit>
void GlobalOptimizer::walkRay(const Beam& beam, float dir_x, float dir_y, Visit&& visit) const {
  const double fx = (beam.ox - x0_) / resolution_, fy = (beam.oy - y0_) / resolution_;
  int i = static_cast<int>(std::floor(fx)), j = static_cast<int>(std::floor(fy));
  const double ex = fx + dir_x * beam.length / resolution_, ey = fy + dir_y * beam.length / resolution_;
  const int ie = static_cast<int>(std::floor(ex)), je = static_cast<int>(std::floor(ey));
  const double inf = std::numeric_limits<double>::infinity();
  const double delta_i = dir_x != 0 ? std::abs(1.0 / dir_x) : inf;
  const double delta_j = dir_y != 0 ? std::abs(1.0 / dir_y) : inf;
  const WalkAxis x{dir_x > 0 ? 1 : -1, dir_x != 0 ? ((dir_x > 0 ? (i + 1 - fx) : (fx - i)) * delta_i) : inf, delta_i};
  const WalkAxis y{dir_y > 0 ? 1 : -1, dir_y != 0 ? ((dir_y > 0 ? (j + 1 - fy) : (fy - j)) * delta_j) : inf, delta_j};
  const int steps = std::abs(ie - i) + std::abs(je - j);
  walkPlane(i, j, x, y, steps, [&](int ci, int cj, double) {
    return !(ci >= 0 && cj >= 0 && ci < width_ && cj < height_) || visit(std::size_t(cj) * width_ + ci);
  });
}

Eigen::Vector2d GlobalOptimizer::centre(std::size_t cell) const {
  return {x0_ + (double(cell % width_) + 0.5) * resolution_, y0_ + (double(cell / width_) + 0.5) * resolution_};
}

double GlobalOptimizer::along(const Beam& beam, std::size_t cell) const { return along(beam, centre(cell)); }

double GlobalOptimizer::beamLogLikelihood(const Beam& beam, bool obstacle, float distance) const {
  if (!beam.hit) return model_.logNoReturn(obstacle);
  // Far in front of the return the Gaussian term underflows next to the uniform one: the
  // likelihood is exactly that of "no obstacle", without exp/log.
  if (!obstacle || distance < beam.certain_miss) return model_.logHitNoObstacle();
  return model_.logHit(beam.z, distance);
}

void GlobalOptimizer::setFirst(Beam* beam, std::int32_t cell, float distance) const {
  beam->first_cell = cell;
  beam->first_dist = cell >= 0 ? distance : kNone;
  beam->log_likelihood = beamLogLikelihood(*beam, cell >= 0, beam->first_dist);
}

// The beams of scans[first, end) appended to beams_ (and scan_first_beam_), widening `bounds`
// (min x, min y, max x, max y of every traced segment) and z_max_.
void GlobalOptimizer::addBeams(const std::vector<StoredScan>& scans, std::size_t first, std::size_t end,
                               double bounds[4]) {
  double& min_x = bounds[0];
  double& min_y = bounds[1];
  double& max_x = bounds[2];
  double& max_y = bounds[3];
  for (std::size_t si = first; si < end; ++si) {
    const StoredScan& s = scans[si];
    const double range_max = options_.max_range > 0.0 ? std::min<double>(options_.max_range, s.range_max) : s.range_max;
    z_max_ = std::max(z_max_, range_max);
    const Eigen::Matrix3f rotation = s.rotation.toRotationMatrix();
    for (std::size_t k = 0; k < s.ranges.size(); ++k) {
      const float r = s.ranges[k];
      const ReadingKind kind = classifyReading(r, s.range_min, s.range_max, options_.readings);
      if (kind != ReadingKind::kHit && kind != ReadingKind::kNoReturn) continue;
      const float a = s.angle_min + static_cast<float>(k) * s.angle_increment;
      const Eigen::Vector3f d3 = rotation * Eigen::Vector3f(std::cos(a), std::sin(a), 0.0f);
      const float planar = std::hypot(d3.x(), d3.y());
      if (planar < 1e-3f) continue;  // pointing straight up or down: says nothing about the slice
      Beam b;
      b.ox = s.origin.x(), b.oy = s.origin.y(), b.dx = d3.x() / planar, b.dy = d3.y() / planar;
      b.hit = kind == ReadingKind::kHit && r <= range_max;
      if (b.hit) {
        b.z = r * planar;  // horizontal distance
        b.length = static_cast<float>(model_.traceLength(b.z));
        // exp(-0.5 u^2) < 1e-21 for u > 10: far below the uniform term's 1e-16 relative resolution.
        b.certain_miss = static_cast<float>(b.z - 10.0 * model_.sigma(b.z));
      } else {
        if (options_.no_return_range <= 0.0) continue;
        b.z = b.length = static_cast<float>(std::min(options_.no_return_range, range_max));
        b.certain_miss = 0.0f;
      }
      b.id = static_cast<std::uint32_t>(beams_.size());
      b.first_cell = -1;
      b.first_dist = kNone;
      b.log_likelihood = 0.0;
      // Rays at most one cell apart at the far end of the cone.
      const double half_width = b.length * std::tan(0.5 * options_.beam_opening_angle);
      b.fan = static_cast<std::uint16_t>(options_.beam_opening_angle > 0.0 ? std::ceil(half_width / resolution_) : 0);
      const double spread = b.fan ? half_width + resolution_ : 0.0;  // the cone's edges
      min_x = std::min({min_x, double(b.ox), b.ox + double(b.dx) * b.length - spread});
      max_x = std::max({max_x, double(b.ox), b.ox + double(b.dx) * b.length + spread});
      min_y = std::min({min_y, double(b.oy), b.oy + double(b.dy) * b.length - spread});
      max_y = std::max({max_y, double(b.oy), b.oy + double(b.dy) * b.length + spread});
      beams_.push_back(b);
    }
    scan_first_beam_.push_back(beams_.size());
  }
}

void GlobalOptimizer::build(const std::vector<StoredScan>& scans, const ProgressFn& progress) {
  beams_.clear();
  // Beams in the x-y plane; the grid covers every traced segment.
  bounds_[0] = bounds_[1] = 1e300;
  bounds_[2] = bounds_[3] = -1e300;
  z_max_ = 1e-3;
  scan_first_beam_.assign(1, 0);
  addBeams(scans, 0, scans.size(), bounds_);
  const double min_x = bounds_[0], min_y = bounds_[1], max_x = bounds_[2], max_y = bounds_[3];
  model_ = ForwardSensorModel(options_.model, resolution_, z_max_);
  cell_beams_begin_.assign(1, 0);
  cell_beams_.clear();
  occupied_.clear();
  if (beams_.empty()) return;
  // Align the grid with the octree's voxel columns (boundaries at multiples of the resolution).
  x0_ = std::floor(min_x / resolution_) * resolution_ - resolution_;
  y0_ = std::floor(min_y / resolution_) * resolution_ - resolution_;
  width_ = static_cast<int>(std::ceil((max_x - x0_) / resolution_)) + 2;
  height_ = static_cast<int>(std::ceil((max_y - y0_) / resolution_)) + 2;
  const std::size_t cells = std::size_t(width_) * height_;

  cone_begin_.assign(beams_.size() + 1, 0);
  cone_cells_.clear();
  std::vector<std::size_t> scratch;
  for (std::size_t b = 0; b < beams_.size(); ++b) {
    if (beams_[b].fan > 0) {
      listConeCells(beams_[b], &scratch);
      cone_cells_.insert(cone_cells_.end(), scratch.begin(), scratch.end());
    }
    cone_begin_[b + 1] = cone_cells_.size();
  }
  if (cone_cells_.empty()) cone_cells_.push_back(0);  // keeps &cone_cells_[0] valid

  // Two passes over the rays: count per cell, then fill. A cell a beam crosses twice (rounding)
  // is listed once. Each worker walks its own chunk of beams with its own counts; a cell's list
  // holds chunk 0's beams first, then chunk 1's, ...: beam order, as one worker gives it.
  const unsigned workers = workersFor(threadCount(), beams_.size());
  std::vector<std::vector<std::uint32_t>> counts(workers);
  forEachChunk(beams_.size(), workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    std::vector<std::uint32_t>& count = counts[w];
    count.assign(cells, 0);
    for (std::size_t b = begin; b < end; ++b) {
      std::size_t last = npos;
      walk(beams_[b], [&](std::size_t c) {
        if (c != last) ++count[c];
        last = c;
        return true;
      });
      if (progress && w + 1 == workers && (b - begin) % 200000 == 0) {
        progress("indexing beams", 0.5 * (b - begin) / (end - begin));
      }
    }
  });
  cell_beams_begin_.assign(cells + 1, 0);
  // counts[w][c] becomes where worker w's beams through c start.
  for (std::size_t c = 0; c < cells; ++c) {
    std::uint64_t at = cell_beams_begin_[c];
    for (unsigned w = 0; w < workers; ++w) {
      const std::uint32_t n = counts[w][c];
      counts[w][c] = static_cast<std::uint32_t>(at - cell_beams_begin_[c]);
      at += n;
    }
    cell_beams_begin_[c + 1] = at;
  }
  // Room for the beams of later scans (extend()): 1/16 more.
  cell_beams_.reserve(cell_beams_begin_.back() + cell_beams_begin_.back() / 16);
  cell_beams_.resize(cell_beams_begin_.back());
  forEachChunk(beams_.size(), workers, [&](std::size_t begin, std::size_t end, unsigned w) {
    std::vector<std::uint32_t>& fill = counts[w];
    for (std::size_t b = begin; b < end; ++b) {
      std::size_t last = npos;
      walk(beams_[b], [&](std::size_t c) {
        if (c != last) cell_beams_[cell_beams_begin_[c] + fill[c]++] = static_cast<std::uint32_t>(b);
        last = c;
        return true;
      });
      if (progress && w + 1 == workers && (b - begin) % 200000 == 0) {
        progress("indexing beams", 0.5 + 0.5 * (b - begin) / (end - begin));
      }
    }
  });
  occupied_.assign(cells, 0);
  beam_changed_.assign(beams_.size(), 0);
  startEmpty();
}

bool GlobalOptimizer::extend(const std::vector<StoredScan>& scans, std::size_t first_new) {
  if (beams_.empty() || first_new != scanCount() || first_new > scans.size() || options_.beam_opening_angle > 0.0) {
    return false;
  }
  const std::size_t old_beams = beams_.size();
  const double old_z_max = z_max_;
  double bounds[4] = {bounds_[0], bounds_[1], bounds_[2], bounds_[3]};
  addBeams(scans, first_new, scans.size(), bounds);
  if (z_max_ != old_z_max || bounds[0] < bounds_[0] || bounds[1] < bounds_[1] || bounds[2] > bounds_[2] ||
      bounds[3] > bounds_[3]) {
    // A build of all would lay the grid out (or scale the model) otherwise: undo.
    beams_.resize(old_beams);
    scan_first_beam_.resize(first_new + 1);
    z_max_ = old_z_max;
    return false;
  }
  const std::size_t cells = cellCount();
  // The new beams' cells per cell, in beam order, as build()'s fill pass lists them.
  std::vector<std::uint32_t> added(cells, 0);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;  // (cell, beam)
  for (std::size_t b = old_beams; b < beams_.size(); ++b) {
    std::size_t last = npos;
    walk(beams_[b], [&](std::size_t c) {
      if (c != last) {
        ++added[c];
        pairs.emplace_back(static_cast<std::uint32_t>(c), static_cast<std::uint32_t>(b));
      }
      last = c;
      return true;
    });
  }
  // In place: each cell's list moves up by the new pairs of the cells before it (from the last
  // cell down, so nothing is overwritten before it moved), and the new beams follow its old ones.
  std::vector<std::uint64_t> begin(cells + 1, 0);
  for (std::size_t c = 0; c < cells; ++c) begin[c + 1] = cell_beams_begin_[c + 1] + (begin[c] - cell_beams_begin_[c]) + added[c];
  // Growing past the capacity would copy the whole index into fresh memory (on this machine
  // slower than a new build): build() leaves room, and so does a growth here.
  if (begin[cells] > cell_beams_.capacity()) cell_beams_.reserve(begin[cells] + begin[cells] / 16);
  cell_beams_.resize(begin[cells]);
  for (std::size_t c = cells; c-- > 0;) {
    const std::uint64_t from = cell_beams_begin_[c], n = cell_beams_begin_[c + 1] - from;
    if (n > 0 && begin[c] != from) std::memmove(&cell_beams_[begin[c]], &cell_beams_[from], n * sizeof(std::uint32_t));
  }
  std::vector<std::uint64_t> fill(cells);
  for (std::size_t c = 0; c < cells; ++c) fill[c] = begin[c] + (cell_beams_begin_[c + 1] - cell_beams_begin_[c]);
  for (const auto& [c, b] : pairs) cell_beams_[fill[c]++] = b;
  cell_beams_begin_ = std::move(begin);
  beam_changed_.assign(beams_.size(), 0);
  return true;
}

void GlobalOptimizer::startEmpty() {
  std::fill(occupied_.begin(), occupied_.end(), 0);
  // No cell occupied: no beam meets an obstacle, nothing to walk.
  log_likelihood_ = 0.0;
  for (Beam& b : beams_) {
    setFirst(&b, -1, kNone);
    log_likelihood_ += b.log_likelihood;
  }
}

void GlobalOptimizer::startFrom(const GridImage& map) {
  for (std::size_t c = 0; c < occupied_.size(); ++c) {
    occupied_[c] = 0;
    if (!observed(c)) continue;
    const double x = x0_ + (double(c % width_) + 0.5) * resolution_, y = y0_ + (double(c / width_) + 0.5) * resolution_;
    const int i = static_cast<int>(std::floor((x - map.origin_x) / map.resolution));
    const int j = static_cast<int>(std::floor((y - map.origin_y) / map.resolution));
    if (i >= 0 && j >= 0 && i < map.width && j < map.height && map.at(i, j) > 50) occupied_[c] = 1;
  }
  resetBeams();
}

void GlobalOptimizer::setOccupied(std::size_t cell, bool occupied) { occupied_[cell] = occupied ? 1 : 0; }

void GlobalOptimizer::findFirstOccupied(Beam* beam, std::int32_t skip_cell) const {
  std::int32_t first = -1;
  walk(*beam, [&](std::size_t c) {
    if (!occupied_[c] || static_cast<std::int32_t>(c) == skip_cell) return true;
    first = static_cast<std::int32_t>(c);
    return false;
  });
  setFirst(beam, first, first >= 0 ? static_cast<float>(along(*beam, static_cast<std::size_t>(first))) : kNone);
}

void GlobalOptimizer::resetBeams() {
  forEachChunk(beams_.size(), workersFor(threadCount(), beams_.size()), [&](std::size_t begin, std::size_t end, unsigned) {
    for (std::size_t b = begin; b < end; ++b) findFirstOccupied(&beams_[b], -1);
  });
  // Summed in beam order, as a single worker would.
  log_likelihood_ = 0.0;
  for (const Beam& b : beams_) log_likelihood_ += b.log_likelihood;
}

double GlobalOptimizer::recomputeLogLikelihood() const {
  double total = 0.0;
  for (Beam b : beams_) {
    findFirstOccupied(&b, -1);
    total += b.log_likelihood;
  }
  return total;
}

double GlobalOptimizer::flipDelta(std::size_t cell) const {
  double delta = 0.0;
  const std::uint64_t end = cell_beams_begin_[cell + 1];
  if (!occupied_[cell]) {
    // Free -> occupied: beams whose first obstacle lies beyond this cell now stop here.
    const Eigen::Vector2d c = centre(cell);
    for (std::uint64_t k = cell_beams_begin_[cell]; k < end; ++k) {
      const Beam& b = beams_[cell_beams_[k]];
      const double d = along(b, c);
      if (b.first_cell >= 0 && b.first_dist <= d) continue;
      delta += beamLogLikelihood(b, true, static_cast<float>(d)) - b.log_likelihood;
    }
  } else {
    // Occupied -> free: beams stopped by this cell now run on to their next obstacle.
    for (std::uint64_t k = cell_beams_begin_[cell]; k < end; ++k) {
      const Beam& b = beams_[cell_beams_[k]];
      if (b.first_cell != static_cast<std::int32_t>(cell)) continue;
      Beam next = b;
      findFirstOccupied(&next, static_cast<std::int32_t>(cell));
      delta += next.log_likelihood - b.log_likelihood;
    }
  }
  return delta;
}

void GlobalOptimizer::flip(std::size_t cell) { flip(cell, flipDelta(cell)); }

void GlobalOptimizer::flip(std::size_t cell, double delta) {
  log_likelihood_ += delta;
  const std::uint64_t end = cell_beams_begin_[cell + 1];
  for (std::uint64_t k = cell_beams_begin_[cell]; k < end; ++k) beam_changed_[cell_beams_[k]] = 1;
  if (!occupied_[cell]) {
    const Eigen::Vector2d c = centre(cell);
    for (std::uint64_t k = cell_beams_begin_[cell]; k < end; ++k) {
      Beam& b = beams_[cell_beams_[k]];
      const double d = along(b, c);
      if (b.first_cell >= 0 && b.first_dist <= d) continue;
      setFirst(&b, static_cast<std::int32_t>(cell), static_cast<float>(d));
    }
    occupied_[cell] = 1;
  } else {
    occupied_[cell] = 0;
    for (std::uint64_t k = cell_beams_begin_[cell]; k < end; ++k) {
      Beam& b = beams_[cell_beams_[k]];
      if (b.first_cell == static_cast<std::int32_t>(cell)) findFirstOccupied(&b, -1);
    }
  }
}

std::vector<std::uint8_t> GlobalOptimizer::cellsToRevisit(std::size_t first_new_scan, const GridImage& earlier) const {
  std::vector<std::uint8_t> look(cellCount(), 0);
  const std::size_t scans = scan_first_beam_.size() - 1;
  for (std::size_t b = scan_first_beam_[std::min(first_new_scan, scans)]; b < beams_.size(); ++b) {
    walk(beams_[b], [&](std::size_t c) {
      look[c] = 1;
      return true;
    });
  }
  for (std::size_t c = 0; c < look.size(); ++c) {
    if (look[c] || !observed(c)) continue;
    const Eigen::Vector2d p = centre(c);
    const int i = static_cast<int>(std::floor((p.x() - earlier.origin_x) / earlier.resolution));
    const int j = static_cast<int>(std::floor((p.y() - earlier.origin_y) / earlier.resolution));
    const bool known = i >= 0 && j >= 0 && i < earlier.width && j < earlier.height && earlier.at(i, j) >= 0;
    if (!known) look[c] = 1;
  }
  return look;
}

OptimizeReport GlobalOptimizer::optimize(const ProgressFn& progress, const std::vector<std::uint8_t>* first_sweep) {
  const auto t0 = std::chrono::steady_clock::now();
  OptimizeReport report;
  report.beams = beams_.size();
  report.ray_cells = cell_beams_.size();
  std::vector<std::size_t> variables;
  for (std::size_t c = 0; c < cellCount(); ++c) {
    if (observed(c)) variables.push_back(c);
  }
  report.cells = variables.size();
  report.initial_log_likelihood = log_likelihood_;
  std::vector<std::pair<double, std::size_t>> candidates;
  std::vector<std::uint8_t> dirty =
      first_sweep && first_sweep->size() == cellCount() ? *first_sweep : std::vector<std::uint8_t>(cellCount(), 1);
  std::fill(beam_changed_.begin(), beam_changed_.end(), 0);
  for (int sweep = 0; sweep < options_.max_sweeps; ++sweep) {
    if (stop_ && stop_->load(std::memory_order_relaxed)) {
      report.stopped = true;
      break;
    }
    // A cell's gain depends only on the beams through it: after the first sweep only cells on
    // beams through a flipped cell need a new look.
    // The gains are read-only work: each worker takes a chunk of the cells, and the chunks'
    // candidates are joined in order (the sort below breaks ties by cell anyway).
    const unsigned workers = workersFor(threadCount(), variables.size());
    std::vector<std::vector<std::pair<double, std::size_t>>> found(workers);
    forEachChunk(variables.size(), workers, [&](std::size_t begin, std::size_t end, unsigned w) {
      for (std::size_t v = begin; v < end; ++v) {
        if (!dirty[variables[v]]) continue;
        const double gain = flipDelta(variables[v]);
        if (gain > kMinGain) found[w].emplace_back(gain, variables[v]);
        if (progress && w + 1 == workers && (v - begin) % 100000 == 0) {
          progress("sweep " + std::to_string(sweep + 1), 0.5 * (v - begin) / (end - begin));
        }
      }
    });
    candidates.clear();
    for (const auto& part : found) candidates.insert(candidates.end(), part.begin(), part.end());
    std::sort(candidates.begin(), candidates.end(),
              [](const std::pair<double, std::size_t>& a, const std::pair<double, std::size_t>& b) {
                return a.first > b.first || (a.first == b.first && a.second < b.second);
              });
    std::size_t flips = 0;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      const double gain = flipDelta(candidates[k].second);
      if (gain > kMinGain) {
        flip(candidates[k].second, gain);
        ++flips;
      }
      if (progress && k % 20000 == 0) progress("sweep " + std::to_string(sweep + 1), 0.5 + 0.5 * k / candidates.size());
    }
    report.sweeps = sweep + 1;
    report.flips_per_sweep.push_back(flips);
    report.log_likelihood_per_sweep.push_back(log_likelihood_);
    if (flips == 0) {
      // A local optimum; its occupied cells that explain no beam go, and the cells on their
      // beams get another look (a cell in front of one may now gain from a flip).
      const std::size_t released = releaseUnsupported();
      report.released += released;
      if (released == 0) {
        report.converged = true;
        break;
      }
    }
    std::fill(dirty.begin(), dirty.end(), 0);
    for (std::size_t b = 0; b < beams_.size(); ++b) {
      if (!beam_changed_[b]) continue;
      beam_changed_[b] = 0;
      walk(beams_[b], [&](std::size_t c) {
        dirty[c] = 1;
        return true;
      });
    }
  }
  report.final_log_likelihood = log_likelihood_;
  report.optimize_seconds = secondsSince(t0);
  report.memory_bytes = memoryBytes();
  return report;
}

std::size_t GlobalOptimizer::releaseUnsupported() {
  // An occupied cell that no beam meets first explains no reading: every beam through it was
  // stopped before it. Freeing it changes no beam's first obstacle, so the log-likelihood stays
  // as it is. The hill climbing never makes such a cell (a flip needs a positive gain); a warm
  // start brings them in: the incremental map's cells behind a wall's face, which would
  // otherwise stay occupied for no reason (freeing them is a tie, and ties don't flip).
  std::vector<std::uint8_t> supported(occupied_.size(), 0);
  for (const Beam& b : beams_) {
    if (b.first_cell >= 0) supported[static_cast<std::size_t>(b.first_cell)] = 1;
  }
  std::size_t released = 0;
  for (std::size_t c = 0; c < occupied_.size(); ++c) {
    if (!occupied_[c] || supported[c]) continue;
    occupied_[c] = 0;
    // A beam's first obstacle is the first occupied cell of its walk, while a flip compares
    // distances to cell centres: at a grazing angle the two can disagree, and a cell the walk
    // reaches after the first obstacle can still gain by stopping a beam. Such a cell stays.
    if (flipDelta(c) > kMinGain) {
      occupied_[c] = 1;
      continue;
    }
    ++released;
    for (std::uint64_t k = cell_beams_begin_[c]; k < cell_beams_begin_[c + 1]; ++k) beam_changed_[cell_beams_[k]] = 1;
  }
  return released;
}

std::size_t GlobalOptimizer::cellAt(double x, double y) const {
  const int i = static_cast<int>(std::floor((x - x0_) / resolution_));
  const int j = static_cast<int>(std::floor((y - y0_) / resolution_));
  if (i < 0 || j < 0 || i >= width_ || j >= height_) return npos;
  return std::size_t(j) * width_ + i;
}

GridImage GlobalOptimizer::unknownGrid() const {
  GridImage grid;
  grid.width = width_;
  grid.height = height_;
  grid.resolution = resolution_;
  grid.origin_x = x0_;
  grid.origin_y = y0_;
  grid.cells.assign(occupied_.size(), -1);
  return grid;
}

GridImage GlobalOptimizer::result() const {
  GridImage grid = unknownGrid();
  for (std::size_t c = 0; c < occupied_.size(); ++c) {
    if (occupied_[c]) {
      grid.cells[c] = 100;
      continue;
    }
    // Free only where a beam passes through before it meets an obstacle; cells behind the first
    // obstacle of every beam (e.g. inside a wall) were never seen: unknown.
    const Eigen::Vector2d centre_c = centre(c);
    for (std::uint64_t k = cell_beams_begin_[c]; k < cell_beams_begin_[c + 1]; ++k) {
      const Beam& b = beams_[cell_beams_[k]];
      if (b.first_cell < 0 || along(b, centre_c) < b.first_dist) {
        grid.cells[c] = 0;
        break;
      }
    }
  }
  return grid;
}

GridImage GlobalOptimizer::state() const {
  GridImage grid = unknownGrid();
  for (std::size_t c = 0; c < occupied_.size(); ++c) {
    if (occupied_[c]) grid.cells[c] = 100;
    else if (observed(c)) grid.cells[c] = 0;
  }
  return grid;
}

std::size_t GlobalOptimizer::memoryBytes() const {
  return beams_.capacity() * sizeof(Beam) + cell_beams_begin_.capacity() * sizeof(std::uint64_t) +
         cone_begin_.capacity() * sizeof(std::uint64_t) + cone_cells_.capacity() * sizeof(std::size_t) +
         cell_beams_.capacity() * sizeof(std::uint32_t) + occupied_.capacity();
}

}  // namespace octo_slice_mapper
