// Inverse sensor model of a range beam (Probabilistic Robotics, ch. 9; the lab's Figure 2):
// how much a single reading says about the occupancy of a point near the beam.
#pragma once

#include <vector>

namespace octo_slice_mapper {

// Defaults are for Hokuyo and SICK class lidars, chosen by leaving one of the four shared logs
// out at a time (doc/benchmarks.md).
struct InverseSensorModelOptions {
  // Full opening angle of a beam's cone (rad): the lidar's own beam divergence (URG and SICK
  // scanners: about 0.25 deg). Evidence stays inside it, so a beam that grazes a wall clears only
  // what it really passed. It must be positive: the cone's weight is zero outside it.
  double beam_opening_angle = 0.0044;
  // Widen every cone to the scan's angle step, so that neighbouring beams tile the scan plane
  // without gaps (it erodes walls seen at a grazing angle: a grazing beam clears wall voxels it
  // never entered).
  bool cone_covers_angle_step = false;
  // Outer share of the half-angle over which the evidence fades smoothly (cosine) to nothing.
  double cone_taper_fraction = 0.5;
  // Range standard deviation sigma(r) = sigma_base + sigma_per_meter * r; it sets the thickness of
  // the occupied peak and the width of the free->occupied->unknown transitions. It is never taken
  // below a quarter voxel (the peak's mass is counted per voxel, so it lands in the voxel of the
  // return however thin it is).
  // A SICK or Hokuyo scanner's noise grows little with range; what grows is the error of the
  // pose a return is placed with, which sigma does not model.
  double sigma_base = 0.005;
  double sigma_per_meter = 0.002;
  // Transitions widen off the beam axis: sigma *= 1 + sigma_angle_gain * (angle / half_angle).
  double sigma_angle_gain = 1.0;
  // Probabilities the model assigns in the free valley and to a voxel that holds the whole
  // occupied peak (the mass of the peak a voxel holds scales the latter).
  double p_free = 0.4;
  double p_occupied = 0.75;
  // Prior occupancy l0 (as probability). The model returns the prior where it knows nothing, so
  // the update inverse_model - l0 is exactly zero there.
  double prior = 0.5;
  // A reading at/beyond range_max ("no return") clears space up to this distance (m), capped at
  // range_max; it never marks anything occupied. 0 (the default) disables clearing by no-return
  // readings: scanners also report glass, black and specular surfaces as no return, and clearing
  // along them lowers the held-out accuracy on the shared logs.
  double no_return_clear_distance = 0.0;
};

// Evaluates the model in log-odds. All distances in metres, angles in radians.
class InverseSensorModel {
 public:
  // The cone's part of the model for one half-angle, tabulated over q = tan(angle off the axis)
  // / tan(half-angle) in [0, 1]: the weight and the factor sigma widens by. What a voxel tracer
  // has at hand is a tangent (lateral / along); this spares it an atan and a cos per voxel.
  class ConeTable {
   public:
    ConeTable(const InverseSensorModel& model, double half_angle);
    double halfAngle() const { return half_angle_; }
    double tanHalf() const { return tan_half_; }

   private:
    friend class InverseSensorModel;
    static constexpr int kSteps = 1024;
    double half_angle_, tan_half_;
    std::vector<float> weight_, widen_;  // at q = i / kSteps
  };

  // `voxel_size`: the edge of the voxels the model is evaluated for (0: points, no extent).
  explicit InverseSensorModel(const InverseSensorModelOptions& options = {}, double voxel_size = 0.0);

  // Log-odds update (inverse_model - l0) for the voxel whose centre is at distance `along` from
  // the sensor, measured along the beam axis, `off_axis` radians away from the axis, for a beam
  // that returned at `range`. `half_angle` is the cone half-angle actually in force for this beam.
  // `occupied_share`: the share of the return's lateral spread the voxel holds (1 on the axis;
  // off it, a voxel holds only its width's share of a cone wider than a voxel).
  float hitUpdate(double range, double along, double off_axis, double half_angle, double occupied_share = 1.0) const;
  // Same for a no-return beam that clears up to `clear_distance`.
  float noReturnUpdate(double clear_distance, double along, double off_axis, double half_angle) const;
  // The same two with the angle off the axis given as q = tan(angle) / tan(half-angle) >= 0 and
  // the cone tabulated (within 1e-5 of the functions above, in weight and in sigma).
  float hitUpdateInCone(double range, double along, double q, const ConeTable& cone, double occupied_share = 1.0) const;
  float noReturnUpdateInCone(double clear_distance, double along, double q, const ConeTable& cone) const;
  // What those two give on a beam's axis (q = 0), with what depends on the beam alone (the cone's
  // weight and sigma there, half a voxel in sigmas) worked out once per beam: the same floats, for
  // a division and two table lookups less per voxel. `share` < 0 for a no-return beam.
  struct AxisProfile {
    double reference = 0.0, w = 0.0, sigma = 1.0, k = 0.0, share = -1.0;
  };
  AxisProfile axisProfile(double reference, const ConeTable& cone, double share) const;
  float onAxis(const AxisProfile& axis, double along) const;

