#include "octo_slice_mapper/sim/depth_camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace octo_slice_mapper {
namespace sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Slab test: the entry and exit distances of a ray through a box (entry > exit: a miss).
void slabs(const Box& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double* entry, double* exit) {
  double lo = -kInf, hi = kInf;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < box.min[a] || o[a] > box.max[a]) lo = kInf;
      continue;
    }
    const double t0 = (box.min[a] - o[a]) / d[a], t1 = (box.max[a] - o[a]) / d[a];
    lo = std::max(lo, std::min(t0, t1));
    hi = std::min(hi, std::max(t0, t1));
  }
  *entry = lo;
  *exit = hi;
}

Box box(double x0, double y0, double z0, double x1, double y1, double z1) {
  return {Eigen::Vector3d(x0, y0, z0), Eigen::Vector3d(x1, y1, z1)};
}

}  // namespace

BoxScene BoxScene::officeRoom() {
  BoxScene s;
  s.room = box(0.0, 0.0, 0.0, 6.0, 5.0, 2.5);
  // The table: a 3 cm top at 0.69-0.72 m on four 5 cm legs.
  s.solids.push_back(box(2.5, 1.5, 0.69, 3.7, 2.3, 0.72));
  for (double x : {2.55, 3.6}) {
    for (double y : {1.55, 2.2}) s.solids.push_back(box(x, y, 0.0, x + 0.05, y + 0.05, 0.69));
  }
  // The shelf: a cabinet 0.3 m deep from the floor, its top board reaching 0.35 m further out
  // at 0.45-0.60 m (above the lidar at 0.26 m, below the robot's top).
  s.solids.push_back(box(1.0, 4.7, 0.0, 2.6, 5.0, 1.8));
  s.solids.push_back(box(1.0, 4.35, 0.45, 2.6, 4.7, 0.60));
  // A step 8 cm high (below the lidar).
  s.solids.push_back(box(4.6, 0.4, 0.0, 5.6, 1.0, 0.08));
  return s;
}

BoxScene BoxScene::officeRoomWithRamp() {
  BoxScene s = officeRoom();
  s.solids.pop_back();  // the step
  s.ramp = Ramp{4.0, 5.0, 0.10};
  return s;
}

double BoxScene::floorAt(double x) const {
  if (!ramp || x <= ramp->x0) return room.min.z();
  if (x >= ramp->x1) return room.min.z() + ramp->height;
  return room.min.z() + ramp->height * (x - ramp->x0) / (ramp->x1 - ramp->x0);
}

BoxScene BoxScene::of(const FloorPlan& plan) {
  BoxScene s;
  s.room = box(plan.min_corner.x(), plan.min_corner.y(), 0.0, plan.max_corner.x(), plan.max_corner.y(), kWallHeight);
  for (const Wall& w : plan.walls) {
    Eigen::Vector2d lo = w.a, hi = w.a;
    for (const Segment& edge : w.outline()) {
      lo = lo.cwiseMin(edge.a).cwiseMin(edge.b);
      hi = hi.cwiseMax(edge.a).cwiseMax(edge.b);
    }
    s.solids.push_back(box(lo.x(), lo.y(), w.bottom, hi.x(), hi.y(), w.top));
  }
  return s;
}

double BoxScene::castRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const {
  double entry, exit;
  slabs(room, origin, dir, &entry, &exit);
  double nearest = exit > 0.0 && entry <= exit ? exit : kInf;
  for (const Box& b : solids) {
    slabs(b, origin, dir, &entry, &exit);
    if (entry <= exit && entry > 0.0) nearest = std::min(nearest, entry);
  }
  if (ramp) {
    const double z0 = room.min.z(), slope = ramp->height / (ramp->x1 - ramp->x0);
    // The slope: z - z0 = slope (x - x0), for x in [x0, x1].
    const double denominator = dir.z() - slope * dir.x();
    if (denominator != 0.0) {
      const double t = (slope * (origin.x() - ramp->x0) - (origin.z() - z0)) / denominator;
      const double x = origin.x() + t * dir.x();
      if (t > 0.0 && x >= ramp->x0 && x <= ramp->x1) nearest = std::min(nearest, t);
    }
    // The platform: z = z0 + height for x beyond x1.
    if (dir.z() != 0.0) {
      const double t = (z0 + ramp->height - origin.z()) / dir.z();
      if (t > 0.0 && origin.x() + t * dir.x() >= ramp->x1) nearest = std::min(nearest, t);
    }
  }
  return nearest;
}

