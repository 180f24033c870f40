// How well a map predicts returns it was not built from, judged as a navigation stack reads the
// exported map: the map_server reading of the .pgm (occupied >= occupied_thresh, free
// < free_thresh, the rest unknown), and each held-out return cast through that trinary grid.
#pragma once

#include <cstddef>
#include <vector>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {

// The cell classes map_server gives the .pgm that savePgmYaml writes for `grid` (100 occupied,
// 0 free, -1 unknown): the same thresholds, applied to the same pixel values.
GridImage trinaryOf(const GridImage& grid, const PgmOptions& options = {});

// Which scans of a log are held out: index first, first + every, first + 2 every, ...
struct HoldOut {
  int every = 0;  // 0: none
  int first = 5;
  bool holds(std::size_t index) const {
    return every > 0 && index >= std::size_t(first) && (index - first) % std::size_t(every) == 0;
  }
};

struct HeldOutScore {
  std::size_t beams = 0;            // returns judged
  std::size_t skipped = 0;          // readings not judged (no-returns, invalid)
  double within_10cm = 0.0;         // share with |expected - measured| <= 0.10 m (the headline)
  double within_25cm = 0.0;
  double mean_abs_error = 0.0;      // m
  double median_abs_error = 0.0;    // m
  double too_short = 0.0;           // share with expected < measured - 0.10 m (an obstacle in front)
  double too_long = 0.0;            // share with expected > measured + 0.10 m (through a wall)
  double unknown_first = 0.0;       // share meeting unknown or off-map space before the return
};

// Each return of `scans` (range_min < z < range_max and z > 0, cut at `max_range`) is cast in
// the x-y plane from the laser through `trinary` (a grid of 100 / 0 / -1), cell by cell, to the
// first occupied cell; unknown cells do not stop it. The expected range is the middle of the
// ray's chord through that cell; none before `max_range` (or leaving the grid) is `max_range`.
HeldOutScore scoreHeldOut(const GridImage& trinary, const std::vector<Scan>& scans, double max_range = 30.0);

}  // namespace octo_slice_mapper
