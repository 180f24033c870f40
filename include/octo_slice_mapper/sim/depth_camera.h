// A Kinect-class depth camera in a small 3D world of boxes: the frames the cloud
// benchmark and tests insert. The world: a room (its walls, floor and ceiling seen from inside)
// with furniture as solid boxes: a table (top at 0.72 m on four legs), a shelf whose overhang
// hangs above the lidar's plane, and a low step below it.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <random>
#include <vector>

#include "octo_slice_mapper/sim/floor_plan.h"

namespace octo_slice_mapper {
namespace sim {

struct Box {
  Eigen::Vector3d min, max;
};

// A ramp across the whole room along x: the floor rises evenly from x0 to x1 by `height` and
// stays that high beyond x1 (a platform up to the room's wall).
struct Ramp {
  double x0 = 0.0, x1 = 0.0, height = 0.0;
};

struct BoxScene {
  Box room;                 // the inside of the room: rays end where they leave it
  std::vector<Box> solids;  // furniture: rays end where they enter one
  std::optional<Ramp> ramp;  // rays end where they meet it too

  // The floor's height at x: the room's bottom, or the ramp's surface.
  double floorAt(double x) const;
  // The office room with a ramp at x 4-5 m up to 0.10 m (5.7 degrees), a platform beyond; the
  // step is not in it (it stood there).
  static BoxScene officeRoomWithRamp();

  // 6 x 5 x 2.5 m, corner at the origin: table at (2.5..3.7, 1.5..2.3), shelf against the
  // north wall with its overhang at 0.45..0.60 m, a step 0.08 m high near the door.
  static BoxScene officeRoom();
  // A floor plan in 3D: its bounds from the floor to kWallHeight as the room, each wall (all of
  // them axis-aligned) a solid from its bottom to its top. People are not in it.
  static BoxScene of(const FloorPlan& plan);
  // Distance along unit `dir` from `origin` (inside the room) to the first surface; +inf if none.
  double castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const;
  // Whether a point lies inside a solid (for ground-truth footprints).
  bool solidAt(const Eigen::Vector3d& p) const;
};

// Kinect v1 / Asus Xtion: 640 x 480, 57 x 43 deg, 0.5-4.5 m; depth noise sigma(z) =
// 0.0012 + 0.0019 (z - 0.4)^2 m (Nguyen, Izadi, Lovell 2012, for the Kinect's axial noise).
struct DepthCameraSpec {
  int width = 640, height = 480;
  double horizontal_fov = 0.9948, vertical_fov = 0.7505;  // rad
  double min_range = 0.5, max_range = 4.5;                 // of the depth (z in the optical frame), m
  bool noise = true;
  // Mixed pixels at depth edges, as a Kinect gives them: where a pixel and its right or lower
  // neighbour differ by more than 0.1 m, the pixel reads, with this probability, a depth between
  // the two (a point floating in the air between an edge and what lies behind it).
  double flying_pixel_probability = 0.0;
};

// The TurtleBot 2's depth camera on its base_link: 0.10 m forward, 0.30 m up, pitched down.
struct CameraMount {
  double x = 0.10, z = 0.30;  // m
  double pitch = 0.10;        // rad, down: the table top at 0.72 m is in view from 1.5 m on
  double rate_hz = 2.0;
  // The simulator's bag binned to 160 x 120: at 640 x 480 and 30 Hz the office tour would be a
  // 9 GB bag. The benchmark and the tests use full frames.
  DepthCameraSpec spec = binned(4);
  static DepthCameraSpec binned(int factor) {
    DepthCameraSpec s;
    s.width /= factor;
    s.height /= factor;
    return s;
  }
};
// base_link -> camera_link (x forward, z up, pitched), and camera_link -> its optical frame (REP 103).
Eigen::Isometry3d cameraLinkOnBase(const CameraMount& mount);
Eigen::Isometry3d opticalOnCameraLink();
// The optical frame in the world for a base at (x, y) facing `yaw`: base * camera_link * optical.
Eigen::Isometry3d opticalOnRobot(const CameraMount& mount, double x, double y, double yaw);

// One organized frame in the camera's optical frame (REP 103: z forward, x right, y down), row by
// row; NaN where the camera gets no depth (nothing within range).
std::vector<Eigen::Vector3f> depthFrame(const BoxScene& scene, const Eigen::Isometry3d& optical_in_world,
                                        const DepthCameraSpec& spec, std::mt19937* rng);

// The optical frame of a camera at `position` looking along `yaw` (rad, about z) and pitched
// down by `pitch` (rad): the body-to-optical rotation of REP 103 applied.
Eigen::Isometry3d opticalPose(const Eigen::Vector3d& position, double yaw, double pitch);

}  // namespace sim
}  // namespace octo_slice_mapper
