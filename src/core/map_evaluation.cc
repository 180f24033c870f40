#include "octo_slice_mapper/map_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

namespace {

// Distance along the planar ray from (ox, oy) in direction (dx, dy) to the first cell of `map`
// above `occupied_percent`, walking cell by cell (Amanatides & Woo); `limit` if none before it.
double castRay(const GridImage& map, double ox, double oy, double dx, double dy, double limit, int occupied_percent) {
  const double fx = (ox - map.origin_x) / map.resolution, fy = (oy - map.origin_y) / map.resolution;
  int i = static_cast<int>(std::floor(fx)), j = static_cast<int>(std::floor(fy));
  const double inf = std::numeric_limits<double>::infinity();
  const int step_i = dx > 0 ? 1 : -1, step_j = dy > 0 ? 1 : -1;
  const double delta_i = dx != 0 ? std::abs(1.0 / dx) : inf, delta_j = dy != 0 ? std::abs(1.0 / dy) : inf;
  double t_i = dx != 0 ? (dx > 0 ? (i + 1 - fx) : (fx - i)) * delta_i : inf;
  double t_j = dy != 0 ? (dy > 0 ? (j + 1 - fy) : (fy - j)) * delta_j : inf;
  const double limit_cells = limit / map.resolution;
  double t = 0.0;  // in cells, where the ray entered cell (i, j)
  while (t <= limit_cells) {
    if (i >= 0 && j >= 0 && i < map.width && j < map.height && map.at(i, j) > occupied_percent) {
      return t * map.resolution;
    }
    if (t_i < t_j) {
      t = t_i, i += step_i, t_i += delta_i;
    } else {
      t = t_j, j += step_j, t_j += delta_j;
    }
  }
  return limit;
}

}  // namespace

RangePredictionError predictRanges(const GridImage& map, const std::vector<Scan>& scans, double max_range,
                                   int occupied_percent) {
  RangePredictionError out;
  std::vector<double> errors;
  for (const Scan& scan : scans) {
    const Eigen::Vector3d origin = scan.sensor_pose.translation();
    const double limit = max_range > 0.0 ? std::min<double>(max_range, scan.range_max) : scan.range_max;
    for (std::size_t k = 0; k < scan.ranges.size(); ++k) {
      const float z = scan.ranges[k];
      if (classifyReading(z, scan.range_min, scan.range_max, {}) != ReadingKind::kHit || z > limit) continue;
      const double a = scan.beamAngle(k);
      const Eigen::Vector3d d = scan.sensor_pose.linear() * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
      const double planar = std::hypot(d.x(), d.y());
      if (planar < 1e-3) continue;
      const double expected = castRay(map, origin.x(), origin.y(), d.x() / planar, d.y() / planar, limit * planar,
                                      occupied_percent);
      if (expected >= limit * planar) ++out.nothing_hit;
      errors.push_back(std::abs(expected - z * planar));
    }
  }
  out.beams = errors.size();
  if (errors.empty()) return out;
  double sum = 0.0;
  std::size_t close = 0;
  for (double e : errors) {
    sum += e;
    close += e <= 0.10;
  }
  out.mean_abs_error = sum / errors.size();
  out.within_10cm = static_cast<double>(close) / errors.size();
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  out.median_abs_error = errors[errors.size() / 2];
  return out;
}

}  // namespace octo_slice_mapper
