// A deterministic simulated TurtleBot run through a FloorPlan: poses over time and Hokuyo-like scans.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "octo_slice_mapper/scan.h"
#include "octo_slice_mapper/sim/floor_plan.h"

namespace octo_slice_mapper {
namespace sim {

struct Pose2D {
  double t = 0.0, x = 0.0, y = 0.0, yaw = 0.0;
  double v = 0.0, w = 0.0;  // forward and angular speed at this instant (for odometry messages)
};

// Hokuyo URG-04LX-like: 682 beams of 2*pi/1024 rad over ~240 deg, 5.6 m.
struct LidarSpec {
  float angle_min = -2.08621f;
  float angle_increment = 0.00613592f;
  int beams = 682;
  float range_min = 0.02f;
  float range_max = 5.6f;
  double rate_hz = 10.0;
  double noise_sigma_near = 0.01;    // m, up to 1 m
  double noise_fraction_far = 0.01;  // of the range beyond 1 m
  double dropout_probability = 0.005;       // reading 0.0 (below range_min), driver-style error
  double nan_probability = 0.003;
  // Dark or glass surfaces that return nothing; off by default (they clear space through walls).
  double spurious_no_return_probability = 0.0;
  // Width of each beam's cone (rad): the reading is the nearest obstacle anywhere in it, like a
  // sonar. 0 = a laser's thin beam.
  double beam_width = 0.0;
  // Laser mount on base_link (the lab's TurtleBot: 0.10 m forward, 0.26 m up), and a yaw and
  // sideways offset as real mounts have.
  double mount_x = 0.10, mount_z = 0.26;
  double mount_y = 0.0, mount_yaw = 0.0;
  // A REP 117 driver: no return as +inf, too close (the dropouts) as -inf. Else the pre-REP
  // style: no return as range_max, dropouts as 0.0.
  bool rep117 = false;
};

struct SessionSpec {
  std::vector<Eigen::Vector2d> waypoints;  // base_footprint path; drives straight, turns in place
  double linear_speed = 0.5;               // m/s
  double angular_speed = 1.2;              // rad/s
  double pose_rate_hz = 50.0;              // odometry / tf rate
  std::uint32_t seed = 42;
  LidarSpec lidar;

  // A tour of FloorPlan::office(): corridor, rooms A, C and B through their doors, back down the corridor.
  static SessionSpec officeTour();
  // Straight down FloorPlan::doorCorridor() past the door with a ring of 24 sonar-like range
  // sensors: 20 deg cones, 15 deg apart, 5 m.
  static SessionSpec corridorPass();
  // The office tour as a real TurtleBot records it: a REP 117 driver, a lidar mounted
  // 20 deg yawed and 3 cm to the side. (The odometry's drift and tilt are DeadReckoning's.)
  static SessionSpec realRobotTour();
};

// Odometry as a real robot integrates it: the true motion's increments with a scale error, a
// yaw-rate bias and noise (so the odom frame drifts away from the world), and an IMU-fused
// attitude with about a degree of pitch and roll and a base height that moves by centimetres.
struct DeadReckoning {
  // A gyro-fused TurtleBot's: wheels 0.3 % off, the gyro's scale 0.2 % and bias 0.02 deg/s.
  // (1 % and 0.1 deg/s turned the office tour's map 15 deg by its end.)
  double distance_scale = 1.003;
  double yaw_scale = 0.998;
  double yaw_bias = 0.0003;        // rad/s
  double noise_per_step = 0.0003;  // m and rad, per odometry step
  double tilt = 0.017;            // rad, amplitude of pitch and roll
  double height = 0.02;           // m, amplitude of the base height
  std::uint32_t seed = 7;
};

struct Pose3D {
  double t = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();  // base_footprint in odom
};

// The odometry poses for the true `poses` (the first one is where odom starts).
std::vector<Pose3D> deadReckoned(const std::vector<Pose2D>& poses, const DeadReckoning& model);

// A corrected log's poses: a SLAM system's, off the true ones by a few centimetres and a fraction
// of a degree, independently from scan to scan (where dead reckoning's errors add up).
struct PoseErrors {
  double sigma_xy = 0.02;                   // m, in x and in y
  double sigma_yaw = 0.5 * M_PI / 180.0;    // rad
  std::uint32_t seed = 11;
};
// Moves each scan's recorded sensor pose by such errors (turned about its own position); its
// readings stay those taken where it really was.
void addPoseErrors(std::vector<Scan>* scans, const PoseErrors& errors);

class SimulatedSession {
 public:
  SimulatedSession(const FloorPlan& plan, const SessionSpec& spec);

  // Robot poses at the odometry rate, from the first waypoint to the last.
  const std::vector<Pose2D>& poses() const { return poses_; }
  double duration() const { return poses_.empty() ? 0.0 : poses_.back().t; }
  Pose2D poseAt(double t) const;  // interpolated
  // Laser pose in the odom/map frame for a base pose.
  Eigen::Isometry3d laserPose(const Pose2D& base) const;
  // Times at which scans are taken.
  std::vector<double> scanTimes() const;
  // The scan at time t (noise drawn from `rng`, so call in time order for a reproducible run).
  Scan scanAt(double t, std::mt19937* rng) const;
  // All scans of the session in order, with the default seed.
  std::vector<Scan> allScans() const;

  const FloorPlan& plan() const { return plan_; }
  const SessionSpec& spec() const { return spec_; }

 private:
  FloorPlan plan_;
  SessionSpec spec_;
  std::vector<Pose2D> poses_;
};

}  // namespace sim
}  // namespace octo_slice_mapper
