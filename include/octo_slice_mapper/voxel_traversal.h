// The one grid walk of the project (Amanatides & Woo): the cells a straight segment crosses, in
// order, each with where the segment leaves it. Scan insertion walks octree voxels with it (3D,
// and in one layer for level scans), the global pass walks its 2D grid with it.
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <type_traits>

namespace octo_slice_mapper {

// One axis of a walk: the way it steps, the walk parameter at its next cell boundary and the
// parameter between two boundaries. The unit of the parameter is the caller's (a fraction of the
// segment, cells of travel): the walk only compares and adds them.
struct WalkAxis {
  int step = 0;        // +1 or -1 (either, when the segment never crosses a boundary of this axis)
  double next = 0.0;   // "never" (a huge value) when it does not
  double delta = 0.0;
};

// The axis of a segment from `from` to `to` (one coordinate, in a grid of cells `size` wide whose
// cell holding `from` has its centre at `centre`), with the fraction of the segment as parameter.
inline WalkAxis walkAxis(double from, double to, double centre, double size, double never) {
  const double d = to - from;
  if (d > 0.0) return {1, (centre + 0.5 * size - from) / d, size / d};
  if (d < 0.0) return {-1, (centre - 0.5 * size - from) / d, -size / d};
  return {0, never, never};
}

namespace detail {
// visit's answer: false stops the walk; a visit returning nothing never stops it.
template <typename Visit, typename... Args>
__attribute__((always_inline)) inline bool keepWalking(Visit& visit, Args... args) {
  if constexpr (std::is_void_v<std::invoke_result_t<Visit&, Args...>>) {
    visit(args...);
    return true;
  } else {
    return visit(args...);
  }
}

// One step in the x-y plane: x when `x_first`, else y. Both candidates computed, one selected
// (conditional moves): the loop-carried chain is a compare and a select, not a load indexed by
// the compare (measured: 0.40 -> 0.36 ms/scan).
__attribute__((always_inline)) inline void stepPlane(bool x_first, const WalkAxis& x, const WalkAxis& y, int& i, int& j,
                                                     double& tx, double& ty) {
  const double next_tx = tx + x.delta, next_ty = ty + y.delta;
  i = x_first ? i + x.step : i;
  j = x_first ? j : j + y.step;
  tx = x_first ? next_tx : tx;
  ty = x_first ? ty : next_ty;
}
}  // namespace detail

// Visits cell (i, j) and the `steps` cells after it, as visit(i, j, t_exit): t_exit is the
// parameter where the walk leaves the cell. Ties step y. Returns false if visit stopped it; i and
// j are then the last cell visited.
// Branch-free per step: which axis advances is unpredictable along a slanted ray, and a
// mispredicted branch per cell costs more than the rest of the step.
template <typename Visit>
__attribute__((always_inline)) inline bool walkPlane(int& i, int& j, WalkAxis x, WalkAxis y, int steps, Visit&& visit) {
  double tx = x.next, ty = y.next;
  for (;; --steps) {
    const bool x_first = tx < ty;
    if (!detail::keepWalking(visit, i, j, std::min(tx, ty))) return false;
    if (steps <= 0) return true;
    detail::stepPlane(x_first, x, y, i, j, tx, ty);
  }
}

// The same in 3D: visit(i, j, k, t_exit), (i, j, k) the last cell visited after it. The axis is x if t_x < t_y, else y, unless t_z is not
// above that one: then z. Selected without a branch (as in walkPlane): the branches made a tilted
// scan's rays 3x the cost of a level one's (issue 21).
template <typename Visit>
__attribute__((always_inline)) inline bool walkSpace(int& i, int& j, int& k, WalkAxis x, WalkAxis y, WalkAxis z,
                                                     int steps, Visit&& visit) {
  double tx = x.next, ty = y.next, tz = z.next;
  for (;; --steps) {
    const bool x_before_y = tx < ty;
    const double t_xy = x_before_y ? tx : ty;
    const bool z_next = !(t_xy < tz);
    if (!detail::keepWalking(visit, i, j, k, z_next ? tz : t_xy)) return false;
    if (steps <= 0) return true;
    const bool x_next = !z_next && x_before_y, y_next = !z_next && !x_before_y;
    const double next_tx = tx + x.delta, next_ty = ty + y.delta, next_tz = tz + z.delta;
    i = x_next ? i + x.step : i;
    j = y_next ? j + y.step : j;
    k = z_next ? k + z.step : k;
    tx = x_next ? next_tx : tx;
    ty = y_next ? next_ty : ty;
    tz = z_next ? next_tz : tz;
  }
}

// The same walk, cell for cell and t for t, for a segment whose z steps are few among its steps
// (a scan tilted by a degree or two: a 12 m ray changes layer a handful of times in 240 steps).
// The rare z step is a branch, predicted right almost every time; x against y stays branch-free.
// Fewer instructions per step than walkSpace, which pays for selecting z every step; for a steep
// ray (a depth camera's) the branch would be mispredicted, so traverseVoxels picks per segment.
template <typename Visit>
__attribute__((always_inline)) inline bool walkSpaceFewZ(int& i, int& j, int& k, WalkAxis x, WalkAxis y, WalkAxis z,
                                                         int steps, Visit&& visit) {
  double tx = x.next, ty = y.next, tz = z.next;
  for (;; --steps) {
    const bool x_before_y = tx < ty;
    const double t_xy = x_before_y ? tx : ty;
    if (__builtin_expect(!(t_xy < tz), 0)) {  // z next, as walkSpace decides it
      if (!detail::keepWalking(visit, i, j, k, tz)) return false;
      if (steps <= 0) return true;
      k += z.step;
      tz += z.delta;
      continue;
    }
    if (!detail::keepWalking(visit, i, j, k, t_xy)) return false;
    if (steps <= 0) return true;
    detail::stepPlane(x_before_y, x, y, i, j, tx, ty);  // as walkPlane steps
  }
}

// Octree voxels, in order, from the voxel of `from` (key from_key) to the voxel of `to` (to_key),
// both included, as visit(key, t_exit) with t_exit a fraction of the segment. Exactly one axis
// advances per step, so the end voxel is due after the keys' distance in steps; where rounding
// took another route the end voxel is visited last anyway (at t_exit 1): a beam ends at its return.
template <typename Visit>
inline void traverseVoxels(const octomap::OcTree& tree, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                           const octomap::OcTreeKey& from_key, const octomap::OcTreeKey& to_key, Visit&& visit) {
  const double res = tree.getResolution(), never = std::numeric_limits<double>::infinity();
  WalkAxis axes[3];
  int steps = 0;
  for (int d = 0; d < 3; ++d) {
    axes[d] = walkAxis(from[d], to[d], tree.keyToCoord(from_key[d]), res, never);
    steps += std::abs(int(to_key[d]) - int(from_key[d]));
  }
  int i = from_key[0], j = from_key[1], k = from_key[2];
  const auto at_key = [&visit](int vi, int vj, int vk, double t_exit) __attribute__((always_inline)) {
    visit(octomap::OcTreeKey(vi, vj, vk), t_exit);
  };
  // One z step in 16 or fewer: nearly level (the same cells either way, only the speed differs).
  if (16 * std::abs(int(to_key[2]) - int(from_key[2])) <= steps) {
    walkSpaceFewZ(i, j, k, axes[0], axes[1], axes[2], steps, at_key);
  } else {
    walkSpace(i, j, k, axes[0], axes[1], axes[2], steps, at_key);
  }
  if (i != to_key[0] || j != to_key[1] || k != to_key[2]) visit(to_key, 1.0);
}

// The same walk for a segment in one horizontal layer (from.z == to.z): the same voxels and t_exit
// as traverseVoxels gives for it (its z step never wins), in 2D.
template <typename Visit>
inline void traverseLevel(const octomap::OcTree& tree, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                          const octomap::OcTreeKey& from_key, const octomap::OcTreeKey& to_key, Visit&& visit) {
  const double res = tree.getResolution();
  constexpr double kNever = 1e300;
  const WalkAxis x = walkAxis(from.x(), to.x(), tree.keyToCoord(from_key[0]), res, kNever);
  const WalkAxis y = walkAxis(from.y(), to.y(), tree.keyToCoord(from_key[1]), res, kNever);
  const int steps = std::abs(int(to_key[0]) - int(from_key[0])) + std::abs(int(to_key[1]) - int(from_key[1]));
  const octomap::key_type z = from_key[2];
  int i = from_key[0], j = from_key[1];
  walkPlane(i, j, x, y, steps, [&visit, z](int vi, int vj, double t_exit) __attribute__((always_inline)) {
    visit(octomap::OcTreeKey(vi, vj, z), t_exit);
  });
  if (i != to_key[0] || j != to_key[1]) visit(to_key, 1.0);
}

}  // namespace octo_slice_mapper
