#include "octo_slice_mapper/internal/floor_plane.h"

#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace octo_slice_mapper {

double FloorPlane::tilt() const { return std::acos(std::clamp(normal.z(), -1.0, 1.0)); }

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// RANSAC over `indices` of `cloud` for a plane within max_tilt of level, refined by least squares
// over its inliers. PCL's models and RANSAC are seeded with a constant unless asked for a random
// seed: the same input gives the same plane.
std::optional<FloorPlane> fitPlane(const Cloud::ConstPtr& cloud, const std::vector<int>& indices,
                                   const FloorFitOptions& options) {
  if (static_cast<int>(indices.size()) < options.min_points) return std::nullopt;
  // A frame without a floor is no error: PCL's "RANSAC found no model" stays unprinted.
  static const bool quiet = [] {
    if (pcl::console::getVerbosityLevel() > pcl::console::L_ALWAYS) pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
    return true;
  }();
  (void)quiet;
  using Model = pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>;
  Model::Ptr model(new Model(cloud, indices, /*random=*/false));
  model->setAxis(Eigen::Vector3f::UnitZ());
  model->setEpsAngle(options.max_tilt);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, options.inlier_distance);
  // PCL stops once a plane is found with 99 % confidence for the share of inliers it has, so the
  // cap binds only where that share is small: in a frame without a seed, whose candidates are the
  // whole view (too low a cap misses a floor that is there), and in a frame without a floor, which
  // always draws up to it (every draw costs such a frame). The measurements behind 300 are in
  // doc/benchmarks.md ("The plane fit's draws").
  ransac.setMaxIterations(300);
  if (!ransac.computeModel()) return std::nullopt;
  std::vector<int> inliers;
  ransac.getInliers(inliers);
  if (static_cast<int>(inliers.size()) < options.min_points) return std::nullopt;
  Eigen::VectorXf coefficients, refined;
  ransac.getModelCoefficients(coefficients);
  model->optimizeModelCoefficients(inliers, coefficients, refined);
  Eigen::Vector3d normal = refined.head<3>().cast<double>();
  double d = refined[3];
  const double length = normal.norm();
  if (!(length > 0.0) || !std::isfinite(d)) return std::nullopt;
  normal /= length, d /= length;
  if (normal.z() < 0.0) normal = -normal, d = -d;
  FloorPlane plane{normal, d};
  if (plane.tilt() > options.max_tilt) return std::nullopt;  // the refinement may leave the cone
  return plane;
}

// A plane tilted across a low step's edge can hold the floor on one side and the step's top on
// the other within its band. Along its slope, such a plane's inliers are two level runs with a
// jump between them, where a tilted floor's inliers rise steadily. The height of the lower run
// when two level runs more than `min_jump` apart fit `points` (the plane's inliers) better than
// the plane does (both models have three parameters: two heights and where the jump is, or a
// plane). The jump is looked for between strips `strip` wide across the slope, summed in one
// pass: every frame asks, and sorting its inliers would cost more than the rest of this.
std::optional<double> lowerOfTwoLevels(const std::vector<Eigen::Vector3d>& points, const FloorPlane& plane,
                                       double min_jump, double strip) {
  const Eigen::Vector2d uphill(-plane.normal.x(), -plane.normal.y());
  if (uphill.norm() < 1e-9 || points.size() < 20) return std::nullopt;
  const Eigen::Vector2d along = uphill.normalized();
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (const Eigen::Vector3d& p : points) {
    const double s = along.dot(p.head<2>());
    first = std::min(first, s), last = std::max(last, s);
  }
  struct Sums {
    double n = 0.0, z = 0.0, zz = 0.0;
  };
  const std::size_t strips = std::min<std::size_t>(4096, static_cast<std::size_t>((last - first) / strip) + 1);
  std::vector<Sums> by_strip(strips);
  double plane_sse = 0.0;
  Sums all;
  for (const Eigen::Vector3d& p : points) {
    const auto k = std::min(strips - 1, static_cast<std::size_t>((along.dot(p.head<2>()) - first) / strip));
    Sums& b = by_strip[k];
    b.n += 1.0, b.z += p.z(), b.zz += p.z() * p.z();
    plane_sse += plane.distance(p) * plane.distance(p);
  }
  for (const Sums& b : by_strip) all.n += b.n, all.z += b.z, all.zz += b.zz;
  // Each run holds a tenth of the points at least: a few outliers at an end are no surface.
  const double least = 0.1 * all.n;
  double best = plane_sse;
  std::optional<double> low;
  Sums below;
  for (std::size_t k = 0; k + 1 < strips; ++k) {
    below.n += by_strip[k].n, below.z += by_strip[k].z, below.zz += by_strip[k].zz;
    const double n2 = all.n - below.n;
    if (below.n < least || n2 < least) continue;
    const double m1 = below.z / below.n, m2 = (all.z - below.z) / n2;
    const double sse = (below.zz - below.z * m1) + ((all.zz - below.zz) - (all.z - below.z) * m2);  // about each run's mean
    if (m2 - m1 > min_jump && sse < best) best = sse, low = m1;
  }
  return low;
}

}  // namespace

