#include "octo_slice_mapper/sim/session.h"

#include <cmath>

namespace octo_slice_mapper {
namespace sim {
namespace {

double wrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

// A motion primitive: turn in place (w != 0) or drive straight (v != 0) for `duration`.
struct Motion {
  double duration, v, w;
};

}  // namespace

SessionSpec SessionSpec::officeTour() {
  SessionSpec spec;
  spec.waypoints = {{1.0, 1.0},  {2.45, 1.0}, {2.45, 4.5}, {1.5, 6.5},  {5.0, 7.0},  {5.0, 3.5},
                    {2.45, 3.5}, {2.45, 1.0}, {6.45, 1.0}, {6.45, -2.0}, {8.0, -2.2}, {6.45, -1.5},
                    {6.45, 1.0}, {9.45, 1.0}, {9.45, 4.0}, {12.5, 4.5}, {12.5, 7.0}, {8.0, 7.0},
                    {8.0, 4.0},  {9.45, 3.5}, {9.45, 1.0}, {13.0, 1.0}, {1.0, 0.8}};
  return spec;
}

SessionSpec SessionSpec::realRobotTour() {
  SessionSpec spec = officeTour();
  spec.lidar.rep117 = true;
  spec.lidar.mount_yaw = 0.349;  // 20 deg
  spec.lidar.mount_y = 0.03;
  return spec;
}

SessionSpec SessionSpec::corridorPass() {
  SessionSpec spec;
  spec.waypoints = {{0.6, 0.5 * kDoorCorridorWidth}, {9.4, 0.5 * kDoorCorridorWidth}};
  spec.linear_speed = 0.4;
  spec.lidar.beams = 24;
  spec.lidar.angle_min = static_cast<float>(-M_PI);
  spec.lidar.angle_increment = static_cast<float>(2.0 * M_PI / 24.0);
  spec.lidar.beam_width = 20.0 * M_PI / 180.0;
  spec.lidar.range_max = 5.0f;
  spec.lidar.dropout_probability = 0.0;
  spec.lidar.nan_probability = 0.0;
  spec.seed = 11;
  return spec;
}

SimulatedSession::SimulatedSession(const FloorPlan& plan, const SessionSpec& spec) : plan_(plan), spec_(spec) {
  plan_.lidar_plane_z = spec.lidar.mount_z;  // the 2D world the lidar sees is its plane's
  if (spec.waypoints.size() < 2) return;
  std::vector<Motion> motions;
  double yaw = std::atan2(spec.waypoints[1].y() - spec.waypoints[0].y(), spec.waypoints[1].x() - spec.waypoints[0].x());
  const double start_yaw = yaw;
  for (std::size_t k = 1; k < spec.waypoints.size(); ++k) {
    const Eigen::Vector2d delta = spec.waypoints[k] - spec.waypoints[k - 1];
    const double heading = std::atan2(delta.y(), delta.x());
    const double turn = wrapAngle(heading - yaw);
    if (std::abs(turn) > 1e-9) motions.push_back({std::abs(turn) / spec.angular_speed, 0.0, std::copysign(spec.angular_speed, turn)});
    motions.push_back({delta.norm() / spec.linear_speed, spec.linear_speed, 0.0});
    yaw = heading;
  }
  const double dt = 1.0 / spec.pose_rate_hz;
  Pose2D pose{0.0, spec.waypoints[0].x(), spec.waypoints[0].y(), start_yaw, 0.0, 0.0};
  poses_.push_back(pose);
  std::size_t m = 0;
  double left = motions.empty() ? 0.0 : motions[0].duration;
  while (m < motions.size()) {
    // Integrate exactly over dt, possibly across primitive boundaries.
    double remaining = dt;
    while (remaining > 1e-12 && m < motions.size()) {
      const double step = std::min(remaining, left);
      const Motion& mo = motions[m];
      pose.x += mo.v * std::cos(pose.yaw) * step;
      pose.y += mo.v * std::sin(pose.yaw) * step;
      pose.yaw = wrapAngle(pose.yaw + mo.w * step);
      pose.v = mo.v;
      pose.w = mo.w;
      remaining -= step;
      left -= step;
      if (left <= 1e-12 && ++m < motions.size()) left = motions[m].duration;
    }
    pose.t += dt - remaining;
    poses_.push_back(pose);
  }
  poses_.back().v = poses_.back().w = 0.0;
}

Pose2D SimulatedSession::poseAt(double t) const {
  if (poses_.empty()) return {};
  if (t <= poses_.front().t) return poses_.front();
  if (t >= poses_.back().t) return poses_.back();
  const double dt = 1.0 / spec_.pose_rate_hz;
  std::size_t k = std::min(poses_.size() - 2, static_cast<std::size_t>(t / dt));
  while (k + 1 < poses_.size() && poses_[k + 1].t < t) ++k;
  while (k > 0 && poses_[k].t > t) --k;
  const Pose2D& a = poses_[k];
  const Pose2D& b = poses_[k + 1];
  const double s = (b.t > a.t) ? (t - a.t) / (b.t - a.t) : 0.0;
  Pose2D p = a;
  p.t = t;
  p.x = a.x + s * (b.x - a.x);
  p.y = a.y + s * (b.y - a.y);
  p.yaw = wrapAngle(a.yaw + s * wrapAngle(b.yaw - a.yaw));
  return p;
}

Eigen::Isometry3d SimulatedSession::laserPose(const Pose2D& base) const {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(base.x, base.y, 0.0));
  pose.rotate(Eigen::AngleAxisd(base.yaw, Eigen::Vector3d::UnitZ()));
  pose.translate(Eigen::Vector3d(spec_.lidar.mount_x, spec_.lidar.mount_y, spec_.lidar.mount_z));
  pose.rotate(Eigen::AngleAxisd(spec_.lidar.mount_yaw, Eigen::Vector3d::UnitZ()));
  return pose;
}

std::vector<double> SimulatedSession::scanTimes() const {
  std::vector<double> times;
  const double period = 1.0 / spec_.lidar.rate_hz;
  for (double t = period; t <= duration(); t += period) times.push_back(t);
  return times;
}

Scan SimulatedSession::scanAt(double t, std::mt19937* rng) const {
  const LidarSpec& lidar = spec_.lidar;
  Scan scan;
  scan.stamp = t;
  scan.sensor_pose = laserPose(poseAt(t));
  scan.angle_min = lidar.angle_min;
  scan.angle_increment = lidar.angle_increment;
  scan.range_min = lidar.range_min;
  scan.range_max = lidar.range_max;
  scan.ranges.resize(static_cast<std::size_t>(lidar.beams));
  const Eigen::Vector2d origin = scan.sensor_pose.translation().head<2>();
  const double yaw = std::atan2(scan.sensor_pose.linear()(1, 0), scan.sensor_pose.linear()(0, 0));
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int i = 0; i < lidar.beams; ++i) {
    const double a = yaw + lidar.angle_min + i * static_cast<double>(lidar.angle_increment);
    double truth = plan_.castRay(origin, Eigen::Vector2d(std::cos(a), std::sin(a)), t);
    for (int k = -8; lidar.beam_width > 0.0 && k <= 8; ++k) {  // a cone returns its nearest echo
      const double ak = a + 0.5 * lidar.beam_width * k / 8.0;
      truth = std::min(truth, plan_.castRay(origin, Eigen::Vector2d(std::cos(ak), std::sin(ak)), t));
    }
    const double u = uniform(*rng);
    const double noise = gauss(*rng);
    float r;
    if (u < lidar.nan_probability) {
      r = std::numeric_limits<float>::quiet_NaN();
    } else if (u < lidar.nan_probability + lidar.dropout_probability) {
      r = lidar.rep117 ? -std::numeric_limits<float>::infinity() : 0.0f;
    } else if (u < lidar.nan_probability + lidar.dropout_probability + lidar.spurious_no_return_probability ||
               truth >= lidar.range_max) {
      r = lidar.rep117 ? std::numeric_limits<float>::infinity() : lidar.range_max;
    } else {
      const double sigma = truth < 1.0 ? lidar.noise_sigma_near : lidar.noise_fraction_far * truth;
      r = static_cast<float>(std::max(static_cast<double>(lidar.range_min), truth + sigma * noise));
      if (r >= lidar.range_max) r = std::nextafter(lidar.range_max, 0.0f);
    }
    scan.ranges[static_cast<std::size_t>(i)] = r;
  }
  return scan;
}

