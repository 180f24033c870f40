#include "octo_slice_mapper/inverse_sensor_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace octo_slice_mapper {

double logOdds(double p) { return std::log(p / (1.0 - p)); }
double probability(double log_odds) { return 1.0 / (1.0 + std::exp(-log_odds)); }

InverseSensorModel::InverseSensorModel(const InverseSensorModelOptions& options, double voxel_size)
    : options_(options), voxel_size_(voxel_size), min_sigma_(0.25 * voxel_size) {
  auto in_open_unit = [](double p) { return p > 0.0 && p < 1.0; };
  if (!in_open_unit(options.p_free) || !in_open_unit(options.p_occupied) || !in_open_unit(options.prior)) {
    throw std::invalid_argument("inverse sensor model: probabilities must lie in (0, 1)");
  }
  if (!(options.p_free < options.prior && options.prior < options.p_occupied)) {
    throw std::invalid_argument("inverse sensor model: need p_free < prior < p_occupied");
  }
  if (!(options.sigma_base > 0.0) || options.sigma_per_meter < 0.0 || options.sigma_angle_gain < 0.0) {
    throw std::invalid_argument("inverse sensor model: sigma_base must be > 0, gains >= 0");
  }
  // A cone of no width weighs every voxel zero, the one a beam ends in too: it would map nothing.
  const bool no_cone = options.beam_opening_angle <= 0.0 && !options.cone_covers_angle_step;
  if (options.beam_opening_angle < 0.0 || no_cone || options.cone_taper_fraction < 0.0 || options.cone_taper_fraction > 1.0) {
    throw std::invalid_argument("inverse sensor model: opening angle > 0 (or cone_covers_angle_step), taper fraction in [0, 1]");
  }
  if (voxel_size < 0.0) throw std::invalid_argument("inverse sensor model: voxel size must be >= 0");
  const double l0 = logOdds(options.prior);
  l_free_ = static_cast<float>(logOdds(options.p_free) - l0);
  l_occ_ = static_cast<float>(logOdds(options.p_occupied) - l0);
  // The profiles depend on u alone: tabulate them once (erfc, exp and cos per voxel cost more
  // than the rest of an insertion).
  const int n = static_cast<int>((kBehindCutoff - kPureFreeBelow) * kStepsPerSigma);
  free_profile_.resize(n + 1);
  behind_.resize(n + 1);
  for (int i = 0; i <= n; ++i) {
    const double u = kPureFreeBelow + double(i) / kStepsPerSigma;
    free_profile_[i] = l_free_ * freeShare(u);
    behind_[i] = behind(u);
  }
  const int m = static_cast<int>(2.0 * kCdfReach * kStepsPerSigma);
  cdf_.resize(m + 1);
  for (int i = 0; i <= m; ++i) cdf_[i] = 0.5 * std::erfc(-(double(i) / kStepsPerSigma - kCdfReach) / M_SQRT2);
}

double InverseSensorModel::freeShare(double u) { return 0.5 * std::erfc((u + 2.0) / M_SQRT2); }

// B fades the peak's far flank to zero between u = 1 and u = 2 (see hitUpdate).
double InverseSensorModel::behind(double u) {
  if (u <= 1.0) return 1.0;
  if (u >= kBehindCutoff) return 0.0;
  return 0.5 * (1.0 + std::cos(M_PI * (u - 1.0) / (kBehindCutoff - 1.0)));
}

double InverseSensorModel::hitProfileExact(double u, double k) const {
  if (u >= kBehindCutoff) return 0.0;
  auto cdf = [](double x) { return 0.5 * std::erfc(-x / M_SQRT2); };
  const double mass = k > 0.0 ? cdf(u + k) - cdf(u - k) : std::exp(-0.5 * u * u);
  return l_free_ * freeShare(u) + l_occ_ * behind(u) * mass;
}

