// Forward (beam) sensor model: how likely is a reading, given the first occupied cell on the beam.
#pragma once

#include <cmath>

namespace octo_slice_mapper {

// A mixture (Probabilistic Robotics, sec. 6.3) with the expected range z* = distance to the first
// occupied cell along the beam:
//   an obstacle at z* exists:   p(z) = z_hit * N(z; z*, sigma) + z_rand / z_max   for a return z,
//                               P(no return) = z_miss                            (obstacle missed)
//   no obstacle within range:   p(z) = z_rand / z_max                            (spurious return),
//                               P(no return) = 1 - z_rand
// sigma combines the sensor's range noise with the cell size: sqrt(sigma(z*)^2 + (res/2)^2).
// Short readings (people, unmapped clutter) are covered by the uniform z_rand term.
// Defaults are for Hokuyo / SICK class lidars.
struct ForwardSensorModelOptions {
  double z_hit = 0.83;
  double z_rand = 0.15;
  double z_miss = 0.02;
  double sigma_base = 0.01;
  double sigma_per_meter = 0.005;
  // Beyond z* + trace_sigmas * sigma a cell cannot explain a return any more: rays stop there.
  double trace_sigmas = 4.0;
};

class ForwardSensorModel {
 public:
  ForwardSensorModel(const ForwardSensorModelOptions& options, double resolution, double z_max)
      : o_(options), half_cell_sq_(0.25 * resolution * resolution), z_max_(z_max),
        log_rand_(std::log(options.z_rand / z_max)) {}

  double sigma(double expected) const {
    const double s = o_.sigma_base + o_.sigma_per_meter * expected;
    return std::sqrt(s * s + half_cell_sq_);
  }
  // log p(z | obstacle at `expected`), z a return.
  double logHit(double z, double expected) const {
    const double s = sigma(expected);
    const double u = (z - expected) / s;
    return std::log(o_.z_hit * std::exp(-0.5 * u * u) / (s * 2.5066282746310002) + o_.z_rand / z_max_);
  }
  // log p(z | no obstacle within range), z a return.
  double logHitNoObstacle() const { return log_rand_; }
  double logNoReturn(bool obstacle_in_range) const {
    return std::log(obstacle_in_range ? o_.z_miss : 1.0 - o_.z_rand);
  }
  // How far beyond a return of range z a cell can still matter.
  double traceLength(double z) const { return z + o_.trace_sigmas * sigma(z); }
  const ForwardSensorModelOptions& options() const { return o_; }

 private:
  ForwardSensorModelOptions o_;
  double half_cell_sq_, z_max_, log_rand_;
};

}  // namespace octo_slice_mapper