void addPoseErrors(std::vector<Scan>* scans, const PoseErrors& errors) {
  std::mt19937 rng(errors.seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (Scan& scan : *scans) {
    const double dx = errors.sigma_xy * unit(rng), dy = errors.sigma_xy * unit(rng), dyaw = errors.sigma_yaw * unit(rng);
    const Eigen::Vector3d at = scan.sensor_pose.translation();
    scan.sensor_pose.prerotate(Eigen::AngleAxisd(dyaw, Eigen::Vector3d::UnitZ()));
    scan.sensor_pose.translation() = at + Eigen::Vector3d(dx, dy, 0.0);
  }
}

std::vector<Pose3D> deadReckoned(const std::vector<Pose2D>& poses, const DeadReckoning& model) {
  std::vector<Pose3D> out;
  if (poses.empty()) return out;
  std::mt19937 rng(model.seed);
  std::normal_distribution<double> noise(0.0, model.noise_per_step);
  double x = poses[0].x, y = poses[0].y, yaw = poses[0].yaw;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    if (k > 0) {
      const Pose2D& a = poses[k - 1];
      const Pose2D& b = poses[k];
      // The step as the wheels measure it, in the robot's frame, applied to the odometry's pose.
      const double c = std::cos(a.yaw), s = std::sin(a.yaw);
      const double forward = c * (b.x - a.x) + s * (b.y - a.y), side = -s * (b.x - a.x) + c * (b.y - a.y);
      const double turn = wrapAngle(b.yaw - a.yaw);
      const double moving = std::abs(forward) + std::abs(turn) > 1e-9 ? 1.0 : 0.0;
      const double f = forward * model.distance_scale + moving * noise(rng);
      const double l = side * model.distance_scale;
      x += std::cos(yaw) * f - std::sin(yaw) * l;
      y += std::sin(yaw) * f + std::cos(yaw) * l;
      yaw = wrapAngle(yaw + turn * model.yaw_scale + moving * (model.yaw_bias * (b.t - a.t) + noise(rng)));
    }
    const double t = poses[k].t;
    // Slow swaying, as an IMU-fused attitude reports on a moving base.
    const double roll = model.tilt * std::sin(0.7 * t), pitch = model.tilt * std::sin(0.43 * t + 1.0);
    Pose3D p;
    p.t = t;
    p.pose.translate(Eigen::Vector3d(x, y, model.height * std::sin(0.9 * t)));
    p.pose.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
    out.push_back(p);
  }
  return out;
}

std::vector<Scan> SimulatedSession::allScans() const {
  std::mt19937 rng(spec_.seed);
  std::vector<Scan> scans;
  for (double t : scanTimes()) scans.push_back(scanAt(t, &rng));
  return scans;
}

}  // namespace sim
}  // namespace octo_slice_mapper
