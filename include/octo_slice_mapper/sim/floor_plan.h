// A small known world for the simulated session: walls as segments, doors, one walking person.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "octo_slice_mapper/map_io.h"

namespace octo_slice_mapper {
namespace sim {

struct Segment {
  Eigen::Vector2d a, b;
};

constexpr double kWallHeight = 2.5;  // m, the building's walls (and the camera's ceiling)

// A wall (or a block of furniture): the rectangle spanning a -> b lengthwise and `thickness`
// across, centred on the line ab, from `bottom` to `top` (m above the floor): a table top, a
// shelf's overhang or a step is a "wall" that a 2D lidar's plane may pass above or below.
struct Wall {
  Eigen::Vector2d a, b;
  double thickness = 0.10;
  double bottom = 0.0, top = kWallHeight;
  bool crosses(double min_z, double max_z) const { return bottom <= max_z && top >= min_z; }
  std::array<Segment, 4> outline() const;
  bool contains(const Eigen::Vector2d& p) const;
};

struct Door {
  std::string name;
  Eigen::Vector2d a, b;  // the opening, between two wall ends
  bool open = true;
};

// A person walking back and forth between two points at constant speed (a disc in the plane).
struct Person {
  Eigen::Vector2d from, to;
  double speed = 0.6;    // m/s
  double radius = 0.2;   // m
  Eigen::Vector2d positionAt(double t) const;
};

constexpr double kDoorCorridorWidth = 2.0;

struct FloorPlan {
  std::vector<Wall> walls;  // static, also the ground truth (closed doors are walls)
  std::vector<Door> doors;
  std::vector<Person> people;  // dynamic, not in the ground truth
  Eigen::Vector2d min_corner, max_corner;
  // The height the simulated 2D lidar scans at: castRay() sees the walls that cross it
  // (SimulatedSession sets it to its lidar's mount height).
  double lidar_plane_z = 0.26;

  // Corridor along x with rooms north and south, three open doors, furniture, one person. Room B
  // holds 3D furniture for a depth camera: a table (top 0.69-0.72 m on four legs), a
  // cabinet whose top board overhangs at 0.45-0.60 m, above the lidar plane, and a step 0.08 m
  // high, below it.
  static FloorPlan office();
  // The lab's Figure 4: a corridor along x (kDoorCorridorWidth wide) with one open door
  // (x 4.5-5.4) in its north wall to a room; a robot passing by sees the doorway obliquely.
  static FloorPlan doorCorridor();

  // Distance from `origin` along unit `dir` to the first wall or person at time t; +inf if none.
  double castRay(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir, double t, bool with_people = true) const;
  // The static walls the lidar plane crosses, rasterised at `resolution` (100 occupied, 0 free).
  GridImage groundTruth(double resolution) const;
  // The footprint of everything static between min_z and max_z (a slice band's truth).
  GridImage groundTruthBand(double resolution, double min_z, double max_z) const;

};

}  // namespace sim
}  // namespace octo_slice_mapper
