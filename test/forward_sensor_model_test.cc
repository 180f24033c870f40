#include "octo_slice_mapper/forward_sensor_model.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace octo_slice_mapper;

namespace {

TEST(ForwardSensorModel, MostLikelyReadingIsTheExpectedRange) {
  const ForwardSensorModel model(ForwardSensorModelOptions{}, 0.05, 10.0);
  const double expected = 3.0;
  const double at = model.logHit(expected, expected);
  EXPECT_GT(at, model.logHit(expected + 0.05, expected));
  EXPECT_GT(at, model.logHit(expected - 0.05, expected));
  EXPECT_NEAR(model.logHit(expected + 0.05, expected), model.logHit(expected - 0.05, expected), 1e-12);
  // Far from the expected range only the random-reading term is left.
  EXPECT_NEAR(model.logHit(expected + 2.0, expected), model.logHitNoObstacle(), 1e-9);
  EXPECT_NEAR(model.logHitNoObstacle(), std::log(0.15 / 10.0), 1e-12);
}

TEST(ForwardSensorModel, ReturnsIntegrateToTheHitAndRandomShares) {
  // Over all readings in [0, z_max], a return's density integrates to z_hit + z_rand; together
  // with P(no return) = z_miss the mixture is a distribution.
  ForwardSensorModelOptions o;
  const ForwardSensorModel model(o, 0.05, 10.0);
  double total = 0.0;
  const double dz = 1e-4;
  for (double z = 0.0; z < 10.0; z += dz) total += std::exp(model.logHit(z, 4.0)) * dz;
  EXPECT_NEAR(total + std::exp(model.logNoReturn(true)), o.z_hit + o.z_rand + o.z_miss, 1e-3);
  EXPECT_NEAR(o.z_hit + o.z_rand + o.z_miss, 1.0, 1e-12);
}

TEST(ForwardSensorModel, NoReturnIsLikelyOnlyWithoutAnObstacle) {
  const ForwardSensorModel model(ForwardSensorModelOptions{}, 0.05, 10.0);
  EXPECT_NEAR(model.logNoReturn(false), std::log(0.85), 1e-12);
  EXPECT_NEAR(model.logNoReturn(true), std::log(0.02), 1e-12);
}

TEST(ForwardSensorModel, NoiseGrowsWithRangeAndNeverBelowHalfACell) {
  const ForwardSensorModel model(ForwardSensorModelOptions{}, 0.05, 10.0);
  EXPECT_GT(model.sigma(8.0), model.sigma(1.0));
  EXPECT_GE(model.sigma(0.0), 0.025);
  EXPECT_GT(model.traceLength(5.0), 5.0 + 3.0 * model.sigma(5.0));
}

}  // namespace
