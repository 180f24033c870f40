#include "core/internal/map_evaluation.h"

#include <algorithm>
#include <cmath>

namespace octo_slice_mapper {
namespace {

// Value of `grid` at the cell containing world point (x, y), -1 outside.
int valueAtWorld(const GridImage& grid, double x, double y) {
  const int i = static_cast<int>(std::floor((x - grid.origin_x) / grid.resolution));
  const int j = static_cast<int>(std::floor((y - grid.origin_y) / grid.resolution));
  if (i < 0 || j < 0 || i >= grid.width || j >= grid.height) return kUnknownCell;
  return grid.at(i, j);
}

template <typename Pred>
bool anyNear(const GridImage& grid, double x, double y, int tolerance, double step, Pred pred) {
  for (int dj = -tolerance; dj <= tolerance; ++dj) {
    for (int di = -tolerance; di <= tolerance; ++di) {
      if (pred(valueAtWorld(grid, x + di * step, y + dj * step))) return true;
    }
  }
  return false;
}

}  // namespace

OccupancyScore scoreOccupancy(const GridImage& map, const GridImage& truth, int tolerance_cells, int occupied_percent) {
  OccupancyScore score;
  auto map_occupied = [occupied_percent](int v) { return v > occupied_percent; };
  auto truth_occupied = [](int v) { return v > 50; };
  auto known = [](int v) { return v >= 0; };
  std::size_t true_positive_map = 0, hit_truth = 0;
  for (int j = 0; j < map.height; ++j) {
    for (int i = 0; i < map.width; ++i) {
      if (!map_occupied(map.at(i, j))) continue;
      score.map_occupied++;
      const double x = map.origin_x + (i + 0.5) * map.resolution, y = map.origin_y + (j + 0.5) * map.resolution;
      if (anyNear(truth, x, y, tolerance_cells, map.resolution, truth_occupied)) true_positive_map++;
    }
  }
  for (int j = 0; j < truth.height; ++j) {
    for (int i = 0; i < truth.width; ++i) {
      if (!truth_occupied(truth.at(i, j))) continue;
      const double x = truth.origin_x + (i + 0.5) * truth.resolution, y = truth.origin_y + (j + 0.5) * truth.resolution;
      if (!anyNear(map, x, y, tolerance_cells, truth.resolution, known)) continue;
      score.truth_observed++;
      if (anyNear(map, x, y, tolerance_cells, truth.resolution, map_occupied)) hit_truth++;
    }
  }
  score.precision = score.map_occupied ? double(true_positive_map) / score.map_occupied : 0.0;
  score.recall = score.truth_observed ? double(hit_truth) / score.truth_observed : 0.0;
  return score;
}

}  // namespace octo_slice_mapper
