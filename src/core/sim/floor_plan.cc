#include "octo_slice_mapper/sim/floor_plan.h"

#include <cmath>
#include <limits>

namespace octo_slice_mapper {
namespace sim {
namespace {

// Ray (o + s d, s >= 0) against segment ab; returns s or +inf.
double raySegment(const Eigen::Vector2d& o, const Eigen::Vector2d& d, const Segment& seg) {
  const Eigen::Vector2d e = seg.b - seg.a;
  const double denom = d.x() * e.y() - d.y() * e.x();
  if (std::abs(denom) < 1e-12) return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d w = seg.a - o;
  const double s = (w.x() * e.y() - w.y() * e.x()) / denom;
  const double u = (w.x() * d.y() - w.y() * d.x()) / denom;
  if (s < 0.0 || u < 0.0 || u > 1.0) return std::numeric_limits<double>::infinity();
  return s;
}

double rayDisc(const Eigen::Vector2d& o, const Eigen::Vector2d& d, const Eigen::Vector2d& c, double radius) {
  const Eigen::Vector2d oc = o - c;
  const double b = oc.dot(d);
  const double disc = b * b - (oc.squaredNorm() - radius * radius);
  if (disc < 0.0) return std::numeric_limits<double>::infinity();
  const double s = -b - std::sqrt(disc);
  return s >= 0.0 ? s : std::numeric_limits<double>::infinity();
}

// A solid block from (x0, y0) to (x1, y1) as one wide "wall", from `bottom` to `top`.
void addBox(std::vector<Wall>* walls, double x0, double y0, double x1, double y1, double bottom = 0.0,
            double top = kWallHeight) {
  const double yc = 0.5 * (y0 + y1);
  walls->push_back({{x0, yc}, {x1, yc}, y1 - y0, bottom, top});
}

}  // namespace

std::array<Segment, 4> Wall::outline() const {
  const Eigen::Vector2d dir = (b - a).normalized();
  const Eigen::Vector2d n = Eigen::Vector2d(-dir.y(), dir.x()) * (0.5 * thickness);
  return {Segment{a + n, b + n}, Segment{b + n, b - n}, Segment{b - n, a - n}, Segment{a - n, a + n}};
}

bool Wall::contains(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d ab = b - a;
  const double length = ab.norm();
  const Eigen::Vector2d dir = ab / length;
  const Eigen::Vector2d ap = p - a;
  const double along = ap.dot(dir), across = ap.x() * dir.y() - ap.y() * dir.x();
  return along >= 0.0 && along <= length && std::abs(across) <= 0.5 * thickness;
}

Eigen::Vector2d Person::positionAt(double t) const {
  const double length = (to - from).norm();
  if (length <= 0.0 || speed <= 0.0) return from;
  const double period = 2.0 * length / speed;
  double phase = std::fmod(t, period) * speed;
  if (phase > length) phase = 2.0 * length - phase;
  return from + (to - from) * (phase / length);
}

FloorPlan FloorPlan::office() {
  FloorPlan plan;
  auto& w = plan.walls;
  // Corridor y in [0, 2], x in [0, 14]. North wall with doors to room A (x 2.0-2.9) and room B (9.0-9.9).
  w.push_back({{0, 2}, {2.0, 2}});
  w.push_back({{2.9, 2}, {9.0, 2}});
  w.push_back({{9.9, 2}, {14, 2}});
  // South wall with the door to room C (x 6.0-6.9).
  w.push_back({{0, 0}, {6.0, 0}});
  w.push_back({{6.9, 0}, {14, 0}});
  // Outer walls of corridor and rooms A, B (y up to 8), and the wall between A and B.
  w.push_back({{0, 0}, {0, 8}});
  w.push_back({{14, 0}, {14, 8}});
  w.push_back({{0, 8}, {14, 8}});
  w.push_back({{6, 2}, {6, 8}});
  // Room C: x in [4, 10], y in [-4, 0].
  w.push_back({{4, 0}, {4, -4}});
  w.push_back({{10, 0}, {10, -4}});
  w.push_back({{4, -4}, {10, -4}});
  // Furniture: a cabinet in room A, a pillar in room B, a table block in room C.
  addBox(&w, 3.5, 5.0, 4.5, 6.0);
  addBox(&w, 10.8, 5.0, 11.2, 5.4);
  addBox(&w, 8.2, -3.6, 9.4, -3.0);
  // Room B's 3D furniture, along the tour's path there (the camera looks at each on the way). The
  // table: a 3 cm top on four 5 cm legs; the lidar sees the legs only.
  addBox(&w, 9.0, 5.6, 10.2, 6.4, 0.69, 0.72);
  for (double x : {9.05, 10.1}) {
    for (double y : {5.65, 6.3}) addBox(&w, x, y, x + 0.05, y + 0.05, 0.0, 0.69);
  }
  // A cabinet against the north wall, its top board reaching 0.35 m further out at 0.45-0.60 m.
  addBox(&w, 11.8, 7.65, 13.2, 7.95, 0.0, 1.8);
  addBox(&w, 11.8, 7.3, 13.2, 7.65, 0.45, 0.60);
  // A step (a low platform) beside the path into room B.
  addBox(&w, 9.9, 2.9, 10.9, 3.5, 0.0, 0.08);
  plan.doors = {{"room_a", {2.0, 2}, {2.9, 2}, true},
                {"room_b", {9.0, 2}, {9.9, 2}, true},
                {"room_c", {6.0, 0}, {6.9, 0}, true}};
  plan.people.push_back({{3.5, 1.6}, {12.5, 1.6}, 0.6, 0.2});
  plan.min_corner = {-0.5, -4.5};
  plan.max_corner = {14.5, 8.5};
  return plan;
}

FloorPlan FloorPlan::doorCorridor() {
  FloorPlan plan;
  auto& w = plan.walls;
  const double y = kDoorCorridorWidth;
  w.push_back({{0, 0}, {10, 0}});          // south wall
  w.push_back({{0, y}, {4.5, y}});         // north wall, west of the door
  w.push_back({{5.4, y}, {10, y}});        // north wall, east of the door
  w.push_back({{0, 0}, {0, y}});
  w.push_back({{10, 0}, {10, y}});
  w.push_back({{3.0, y}, {3.0, y + 3.0}});  // the room behind the door
  w.push_back({{7.0, y}, {7.0, y + 3.0}});
  w.push_back({{3.0, y + 3.0}, {7.0, y + 3.0}});
  plan.doors = {{"door", {4.5, y}, {5.4, y}, true}};
  plan.min_corner = {-0.5, -0.5};
  plan.max_corner = {10.5, y + 3.5};
  return plan;
}

double FloorPlan::castRay(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir, double t, bool with_people) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Wall& w : walls) {
    if (!w.crosses(lidar_plane_z, lidar_plane_z)) continue;
    for (const Segment& s : w.outline()) best = std::min(best, raySegment(origin, dir, s));
  }
  if (with_people) {
    for (const Person& p : people) best = std::min(best, rayDisc(origin, dir, p.positionAt(t), p.radius));
  }
  return best;
}

GridImage FloorPlan::groundTruth(double resolution) const {
  return groundTruthBand(resolution, lidar_plane_z, lidar_plane_z);
}

GridImage FloorPlan::groundTruthBand(double resolution, double min_z, double max_z) const {
  GridImage grid;
  grid.resolution = resolution;
  grid.origin_x = min_corner.x();
  grid.origin_y = min_corner.y();
  grid.width = static_cast<int>(std::ceil((max_corner.x() - min_corner.x()) / resolution));
  grid.height = static_cast<int>(std::ceil((max_corner.y() - min_corner.y()) / resolution));
  grid.cells.assign(std::size_t(grid.width) * grid.height, 0);
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const Eigen::Vector2d centre(grid.origin_x + (i + 0.5) * resolution, grid.origin_y + (j + 0.5) * resolution);
      for (const Wall& w : walls) {
        if (w.crosses(min_z, max_z) && w.contains(centre)) {
          grid.cells[std::size_t(j) * grid.width + i] = 100;
          break;
        }
      }
    }
  }
  return grid;
}

}  // namespace sim
}  // namespace octo_slice_mapper
