// The floor of one depth frame: a plane nearly perpendicular to gravity (the map frame's z axis)
// found by PCL's sample consensus among the frame's returns below the sensor.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <optional>
#include <vector>

namespace octo_slice_mapper {

struct FloorFitOptions {
  // A floor plane's normal lies within this angle of the map's z axis (rad, 5.2 degrees): a ramp
  // (wheelchair ramps rise at most 1 in 12, 4.8 degrees), a tilted mount or odometry off by a
  // few degrees still fit; a wall or a heap of clutter seldom does.
  double max_tilt = 0.09;
  // A return within this of the plane is on it (m). The samples are end-voxel means, which
  // average a Kinect's noise (one return at 3 m: about 1.5 cm). The band, twice this wide, must
  // not hold both the floor and a low step's top: wider, a plane a degree or two off level takes
  // the floor and an 8 cm step as one surface, and the step is lost to the floor.
  double inlier_distance = 0.03;
  // A plane needs this many of the frame's samples on it; fewer: the frame saw no floor.
  int min_points = 120;
  // The floor lies at least this far below the sensor (m): a camera sees no floor at its own height.
  double min_below_sensor = 0.15;
  // The frame's samples are thinned to at most this many before the fit (every k-th, in order).
  int max_samples = 1500;
  // With a previous floor, the fit first looks within this of it (m); a lower plane still wins.
  double seed_window = 0.25;
};

// n . p + d = 0 with n a unit normal pointing up (n.z > 0).
struct FloorPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double d = 0.0;
  double heightAt(double x, double y) const { return -(d + normal.x() * x + normal.y() * y) / normal.z(); }
  double distance(const Eigen::Vector3d& p) const { return normal.dot(p) + d; }  // > 0 above
  double tilt() const;  // rad between the normal and the z axis
};

struct FloorFit {
  FloorPlane plane;
  std::vector<std::size_t> inliers;  // indices into the samples given, ascending
  Eigen::Vector2d min = Eigen::Vector2d::Zero(), max = Eigen::Vector2d::Zero();  // the inliers' x-y box
};

// A plane's height where its frame saw no floor: a plane tilted by a few degrees (a Kinect's
// depth distortion, a fit through clutter) is 0.25 m off 3 m away, so it is followed only up to
// `margin` (m) beyond its inliers' box and is level outside.
struct BoundedPlane {
  FloorPlane plane;
  Eigen::Vector2d min = Eigen::Vector2d::Zero(), max = Eigen::Vector2d::Zero();
  double heightAt(double x, double y) const {
    return plane.heightAt(std::clamp(x, min.x(), max.x()), std::clamp(y, min.y(), max.y()));
  }
  static BoundedPlane of(const FloorFit& fit, double margin) {
    return {fit.plane, fit.min - Eigen::Vector2d::Constant(margin), fit.max + Eigen::Vector2d::Constant(margin)};
  }
};

// The frame's floor among `samples` (map frame returns; a frame's end-voxel means are a good
// sample: one per surface voxel): the lowest plane within max_tilt of level that min_points
// samples support, looked for near `seed` first. A table top is level too: a lower supported
// plane is always taken over it. Empty when no plane qualifies (a frame facing a wall, clutter,
// too few floor returns). Deterministic: the same samples give the same plane.
// `ground`, when given, is a point on the floor the sensor's carrier stands on (a robot's
// base_footprint): then only a plane within `ground_tolerance` of it at its x-y is the floor, so
// that neither a table nor a lower floor beyond an edge (a stairwell, a loading dock) is taken
// for it; empty when the frame shows no such plane.
std::optional<FloorFit> fitFloor(const std::vector<Eigen::Vector3d>& samples, const Eigen::Vector3d& sensor,
                                 const std::optional<FloorPlane>& seed, const FloorFitOptions& options,
                                 const std::optional<Eigen::Vector3d>& ground = std::nullopt,
                                 double ground_tolerance = 0.05);

}  // namespace octo_slice_mapper
