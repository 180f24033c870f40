// The one grid walk of the project (Amanatides & Woo): the cells a straight segment crosses, in
// order, each with where the segment leaves it. Scan insertion walks octree voxels with it in 3D,
// the global pass walks its 2D grid with it.
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
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
}  // namespace detail

// A walk's cell is one linear index: cell (i, j, k) is i * stride_x + j * stride_y + k * stride_z,
// with strides of the caller's choosing (an OcTree key packed per axis, a window's cells), so that
// a step adds one number and the visitor gets the index it stores at rather than coordinates to
// combine (per voxel, combining a key into a window's index costs more than the step).
// Index is unsigned: a step backwards wraps, as it must.
template <typename Index>
struct AxisSteps {
  Index x = 0, y = 0, z = 0;  // what one step along each axis (in its walk's direction) adds
  // For the axes of a walk (their directions) and the index strides of one cell per axis.
  static AxisSteps of(const WalkAxis& ax, const WalkAxis& ay, const WalkAxis& az, Index sx, Index sy, Index sz) {
    return {along(ax, sx), along(ay, sy), along(az, sz)};
  }
  static Index along(const WalkAxis& axis, Index stride) { return axis.step < 0 ? Index(0) - stride : stride; }
};

// Visits cell p and the `steps` cells after it in the plane, as visit(p, t_exit): t_exit is the
// parameter where the walk leaves the cell. Ties step y. Returns false if visit stopped it; p is
// then the last cell visited. p is a linear index or anything a step can be added to (+=).
// Which axis advances is unpredictable along a slanted ray: the step is written as selects, so
// that the loop-carried chain can be a compare and a select (measurably faster than branches). GCC
// 12 turns them into a branch in the tracer's loop all the same; masked adds instead did not
// measure faster.
template <typename Index, typename Visit>
__attribute__((always_inline)) inline bool walkPlane(Index& p, const WalkAxis& x, const WalkAxis& y, Index step_x,
                                                     Index step_y, int steps, Visit&& visit) {
  double tx = x.next, ty = y.next;
  for (;; --steps) {
    const bool x_first = tx < ty;
    if (!detail::keepWalking(visit, p, std::min(tx, ty))) return false;
    if (steps <= 0) return true;
    const double next_tx = tx + x.delta, next_ty = ty + y.delta;
    p += x_first ? step_x : step_y;
    tx = x_first ? next_tx : tx;
    ty = x_first ? ty : next_ty;
  }
}

// The same in a 2D grid of cells (i, j), as the global pass walks it: visit(i, j, t_exit), and
// (i, j) the last cell visited after it.
template <typename Visit>
inline bool walkPlane(int& i, int& j, const WalkAxis& x, const WalkAxis& y, int steps, Visit&& visit) {
  // The position of the walk above: a step adds {x.step, 0} or {0, y.step} (packed into one
  // 64-bit index, the pass's walks take more instructions).
  struct Cell {
    int i, j;
    Cell& operator+=(const Cell& step) {
      i += step.i;
      j += step.j;
      return *this;
    }
  };
  Cell p{i, j};
  const bool done = walkPlane(p, x, y, Cell{x.step, 0}, Cell{0, y.step}, steps,
                              [&](const Cell& c, double t_exit) __attribute__((always_inline)) {
                                return detail::keepWalking(visit, c.i, c.j, t_exit);
                              });
  i = p.i;
  j = p.j;
  return done;
}

namespace detail {
// walkSpace's loop, with the axes' next crossings in the caller's tx, ty, tz. kVisitLast: visits
// p and the `steps` cells after it, p the last one visited. Otherwise visits p and the steps - 1
// cells after it and takes one more step: p (and tx, ty, tz) are then at the next cell, not
// visited (none visited, and nothing changed, for steps <= 0).
template <bool kVisitLast, typename Index, typename Visit>
__attribute__((always_inline)) inline bool walkSpaceLoop(Index& p, double& tx, double& ty, double& tz,
                                                         const WalkAxis& x, const WalkAxis& y, const WalkAxis& z,
                                                         const AxisSteps<Index>& step, int steps, Visit&& visit) {
  for (;; --steps) {
    if constexpr (!kVisitLast) {
      if (steps <= 0) return true;
    }
    const bool x_before_y = tx < ty;
    const double t_xy = x_before_y ? tx : ty;
    const bool z_next = !(t_xy < tz);
    if (!keepWalking(visit, p, z_next ? tz : t_xy)) return false;
    if constexpr (kVisitLast) {
      if (steps <= 0) return true;
    }
    const bool x_next = !z_next && x_before_y, y_next = !z_next && !x_before_y;
    const double next_tx = tx + x.delta, next_ty = ty + y.delta, next_tz = tz + z.delta;
    p += z_next ? step.z : x_before_y ? step.x : step.y;
    tx = x_next ? next_tx : tx;
    ty = y_next ? next_ty : ty;
    tz = z_next ? next_tz : tz;
  }
}
}  // namespace detail

