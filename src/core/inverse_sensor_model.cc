#include "octo_slice_mapper/inverse_sensor_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace octo_slice_mapper {

double logOdds(double p) { return std::log(p / (1.0 - p)); }
double probability(double log_odds) { return 1.0 / (1.0 + std::exp(-log_odds)); }

InverseSensorModel::InverseSensorModel(const InverseSensorModelOptions& options, double min_sigma)
    : options_(options), min_sigma_(min_sigma) {
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
  if (options.beam_opening_angle < 0.0 || options.cone_taper_fraction < 0.0 || options.cone_taper_fraction > 1.0) {
    throw std::invalid_argument("inverse sensor model: opening angle >= 0, taper fraction in [0, 1]");
  }
  const double l0 = logOdds(options.prior);
  l_free_ = static_cast<float>(logOdds(options.p_free) - l0);
  l_occ_ = static_cast<float>(logOdds(options.p_occupied) - l0);
  // The profiles depend on u alone: tabulate them once (erfc, exp and cos per voxel cost more
  // than the rest of an insertion).
  const int n = static_cast<int>((kBehindCutoff - kPureFreeBelow) * kStepsPerSigma);
  hit_profile_.resize(n + 1);
  free_profile_.resize(n + 1);
  for (int i = 0; i <= n; ++i) {
    const double u = kPureFreeBelow + double(i) / kStepsPerSigma;
    hit_profile_[i] = hitProfileExact(u);
    free_profile_[i] = l_free_ * freeShare(u);
  }
}

double InverseSensorModel::freeShare(double u) { return 0.5 * std::erfc((u + 2.0) / M_SQRT2); }

double InverseSensorModel::hitProfileExact(double u) const {
  if (u >= kBehindCutoff) return 0.0;
  const double behind = u <= 1.0 ? 1.0 : 0.5 * (1.0 + std::cos(M_PI * (u - 1.0) / (kBehindCutoff - 1.0)));
  const double peak = std::exp(-0.5 * u * u) * behind;
  return l_free_ * freeShare(u) + l_occ_ * peak;
}

// Linear interpolation in a table over u in [kPureFreeBelow, kBehindCutoff).
double InverseSensorModel::lookup(const std::vector<double>& table, double u) {
  const double x = (u - kPureFreeBelow) * kStepsPerSigma;
  const std::size_t i = std::min(static_cast<std::size_t>(x), table.size() - 2);
  const double f = x - double(i);
  return table[i] + f * (table[i + 1] - table[i]);
}

double InverseSensorModel::halfAngleFor(double angle_increment) const {
  return 0.5 * std::max(options_.beam_opening_angle, std::abs(angle_increment));
}

double InverseSensorModel::widening(double off_axis, double half_angle) const {
  return half_angle > 0.0 ? 1.0 + options_.sigma_angle_gain * std::min(1.0, off_axis / half_angle) : 1.0;
}

double InverseSensorModel::sigmaWidened(double range, double widen) const {
  // The occupied peak can't be thinner than the voxel it has to land in.
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

// Along the axis, with u = (d - r) / sigma, the update is w * (l_free * F(u) + l_occ * G(u) * B(u)):
//   F, the free valley, is 1 well before the return and falls smoothly (a Gaussian CDF) to 0
//     around u = -2, so the last stretch before the return is not claimed free;
//   G, the occupied peak, is a Gaussian of width sigma centred on the return;
//   B fades the peak's far flank smoothly to zero between u = 1 and u = 2, so no information
//     reaches more than 2 sigma behind the obstacle (a long positive tail would add up over many
//     scans and thicken every wall).
float InverseSensorModel::hitUpdate(double range, double along, double off_axis, double half_angle) const {
  return directUpdate(hit_profile_, range, along, off_axis, half_angle);
}

float InverseSensorModel::noReturnUpdate(double clear_distance, double along, double off_axis,
                                         double half_angle) const {
  return directUpdate(free_profile_, clear_distance, along, off_axis, half_angle);
}

float InverseSensorModel::hitUpdateInCone(double range, double along, double q, const ConeTable& cone) const {
  return tabulatedUpdate(hit_profile_, range, along, q, cone);
}

float InverseSensorModel::noReturnUpdateInCone(double clear_distance, double along, double q,
                                               const ConeTable& cone) const {
  return tabulatedUpdate(free_profile_, clear_distance, along, q, cone);
}

// `profile` (the hit or the no-return one) at `along` for a beam ending at `reference`, weighted.
float InverseSensorModel::profileUpdate(const std::vector<double>& profile, double reference, double along, double w,
                                        double sigma) const {
  const double u = (along - reference) / sigma;
  if (u >= kBehindCutoff) return 0.0f;
  // Deep in the free valley F = 1 and G = 0 to float precision.
  if (u < kPureFreeBelow) return static_cast<float>(w * l_free_);
  return static_cast<float>(w * lookup(profile, u));
}

float InverseSensorModel::directUpdate(const std::vector<double>& profile, double reference, double along,
                                       double off_axis, double half_angle) const {
  const double w = coneWeight(off_axis, half_angle);
  if (w <= 0.0 || along < 0.0) return 0.0f;
  return profileUpdate(profile, reference, along, w, sigmaAt(reference, off_axis, half_angle));
}

InverseSensorModel::ConeTable::ConeTable(const InverseSensorModel& model, double half_angle)
    : half_angle_(half_angle), tan_half_(std::tan(half_angle)), weight_(kSteps + 1), widen_(kSteps + 1) {
  for (int i = 0; i <= kSteps; ++i) {
    const double angle = std::atan(double(i) / kSteps * tan_half_);
    weight_[i] = static_cast<float>(model.coneWeight(angle, half_angle));  // 0 at the edge, q = 1
    widen_[i] = static_cast<float>(model.widening(angle, half_angle));
  }
}

float InverseSensorModel::tabulatedUpdate(const std::vector<double>& profile, double reference, double along,
                                          double q, const ConeTable& cone) const {
  if (!(q < 1.0) || along < 0.0) return 0.0f;
  const double x = q * ConeTable::kSteps;
  const int i = static_cast<int>(x);  // < kSteps, so i + 1 is in the table
  const double f = x - i;
  const double w = cone.weight_[i] + f * (cone.weight_[i + 1] - cone.weight_[i]);
  if (w <= 0.0) return 0.0f;
  const double widen = cone.widen_[i] + f * (cone.widen_[i + 1] - cone.widen_[i]);
  return profileUpdate(profile, reference, along, w, sigmaWidened(reference, widen));
}

}  // namespace octo_slice_mapper
