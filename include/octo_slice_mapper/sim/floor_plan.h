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

// A wall (or a block of furniture): the rectangle spanning a -> b lengthwise and `thickness`
// across, centred on the line ab.
struct Wall {
  Eigen::Vector2d a, b;
  double thickness = 0.10;
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

  // Corridor along x with rooms north and south, three open doors, furniture, one person.
  static FloorPlan office();
  // The lab's Figure 4: a corridor along x (kDoorCorridorWidth wide) with one open door
  // (x 4.5-5.4) in its north wall to a room; a robot passing by sees the doorway obliquely.
  static FloorPlan doorCorridor();

  // Distance from `origin` along unit `dir` to the first wall or person at time t; +inf if none.
  double castRay(const Eigen::Vector2d& origin, const Eigen::Vector2d& dir, double t, bool with_people = true) const;
  // The static walls rasterised at `resolution` (100 occupied, 0 free).
  GridImage groundTruth(double resolution) const;

};

}  // namespace sim
}  // namespace octo_slice_mapper
