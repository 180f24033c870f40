// Task 2: the map that best explains all kept scans at once, by hill climbing over binary cells
// of the 2D slice grid under the forward sensor model.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "octo_slice_mapper/forward_sensor_model.h"
#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/internal/scan_store.h"

namespace octo_slice_mapper {

struct GlobalOptimizerOptions {
  ForwardSensorModelOptions model;
  // How readings are read: the Mapper gives the insertion's, so both passes read a scan alike.
  ReadingPolicy readings;
  // A no-return reading says "no obstacle within this distance" (as the inverse model clears).
  double no_return_range = 4.0;
  // Returns farther than this are not used (0 = the sensor's range_max). Unlike the insertion,
  // the pass keeps far returns by default: one a pose error moved only costs its own beam's
  // likelihood (the uniform term), where in the inverse model it marks and clears cells; cutting
  // them at the insertion's 30 m left the outdoor log's optimized map with far less known.
  double max_range = 0.0;
  int max_sweeps = 100;
  // Workers for indexing the beams and judging the cells (0 = every core). The map is the same
  // for any number.
  int threads = 0;
  // Full opening angle of a beam (rad). 0: a laser's thin beam, traced along its axis. Wider
  // (sonar): the expected range is the nearest occupied cell anywhere in the cone.
  double beam_opening_angle = 0.0;
  // Laser height used to index scans; the optimizer is 2D: beams are projected onto the x-y plane.
};

struct OptimizeReport {
  double initial_log_likelihood = 0.0;
  double final_log_likelihood = 0.0;
  std::vector<std::size_t> flips_per_sweep;
  std::vector<double> log_likelihood_per_sweep;  // after each sweep
  int sweeps = 0;
  bool converged = false;  // a sweep without flips: a local optimum
  bool stopped = false;    // a stop was asked for (stopWhen) before it converged
  std::size_t cells = 0;   // observed cells (the variables)
  std::size_t beams = 0;
  std::size_t ray_cells = 0;  // (cell, beam) pairs in the index
  double build_seconds = 0.0, optimize_seconds = 0.0;
  bool index_extended = false;  // (optimizeScans) an earlier pass's index extended, not built anew
  std::size_t released = 0;  // occupied cells no beam met first, freed (releaseUnsupported)
  std::size_t memory_bytes = 0;
};

// Reports stage and fraction done, for progress bars.
using ProgressFn = std::function<void(const std::string& stage, double fraction)>;

class GlobalOptimizer {
 public:
  GlobalOptimizer(const GlobalOptimizerOptions& options, double resolution);

  // Indexes every beam of `scans`: which cells it crosses (a cell -> beams index, built in two
  // passes so it needs no per-pair distances). Cells no beam crosses stay unknown.
  void build(const std::vector<StoredScan>& scans, const ProgressFn& progress = {});
  // After build(scans[0, first_new)) (or extend()), indexes the beams of scans[first_new, end) as
  // well, without walking the others again: then the index, the grid and the beams are exactly
  // what build(scans) gives (so are the results from any start). Only when the new beams stay
  // within the traced extent so far and the longest range is the same, for thin beams; otherwise
  // false, nothing changed, and build() is the way. The cells' states stay as they were (call
  // startEmpty() or startFrom()).
  bool extend(const std::vector<StoredScan>& scans, std::size_t first_new);
  std::size_t scanCount() const { return scan_first_beam_.size() - 1; }

  // Initial states: all observed cells free (the lab's start), or occupied where `map` (e.g. the
  // incremental slice) is above 50 % (warm start).
  void startEmpty();
  void startFrom(const GridImage& map);
  void setOccupied(std::size_t cell, bool occupied);  // then call resetBeams()
  void resetBeams();  // recompute every beam's first occupied cell and the total log-likelihood

  // Sweeps until no single flip improves (or max_sweeps). Within a sweep, cells are tried in order
  // of their gain at the start of the sweep, each re-evaluated just before flipping; a flip is made
  // only for a strictly positive gain (ties don't flip), so the log-likelihood never decreases.
  // `first_sweep` (one flag per cell): the cells the first sweep looks at (default: all); the
  // later sweeps look at the cells on beams through a flipped cell, as always.
  // At a local optimum the occupied cells no beam meets first are freed (releaseUnsupported) and
  // the sweeps go on until a sweep flips nothing and nothing is left to free.
  OptimizeReport optimize(const ProgressFn& progress = {}, const std::vector<std::uint8_t>* first_sweep = nullptr);
  // Frees every occupied cell that is no beam's first obstacle and would not gain from being
  // occupied again; returns how many. No beam's record and not the log-likelihood change (a warm
  // start's cells behind a wall's face are such cells; hill climbing from all-free makes none);
  // a cell in front of a freed one may gain from a flip now (its beams are marked changed).
  std::size_t releaseUnsupported();
  // optimize() ends before its next sweep once `*stop` is true (null: never): a background pass
  // being shut down does not finish a pass of many seconds first.
  void stopWhen(const std::atomic<bool>* stop) { stop_ = stop; }
  // The cells a first sweep must look at to reach the same map as a full one, when the start is
  // a converged earlier result over the scans before `first_new_scan` (as build() got them, in
  // the same order) and `earlier` is that result: a cell's gain depends only on the beams through
  // it, so only cells the new scans' beams cross, and cells `earlier` does not know (their start
  // came from elsewhere), can gain from a flip.
  std::vector<std::uint8_t> cellsToRevisit(std::size_t first_new_scan, const GridImage& earlier) const;