// The same in 3D: visit(p, t_exit), p the last cell visited after it. The axis is x if t_x < t_y,
// else y, unless t_z is not above that one: then z. Selected without a branch (as in walkPlane):
// the branches made a tilted scan's rays 3x the cost of a level one's.
template <typename Index, typename Visit>
__attribute__((always_inline)) inline bool walkSpace(Index& p, const WalkAxis& x, const WalkAxis& y, const WalkAxis& z,
                                                     const AxisSteps<Index>& step, int steps, Visit&& visit) {
  double tx = x.next, ty = y.next, tz = z.next;
  return detail::walkSpaceLoop<true>(p, tx, ty, tz, x, y, z, step, steps, visit);
}

// OcTree keys as walk indices, 16 bits per axis (keys are 16-bit): for walks that hand on keys.
struct PackedKeys {
  using Index = std::uint64_t;
  static Index indexOf(const octomap::OcTreeKey& key) {
    return Index{key[0]} | Index{key[1]} << 16 | Index{key[2]} << 32;
  }
  static octomap::OcTreeKey keyOf(Index p) {
    return octomap::OcTreeKey(static_cast<octomap::key_type>(p), static_cast<octomap::key_type>(p >> 16),
                              static_cast<octomap::key_type>(p >> 32));
  }
  static constexpr Index stride(int axis) { return Index{1} << (16 * axis); }
};

namespace detail {
// Whether walkSpace, taking `steps` = n[0] + n[1] + n[2] steps along these axes, could step an
// axis past its end key: whether some axis' first crossing after its n[d] due ones comes no later
// than another's last due one. The walk takes the earliest crossing, so while every extra
// crossing comes after every due one it takes exactly the due ones. Exact arithmetic rules that
// out but for a segment ending on a cell boundary (two crossings at its end: one due, one not);
// rounding adds near-ties there and, on an axis the segment barely moves along, crossings that
// coordToKey disagrees with. The margin covers the walk summing `delta` rather than multiplying.
inline bool mayLeaveBox(const WalkAxis (&axes)[3], const int (&n)[3]) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double last_due = -kInf, first_extra = kInf;
  for (int d = 0; d < 3; ++d) {
    // (n - 1) * delta only for n > 1 (then delta is finite: the segment spans a voxel); for one
    // step delta may be infinite, and 0 * inf is NaN.
    const double last = axes[d].next + (n[d] > 1 ? double(n[d] - 1) * axes[d].delta : 0.0);
    last_due = std::max(last_due, n[d] > 0 ? last : -kInf);
    first_extra = std::min(first_extra, n[d] > 0 ? last + axes[d].delta : axes[d].next);
  }
  return !(first_extra > last_due + 1e-9 * std::max(1.0, last_due));
}

