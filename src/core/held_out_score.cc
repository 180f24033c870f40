#include "octo_slice_mapper/held_out_score.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace octo_slice_mapper {

GridImage trinaryOf(const GridImage& grid, const PgmOptions& options) {
  GridImage out = grid;
  for (std::int8_t& v : out.cells) {
    // What addPgmYaml writes (0, 254 or 205) read back as map_server does (p = (255 - px) / 255).
    if (v >= 0 && v / 100.0 > options.occupied_thresh) v = 100;
    else if (v >= 0 && v / 100.0 < options.free_thresh) v = 0;
    else v = kUnknownCell;
  }
  return out;
}

namespace {

struct Cast {
  double expected;  // m
  bool unknown_first;
};

// Casts from (x, y) along the unit direction (dx, dy), in cell units inside the grid's box.
Cast castThrough(const GridImage& m, double x, double y, double dx, double dy, double max_range, double measured) {
  const double res = m.resolution;
  const double gx = (x - m.origin_x) / res, gy = (y - m.origin_y) / res, reading = measured / res;
  const double inf = std::numeric_limits<double>::infinity();
  // The part of [0, max_range] inside the box [0, width] x [0, height].
  double t_in = 0.0, t_out = max_range / res;
  auto clip = [&](double g, double d, double size) {
    if (d == 0.0) {
      if (g < 0.0 || g >= size) t_out = -1.0;
      return;
    }
    const double a = -g / d, b = (size - g) / d;
    t_in = std::max(t_in, std::min(a, b));
    t_out = std::min(t_out, std::max(a, b));
  };
  clip(gx, dx, m.width);
  clip(gy, dy, m.height);
  Cast cast{max_range, false};
  if (!(t_in < t_out)) {
    cast.unknown_first = reading > 0.0;
    return cast;
  }
  if (t_in > 0.0 && t_in < reading) cast.unknown_first = true;
  int i = std::clamp(static_cast<int>(std::floor(gx + t_in * dx)), 0, m.width - 1);
  int j = std::clamp(static_cast<int>(std::floor(gy + t_in * dy)), 0, m.height - 1);
  const int si = dx > 0 ? 1 : -1, sj = dy > 0 ? 1 : -1;
  const double step_i = dx != 0 ? 1.0 / std::abs(dx) : inf, step_j = dy != 0 ? 1.0 / std::abs(dy) : inf;
  double next_i = dx > 0 ? (i + 1 - gx) / dx : dx < 0 ? (i - gx) / dx : inf;
  double next_j = dy > 0 ? (j + 1 - gy) / dy : dy < 0 ? (j - gy) / dy : inf;
  double entered = t_in;
  while (true) {
    const double left = std::min({next_i, next_j, t_out});
    const std::int8_t v = m.at(i, j);
    if (v == 100) {
      cast.expected = 0.5 * (entered + left) * res;
      return cast;
    }
    if (v == kUnknownCell && entered < reading) cast.unknown_first = true;
    if (left >= t_out) break;
    if (next_i < next_j) {
      i += si, entered = next_i, next_i += step_i;
    } else {
      j += sj, entered = next_j, next_j += step_j;
    }
    if (i < 0 || j < 0 || i >= m.width || j >= m.height) break;
  }
  if (t_out < max_range / res && t_out < reading) cast.unknown_first = true;  // left the grid first
  return cast;
}

}  // namespace

HeldOutScore scoreHeldOut(const GridImage& trinary, const std::vector<Scan>& scans, double max_range) {
  HeldOutScore score;
  std::vector<double> errors;
  std::size_t close = 0, fair = 0, too_short = 0, too_long = 0, unknown_first = 0;
  double sum = 0.0;
  for (const Scan& scan : scans) {
    const Eigen::Vector3d o = scan.sensor_pose.translation();
    for (std::size_t k = 0; k < scan.ranges.size(); ++k) {
      const float z = scan.ranges[k];
      // A zero reading is no reading (CARMEN, and the shared judge), even with range_min 0.
      if (trinary.width <= 0 || !(z > 0.0f) || classifyReading(z, scan.range_min, scan.range_max, {}) != ReadingKind::kHit) {
        ++score.skipped;
        continue;
      }
      const double a = scan.beamAngle(k);
      const Eigen::Vector3d d = scan.sensor_pose.linear() * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
      const double planar = std::hypot(d.x(), d.y());
      if (planar < 1e-6) {
        ++score.skipped;
        continue;
      }
      const double measured = std::min<double>(z, max_range);
      const Cast c = castThrough(trinary, o.x(), o.y(), d.x() / planar, d.y() / planar, max_range, measured);
      const double e = std::abs(c.expected - measured);
      errors.push_back(e);
      sum += e;
      close += e <= 0.10;
      fair += e <= 0.25;
      too_short += c.expected < measured - 0.10;
      too_long += c.expected > measured + 0.10;
      unknown_first += c.unknown_first;
    }
  }
  score.beams = errors.size();
  if (errors.empty()) return score;
  const double n = static_cast<double>(errors.size());
  score.within_10cm = close / n;
  score.within_25cm = fair / n;
  score.mean_abs_error = sum / n;
  score.too_short = too_short / n;
  score.too_long = too_long / n;
  score.unknown_first = unknown_first / n;
  const std::size_t mid = errors.size() / 2;
  std::nth_element(errors.begin(), errors.begin() + mid, errors.end());
  score.median_abs_error = errors[mid];
  if (errors.size() % 2 == 0) score.median_abs_error = 0.5 * (errors[mid] + *std::max_element(errors.begin(), errors.begin() + mid));
  return score;
}

}  // namespace octo_slice_mapper