// Linear interpolation in a table over u in [kPureFreeBelow, kBehindCutoff). Inlined, as are the
// CDF, sigma and the profile below, into hitUpdateInCone: they run for every voxel near a return,
// and as separate calls they took half again as many instructions.
__attribute__((always_inline)) inline double InverseSensorModel::lookup(const std::vector<double>& table, double u) {
  const double x = (u - kPureFreeBelow) * kStepsPerSigma;
  const std::size_t i = std::min(static_cast<std::size_t>(std::max(0.0, x)), table.size() - 2);
  const double f = x - double(i);
  return table[i] + f * (table[i + 1] - table[i]);
}

__attribute__((always_inline)) inline double InverseSensorModel::normalCdf(double x) const {
  if (x <= -kCdfReach) return 0.0;
  if (x >= kCdfReach) return 1.0;
  const double t = (x + kCdfReach) * kStepsPerSigma;
  const std::size_t i = std::min(static_cast<std::size_t>(t), cdf_.size() - 2);
  const double f = t - double(i);
  return cdf_[i] + f * (cdf_[i + 1] - cdf_[i]);
}

double InverseSensorModel::halfAngleFor(double angle_increment) const {
  if (!options_.cone_covers_angle_step) return 0.5 * options_.beam_opening_angle;
  return 0.5 * std::max(options_.beam_opening_angle, std::abs(angle_increment));
}

double InverseSensorModel::widening(double off_axis, double half_angle) const {
  return half_angle > 0.0 ? 1.0 + options_.sigma_angle_gain * std::min(1.0, off_axis / half_angle) : 1.0;
}

__attribute__((always_inline)) inline double InverseSensorModel::sigmaWidened(double range, double widen) const {
  // Thinner than a quarter voxel the peak adds nothing (its mass lands in one voxel anyway).
  return std::max((options_.sigma_base + options_.sigma_per_meter * range) * widen, min_sigma_);
}

double InverseSensorModel::sigmaAt(double range, double off_axis, double half_angle) const {
  return sigmaWidened(range, widening(off_axis, half_angle));
}

double InverseSensorModel::coneWeight(double off_axis, double half_angle) const {
  if (off_axis <= 0.0) return 1.0;
  if (off_axis >= half_angle) return 0.0;
  const double inner = half_angle * (1.0 - options_.cone_taper_fraction);
  if (off_axis <= inner) return 1.0;
  const double t = (off_axis - inner) / (half_angle - inner);
  return 0.5 * (1.0 + std::cos(M_PI * t));
}

// Along the axis, with u = (d - r) / sigma, the update of a voxel centred at d is
//   w * (l_free * F(u) + l_occ * share * B(u) * M(u)):
//   F, the free valley, is 1 well before the return and falls smoothly (a Gaussian CDF) to 0
//     around u = -2, so the last stretch before the return is not claimed free;
//   M, the occupied peak, is the mass of a Gaussian of width sigma centred on the return that
//     falls within the voxel's extent along the beam (u - k .. u + k, k = half a voxel / sigma):
//     one return is evidence for one obstacle, so the voxels along the axis share one peak's
//     worth (a peak value per voxel instead painted the voxels before and behind the return too,
//     and walls grew towards the sensor);
//   B fades the peak's far flank smoothly to zero between u = 1 and u = 2, so no information
//     reaches more than 2 sigma behind the obstacle (a long positive tail would add up over many
//     scans and thicken every wall).
float InverseSensorModel::hitUpdate(double range, double along, double off_axis, double half_angle,
                                    double occupied_share) const {
  return directUpdate(range, along, off_axis, half_angle, occupied_share);
}

float InverseSensorModel::noReturnUpdate(double clear_distance, double along, double off_axis,
                                         double half_angle) const {
  return directUpdate(clear_distance, along, off_axis, half_angle, -1.0);
}