// The last steps of a walk mayLeaveBox flags, from the state its first total - 3 steps left (p the
// next cell, tx, ty, tz the axes' next crossings): axis d takes exactly n[d] steps in all, so the
// walk ends on the end voxel. Here t_exit is at most 1 (past 1, a crossing's parameter is
// rounding), and the next cell is chosen among the axes with steps left. What each axis took so
// far is worked out from where its parameter got to (a sum of `delta`s: off by far less than half
// a step).
template <typename Index, typename Visit>
__attribute__((always_inline)) inline bool lastStepsCounted(Index& p, double tx, double ty, double tz,
                                                            const WalkAxis& ax, const WalkAxis& ay,
                                                            const WalkAxis& az, const AxisSteps<Index>& step,
                                                            const int (&n)[3], Visit&& visit) {
  constexpr double kNever = std::numeric_limits<double>::infinity();
  const auto taken = [](const WalkAxis& a, double t) {
    if (t == a.next) return 0;
    return std::isfinite(a.delta) ? static_cast<int>(std::lround((t - a.next) / a.delta)) : 1;
  };
  int nx = n[0] - taken(ax, tx), ny = n[1] - taken(ay, ty), nz = n[2] - taken(az, tz);
  for (int steps = std::min(n[0] + n[1] + n[2], 3);; --steps) {
    const double ex = nx > 0 ? tx : kNever, ey = ny > 0 ? ty : kNever, ez = nz > 0 ? tz : kNever;
    const bool x_before_y = ex < ey;
    const double t_xy = x_before_y ? ex : ey;
    const bool z_next = !(t_xy < ez);
    if (!keepWalking(visit, p, std::min(z_next ? ez : t_xy, 1.0))) return false;
    if (steps <= 0) return true;
    const bool x_next = !z_next && x_before_y, y_next = !z_next && !x_before_y;
    p += z_next ? step.z : x_before_y ? step.x : step.y;
    tx = x_next ? tx + ax.delta : tx;
    ty = y_next ? ty + ay.delta : ty;
    tz = z_next ? tz + az.delta : tz;
    nx -= x_next, ny -= y_next, nz -= z_next;
  }
}
}  // namespace detail

// Octree voxels, in order, from the voxel of `from` (key from_key) to the voxel of `to` (to_key),
// both included, as visit(index, t_exit) with t_exit a fraction of the segment and index the
// voxel's in `cells` (PackedKeys, or a window with the same members). Exactly one axis advances
// per step, and each axis only as far as its end key: every voxel visited lies in the key box of
// from_key and to_key (a window over that box is never left), and the last is to_key's.
// False if visit stopped the walk (the end voxel is then not visited).
// Only an axis' last due crossing can come as late as an extra one (mayLeaveBox; two crossings of
// an axis are at least 1/65 536 of the segment apart, rounding far less): at most three, so the
// walk's first total - 3 crossings are due ones whatever the walk, taken as walkSpace takes them
// (an axis without steps never takes one). Whether the last three need counting is asked only of
// the walks that get there: most of a depth frame's walks stop in shared free space long before.
// (A simulated camera placed on voxel corners sends a fifth of its walks to the counted steps;
// real data, none of a TUM sequence's.)
template <typename Cells, typename Visit>
inline bool traverseVoxels(const octomap::OcTree& tree, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                           const octomap::OcTreeKey& from_key, const octomap::OcTreeKey& to_key, const Cells& cells,
                           Visit&& visit) {
  using Index = typename Cells::Index;
  const double res = tree.getResolution(), never = std::numeric_limits<double>::infinity();
  WalkAxis axes[3];
  int n[3];
  for (int d = 0; d < 3; ++d) {
    axes[d] = walkAxis(from[d], to[d], tree.keyToCoord(from_key[d]), res, never);
    n[d] = std::abs(int(to_key[d]) - int(from_key[d]));
  }
  const auto step = AxisSteps<Index>::of(axes[0], axes[1], axes[2], cells.stride(0), cells.stride(1), cells.stride(2));
  Index p = cells.indexOf(from_key);
  const WalkAxis ax = n[0] > 0 ? axes[0] : WalkAxis{axes[0].step, never, never};
  const WalkAxis ay = n[1] > 0 ? axes[1] : WalkAxis{axes[1].step, never, never};
  const WalkAxis az = n[2] > 0 ? axes[2] : WalkAxis{axes[2].step, never, never};
  double tx = ax.next, ty = ay.next, tz = az.next;
  const int total = n[0] + n[1] + n[2];
  if (!detail::walkSpaceLoop<false>(p, tx, ty, tz, ax, ay, az, step, total - 3, visit)) return false;
  if (detail::mayLeaveBox(axes, n)) return detail::lastStepsCounted(p, tx, ty, tz, ax, ay, az, step, n, visit);
  // An axis without steps has its crossing back: it comes after every due one, so the walk takes
  // the same steps, and the last voxel's t_exit is walkSpace's own.
  tx = n[0] > 0 ? tx : axes[0].next, ty = n[1] > 0 ? ty : axes[1].next, tz = n[2] > 0 ? tz : axes[2].next;
  return detail::walkSpaceLoop<true>(p, tx, ty, tz, axes[0], axes[1], axes[2], step, std::min(total, 3), visit);
}

}  // namespace octo_slice_mapper