  // Change of the total log-likelihood if `cell` flipped: only the beams crossing the cell are
  // visited, using each beam's record of its first occupied cell.
  double flipDelta(std::size_t cell) const;
  void flip(std::size_t cell);  // applies it and updates the beam records and the total
  double logLikelihood() const { return log_likelihood_; }
  double recomputeLogLikelihood() const;  // from scratch, tracing every beam (for checking)

  std::size_t cellCount() const { return cell_beams_begin_.empty() ? 0 : cell_beams_begin_.size() - 1; }
  bool observed(std::size_t cell) const { return cell_beams_begin_[cell + 1] > cell_beams_begin_[cell]; }
  bool occupied(std::size_t cell) const { return occupied_[cell] != 0; }
  std::size_t cellAt(double x, double y) const;  // or npos outside the grid
  static constexpr std::size_t npos = std::numeric_limits<std::size_t>::max();
  // 100 occupied, 0 free (a beam passed through before any obstacle), -1 never seen.
  GridImage result() const;
  // The cells' states: 100 occupied, 0 every other observed cell, -1 unobserved (OptimizedMap::state).
  GridImage state() const;
  std::size_t memoryBytes() const;
  std::size_t beamCount() const { return beams_.size(); }

 private:
  const std::atomic<bool>* stop_ = nullptr;  // stopWhen
  struct Beam {
    float ox, oy, dx, dy;  // origin and unit direction in the x-y plane
    std::uint16_t fan;     // extra rays on each side of the axis, spread over the cone
    std::uint32_t id;      // index in beams_ (records are copied while evaluating a flip)
    float z;               // measured range (returns) or no_return_range
    float length;          // how far the beam is traced
    bool hit;
    std::int32_t first_cell;  // first occupied cell along the beam, -1 none
    float first_dist;         // its distance along the beam
    float certain_miss;       // an obstacle closer than this can't explain the return at all
    double log_likelihood;    // of the beam with its current first obstacle
  };
  void setFirst(Beam* beam, std::int32_t cell, float distance) const;
  GridImage unknownGrid() const;  // the optimizer's grid, every cell unknown
  void addBeams(const std::vector<StoredScan>& scans, std::size_t first, std::size_t end, double bounds[4]);
  double bounds_[4] = {0, 0, 0, 0};  // min x, min y, max x, max y of the traced segments
  template <typename Visit>
  void walk(const Beam& beam, Visit&& visit) const;
  void flip(std::size_t cell, double delta);
  double beamLogLikelihood(const Beam& beam, bool obstacle, float distance) const;
  Eigen::Vector2d centre(std::size_t cell) const;
  double along(const Beam& beam, std::size_t cell) const;
  // Distance from the beam's origin to a cell centre (the range at which it would echo).
  static double along(const Beam& beam, const Eigen::Vector2d& c) {
    return beam.fan == 0 ? (c.x() - beam.ox) * beam.dx + (c.y() - beam.oy) * beam.dy
                         : std::hypot(c.x() - beam.ox, c.y() - beam.oy);
  }
  template <typename Visit>
  void walkRay(const Beam& beam, float dx, float dy, Visit&& visit) const;
  void listConeCells(const Beam& beam, std::vector<std::size_t>* cells) const;
  std::vector<std::uint64_t> cone_begin_;  // per beam, into cone_cells_ (empty range for thin beams)
  std::vector<std::size_t> cone_cells_;   // cells of each cone, each once, nearest first
  void findFirstOccupied(Beam* beam, std::int32_t skip_cell) const;
  unsigned threadCount() const { return options_.threads > 0 ? static_cast<unsigned>(options_.threads) : 0u; }

  GlobalOptimizerOptions options_;
  double resolution_;
  double z_max_ = 1.0;
  ForwardSensorModel model_;
  // Grid: cell (i, j) centre at (x0_ + (i + 0.5) res, y0_ + (j + 0.5) res).
  double x0_ = 0.0, y0_ = 0.0;
  int width_ = 0, height_ = 0;
  std::vector<Beam> beams_;
  std::vector<std::uint64_t> cell_beams_begin_;  // CSR offsets, size cells + 1
  std::vector<std::uint32_t> cell_beams_;        // beam ids per cell
  std::vector<std::uint8_t> occupied_;
  std::vector<std::uint8_t> beam_changed_;  // beams through a cell flipped in this sweep
  std::vector<std::size_t> scan_first_beam_;  // scan s's beams are beams_[scan_first_beam_[s], [s + 1])
  double log_likelihood_ = 0.0;
};

}  // namespace octo_slice_mapper
