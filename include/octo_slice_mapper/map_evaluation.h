// Comparing a map with a ground-truth raster: occupied-cell precision and recall.
#pragma once

#include <vector>

#include "octo_slice_mapper/map_io.h"
#include "octo_slice_mapper/scan.h"

namespace octo_slice_mapper {

struct OccupancyScore {
  double precision = 0.0;  // share of map-occupied cells with a true obstacle within tolerance
  double recall = 0.0;     // share of observed true obstacles with a map-occupied cell within tolerance
  std::size_t map_occupied = 0;
  std::size_t truth_observed = 0;  // true obstacle cells the map has any knowledge of
};

// A map cell counts as occupied when its value is above `occupied_percent`. Recall only counts
// true obstacles the map observed (a known map cell within `tolerance_cells`): walls the robot
// never saw are not held against it. Both rasters are aligned by world coordinates.
OccupancyScore scoreOccupancy(const GridImage& map, const GridImage& truth, int tolerance_cells = 1,
                              int occupied_percent = 50);

// How well a map predicts scans it never saw: for each return (range_min < z < range_max, and
// z <= max_range if max_range > 0), the beam is cast through the map in the x-y plane from the
// laser's position to the first cell above `occupied_percent`; the expected range is that
// distance, or the cast limit (max_range, else the scan's range_max) when nothing is hit, as a
// beam model expects a max-range reading then.
struct RangePredictionError {
  std::size_t beams = 0;
  std::size_t nothing_hit = 0;     // beams whose cast met no occupied cell
  double mean_abs_error = 0.0;     // m
  double median_abs_error = 0.0;   // m
  double within_10cm = 0.0;        // share of beams with |expected - measured| <= 0.10 m
};
RangePredictionError predictRanges(const GridImage& map, const std::vector<Scan>& scans, double max_range = 0.0,
                                   int occupied_percent = 50);

}  // namespace octo_slice_mapper