  // Distance beyond the return after which the model carries no information (the tracer stops there).
  // (sigma grows off axis by at most 1 + sigma_angle_gain.)
  double traceMargin(double range) const {
    return kBehindCutoff * (1.0 + options_.sigma_angle_gain) * sigmaAt(range, 0.0, 1.0);
  }
  static constexpr double kBehindCutoff = 2.0;
  // A voxel whose centre lies more than this before a return (along the axis, anywhere in the
  // cone) gets no update above zero: the peak's mass is reckoned from kNoMassBelow sigmas (the
  // widest, at the cone's edge) before the return, plus the voxel's half-extent.
  double occupiedMargin(double range) const {
    return kNoMassBelow * (1.0 + options_.sigma_angle_gain) * sigmaAt(range, 0.0, 1.0) + 0.5 * voxel_size_;
  }
  // On the axis, points closer than range - pureFreeMargin(range) get exactly logOddsFree().
  double pureFreeMargin(double range) const { return -kPureFreeBelow * sigmaAt(range, 0.0, 1.0); }
  static constexpr double kPureFreeBelow = -8.0;  // in sigmas: F = 1 and G = 0 to float precision
  // The profile along the axis in u = (d - r) / sigma for a voxel reaching k = half a voxel /
  // sigma either side of its centre, untabulated (hitUpdate interpolates tables, 256 points per
  // sigma: within 1e-4 of this, in log-odds).
  double hitProfileExact(double u, double k) const;
  double sigmaAt(double range, double off_axis, double half_angle) const;
  // Weight in [0,1] of the evidence at `off_axis` inside a cone of `half_angle`.
  double coneWeight(double off_axis, double half_angle) const;
  // Off the axis up to this angle the weight is still 1.
  double fullWeightAngle(double half_angle) const { return half_angle * (1.0 - options_.cone_taper_fraction); }
  double halfAngleFor(double angle_increment) const;
  double voxelSize() const { return voxel_size_; }

  float logOddsFree() const { return l_free_; }
  float logOddsOccupied() const { return l_occ_; }
  const InverseSensorModelOptions& options() const { return options_; }

 private:
  InverseSensorModelOptions options_;
  double voxel_size_;
  double min_sigma_;  // a quarter voxel
  float l_free_;  // log-odds of p_free relative to the prior
  float l_occ_;   // log-odds of p_occupied relative to the prior
  static constexpr int kStepsPerSigma = 256;
  static double freeShare(double u);
  static double behind(double u);
  static double lookup(const std::vector<double>& table, double u);
  double normalCdf(double x) const;  // tabulated
  // 1 + sigma_angle_gain * (share of the half-angle off the axis): the factor sigma widens by.
  double widening(double off_axis, double half_angle) const;
  double sigmaWidened(double range, double widen) const;
  // The update at `along` for a beam ending at `reference`, weighted by the cone; `share` < 0 for
  // a no-return beam (free valley only).
  // `k`: half a voxel in sigmas.
  float profileUpdate(double reference, double along, double w, double sigma, double k, double share) const;
  // The cone's weight and sigma at q < 1 (its table interpolated).
  void coneAt(double reference, double q, const ConeTable& cone, double* w, double* sigma) const;
  float directUpdate(double reference, double along, double off_axis, double half_angle, double share) const;
  float tabulatedUpdate(double reference, double along, double q, const ConeTable& cone, double share) const;
  std::vector<double> free_profile_;  // l_free * F(u) on [kPureFreeBelow, kBehindCutoff]
  std::vector<double> behind_;        // B(u) on the same
  std::vector<double> cdf_;           // the standard normal CDF on [-kCdfReach, kCdfReach]
  static constexpr double kCdfReach = 12.0;
  static constexpr double kNoMassBelow = 6.0;
};

double logOdds(double p);
double probability(double log_odds);

}  // namespace octo_slice_mapper
