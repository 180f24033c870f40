// Comparing a map with a ground-truth raster: occupied-cell precision and recall.
#pragma once

#include <vector>

#include "octo_slice_mapper/map_io.h"

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

// How well a map predicts scans it never saw: see held_out_score.h.

}  // namespace octo_slice_mapper