__attribute__((always_inline)) inline float InverseSensorModel::profileUpdate(double reference, double along,
                                                                              double w, double sigma, double k,
                                                                              double share) const {
  const double u = (along - reference) / sigma;
  if (u >= kBehindCutoff) return 0.0f;
  // Deep in the free valley F = 1 and M = 0 to float precision.
  if (u < kPureFreeBelow) return static_cast<float>(w * l_free_);
  double value = lookup(free_profile_, u);
  // Further than 6 sigma in front of the voxel the peak's mass in it is below 1e-9: not computed.
  if (share > 0.0 && u + k > -kNoMassBelow) {
    const double mass = k > 0.0 ? normalCdf(u + k) - normalCdf(u - k) : std::exp(-0.5 * u * u);
    // B is 1 up to u = 1, and so is its table there (not read: one table less in the cache).
    const double behind_share = u < 1.0 ? 1.0 : lookup(behind_, u);
    value += l_occ_ * share * behind_share * mass;
  }
  return static_cast<float>(w * value);
}

float InverseSensorModel::directUpdate(double reference, double along, double off_axis, double half_angle,
                                       double share) const {
  const double w = coneWeight(off_axis, half_angle);
  if (w <= 0.0 || along < 0.0) return 0.0f;
  const double sigma = sigmaAt(reference, off_axis, half_angle);
  return profileUpdate(reference, along, w, sigma, 0.5 * voxel_size_ / sigma, share);
}

InverseSensorModel::ConeTable::ConeTable(const InverseSensorModel& model, double half_angle)
    : half_angle_(half_angle), tan_half_(std::tan(half_angle)), weight_(kSteps + 1), widen_(kSteps + 1) {
  for (int i = 0; i <= kSteps; ++i) {
    const double angle = std::atan(double(i) / kSteps * tan_half_);
    weight_[i] = static_cast<float>(model.coneWeight(angle, half_angle));  // 0 at the edge, q = 1
    widen_[i] = static_cast<float>(model.widening(angle, half_angle));
  }
}

__attribute__((always_inline)) inline float InverseSensorModel::tabulatedUpdate(double reference, double along,
                                                                                double q, const ConeTable& cone,
                                                                                double share) const {
  if (!(q < 1.0) || along < 0.0) return 0.0f;
  double w, sigma;
  coneAt(reference, q, cone, &w, &sigma);
  if (w <= 0.0) return 0.0f;
  return profileUpdate(reference, along, w, sigma, 0.5 * voxel_size_ / sigma, share);
}

__attribute__((always_inline)) inline void InverseSensorModel::coneAt(double reference, double q,
                                                                      const ConeTable& cone, double* w,
                                                                      double* sigma) const {
  const double x = q * ConeTable::kSteps;
  const int i = static_cast<int>(x);  // < kSteps, so i + 1 is in the table
  const double f = x - i;
  *w = cone.weight_[i] + f * (cone.weight_[i + 1] - cone.weight_[i]);
  const double widen = cone.widen_[i] + f * (cone.widen_[i + 1] - cone.widen_[i]);
  *sigma = sigmaWidened(reference, widen);
}

InverseSensorModel::AxisProfile InverseSensorModel::axisProfile(double reference, const ConeTable& cone,
                                                                double share) const {
  AxisProfile axis;
  axis.reference = reference;
  axis.share = share;
  coneAt(reference, 0.0, cone, &axis.w, &axis.sigma);  // as tabulatedUpdate at q = 0, to the bit
  axis.k = 0.5 * voxel_size_ / axis.sigma;
  return axis;
}

float InverseSensorModel::onAxis(const AxisProfile& axis, double along) const {
  if (along < 0.0 || axis.w <= 0.0) return 0.0f;
  return profileUpdate(axis.reference, along, axis.w, axis.sigma, axis.k, axis.share);
}

float InverseSensorModel::hitUpdateInCone(double range, double along, double q, const ConeTable& cone,
                                          double occupied_share) const {
  return tabulatedUpdate(range, along, q, cone, occupied_share);
}

float InverseSensorModel::noReturnUpdateInCone(double clear_distance, double along, double q,
                                               const ConeTable& cone) const {
  return tabulatedUpdate(clear_distance, along, q, cone, -1.0);
}

}  // namespace octo_slice_mapper