bool BoxScene::solidAt(const Eigen::Vector3d& p) const {
  for (const Box& b : solids) {
    if ((p.array() >= b.min.array()).all() && (p.array() <= b.max.array()).all()) return true;
  }
  return false;
}

std::vector<Eigen::Vector3f> depthFrame(const BoxScene& scene, const Eigen::Isometry3d& optical_in_world,
                                        const DepthCameraSpec& spec, std::mt19937* rng) {
  const double fx = 0.5 * spec.width / std::tan(0.5 * spec.horizontal_fov);
  const double fy = 0.5 * spec.height / std::tan(0.5 * spec.vertical_fov);
  const double cx = 0.5 * spec.width, cy = 0.5 * spec.height;
  std::normal_distribution<double> gauss(0.0, 1.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Eigen::Vector3f> points(std::size_t(spec.width) * spec.height, Eigen::Vector3f(nan, nan, nan));
  const Eigen::Vector3d origin = optical_in_world.translation();
  for (int v = 0; v < spec.height; ++v) {
    for (int u = 0; u < spec.width; ++u) {
      const Eigen::Vector3d ray((u + 0.5 - cx) / fx, (v + 0.5 - cy) / fy, 1.0);  // z = 1: depth units
      const Eigen::Vector3d world_dir = optical_in_world.linear() * ray.normalized();
      const double distance = scene.castRay(origin, world_dir);
      double depth = distance / ray.norm();
      if (!std::isfinite(depth) || depth < spec.min_range || depth > spec.max_range) continue;
      if (spec.noise) depth += (0.0012 + 0.0019 * (depth - 0.4) * (depth - 0.4)) * gauss(*rng);
      points[std::size_t(v) * spec.width + u] = (ray * depth).cast<float>();
    }
  }
  if (spec.flying_pixel_probability > 0.0) {
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    const std::vector<Eigen::Vector3f> clean = points;
    const auto depthAt = [&](int u, int v) { return clean[std::size_t(v) * spec.width + u].z(); };
    for (int v = 0; v + 1 < spec.height; ++v) {
      for (int u = 0; u + 1 < spec.width; ++u) {
        const float here = depthAt(u, v);
        for (const float there : {depthAt(u + 1, v), depthAt(u, v + 1)}) {
          if (!(std::abs(there - here) > 0.1f) || uniform(*rng) >= spec.flying_pixel_probability) continue;
          const double mixed = here + (0.2 + 0.6 * uniform(*rng)) * (there - here);
          points[std::size_t(v) * spec.width + u] = clean[std::size_t(v) * spec.width + u] * float(mixed / here);
          break;
        }
      }
    }
  }
  return points;
}

Eigen::Isometry3d cameraLinkOnBase(const CameraMount& mount) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(Eigen::Vector3d(mount.x, 0.0, mount.z));
  pose.rotate(Eigen::AngleAxisd(mount.pitch, Eigen::Vector3d::UnitY()));
  return pose;
}

Eigen::Isometry3d opticalOnCameraLink() { return opticalPose(Eigen::Vector3d::Zero(), 0.0, 0.0); }

Eigen::Isometry3d opticalOnRobot(const CameraMount& mount, double x, double y, double yaw) {
  Eigen::Isometry3d base = Eigen::Isometry3d::Identity();
  base.translate(Eigen::Vector3d(x, y, 0.0));
  base.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return base * (cameraLinkOnBase(mount) * opticalOnCameraLink());  // as the static tf chains them
}

Eigen::Isometry3d opticalPose(const Eigen::Vector3d& position, double yaw, double pitch) {
  // Body axes (x forward, y left, z up) to optical (z forward, x right, y down).
  Eigen::Matrix3d body_to_optical;
  body_to_optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(position);
  pose.rotate(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()));
  pose.rotate(body_to_optical);
  return pose;
}

}  // namespace sim
}  // namespace octo_slice_mapper