std::optional<FloorFit> fitFloor(const std::vector<Eigen::Vector3d>& samples, const Eigen::Vector3d& sensor,
                                 const std::optional<FloorPlane>& seed, const FloorFitOptions& options,
                                 const std::optional<Eigen::Vector3d>& ground, double ground_tolerance) {
  // The candidates: below the sensor, thinned evenly to max_samples.
  // (Without a branch per sample: floor, walls and furniture alternate in a frame's samples.)
  std::vector<std::size_t> below(samples.size());
  std::size_t count = 0;
  const double top = sensor.z() - options.min_below_sensor;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    below[count] = i;
    count += static_cast<std::size_t>(samples[i].z() <= top) & static_cast<std::size_t>(samples[i].allFinite());
  }
  below.resize(count);
  const std::size_t stride = std::max<std::size_t>(1, (below.size() + options.max_samples - 1) /
                                                          std::max(1, options.max_samples));
  Cloud::Ptr cloud(new Cloud);
  std::vector<std::size_t> origin_of;  // the cloud's point k is samples[origin_of[k]]
  for (std::size_t k = 0; k < below.size(); k += stride) {
    const Eigen::Vector3d& p = samples[below[k]];
    cloud->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
    origin_of.push_back(below[k]);
  }
  if (static_cast<int>(cloud->size()) < options.min_points) return std::nullopt;
  const auto pointOf = [&](int k) { return samples[origin_of[std::size_t(k)]]; };
  const auto where = [&](auto keep) {
    std::vector<int> indices;
    for (int k = 0; k < static_cast<int>(cloud->size()); ++k) {
      if (keep(pointOf(k))) indices.push_back(k);
    }
    return indices;
  };

  // Whether a plane passes through the ground point (any plane does without one).
  const auto onGround = [&](const std::optional<FloorPlane>& p) {
    return p && (!ground || std::abs(p->heightAt(ground->x(), ground->y()) - ground->z()) <= ground_tolerance);
  };
  std::optional<FloorPlane> plane;
  if (seed) {
    plane = fitPlane(cloud, where([&](const Eigen::Vector3d& p) { return std::abs(seed->distance(p)) <= options.seed_window; }),
                     options);
  }
  if (!plane) {
    std::vector<int> all(cloud->size());
    for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<int>(k);
    plane = fitPlane(cloud, all, options);
  }
  if (ground && !onGround(plane)) {
    // The samples near the ground's level: the floor the carrier stands on, if the frame sees it.
    plane = fitPlane(cloud, where([&](const Eigen::Vector3d& p) { return std::abs(p.z() - ground->z()) <= options.seed_window; }),
                     options);
    if (!onGround(plane)) return std::nullopt;
  }
  if (!plane) return std::nullopt;
  // The lowest supported plane: a table top, a bed or a low step found first gives way to the
  // floor below it. The floor is looked for among the samples more than two inlier distances
  // below the plane: far enough that a floor's own noise, within the band, is no second surface;
  // near enough that the floor in front of a low step (8 cm), whose top fills most of the view
  // and so is the plane found first, is one.
  for (int attempt = 0; attempt < 3; ++attempt) {
    const FloorPlane current = *plane;
    std::optional<FloorPlane> lower = fitPlane(
        cloud, where([&](const Eigen::Vector3d& p) { return current.distance(p) < -2.0 * options.inlier_distance; }),
        options);
    if (!onGround(lower)) break;
    plane = lower;
  }
  // One surface or two: a plane that holds the floor and a step's top is refitted to the floor,
  // the lower of the two (the step's top is then no inlier, and its cells are measured as what
  // stands on the floor).
  std::vector<Eigen::Vector3d> on_plane;
  for (int k = 0; k < static_cast<int>(cloud->size()); ++k) {
    if (std::abs(plane->distance(pointOf(k))) <= options.inlier_distance) on_plane.push_back(pointOf(k));
  }
  if (const std::optional<double> low =
          lowerOfTwoLevels(on_plane, *plane, options.inlier_distance, options.inlier_distance)) {
    const double level = *low;
    if (std::optional<FloorPlane> floor = fitPlane(
            cloud, where([&](const Eigen::Vector3d& p) { return std::abs(p.z() - level) <= options.inlier_distance; }),
            options)) {
      if (onGround(floor)) plane = floor;
    }
  }
  FloorFit fit;
  fit.plane = *plane;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i : below) {
    if (std::abs(fit.plane.distance(samples[i])) > options.inlier_distance) continue;
    fit.inliers.push_back(i);
    lo = lo.cwiseMin(samples[i].head<2>());
    hi = hi.cwiseMax(samples[i].head<2>());
  }
  if (fit.inliers.empty()) return std::nullopt;
  fit.min = lo;
  fit.max = hi;
  return fit;
}

}  // namespace octo_slice_mapper
