#include "octo_slice_mapper/inverse_sensor_model.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace octo_slice_mapper;

namespace {
const double kHalf = 0.01;  // cone half-angle used in these tests (rad)
}

TEST(InverseSensorModel, ShapeAlongTheBeam) {
  InverseSensorModel model;
  const double r = 2.0;
  const double sigma = model.sigmaAt(r, 0.0, kHalf);
  // Free valley well before the return: the full free log-odds.
  EXPECT_NEAR(model.hitUpdate(r, 0.5, 0.0, kHalf), model.logOddsFree(), 1e-3);
  EXPECT_NEAR(model.hitUpdate(r, 1.5, 0.0, kHalf), model.logOddsFree(), 1e-3);
  // Peak at the return: the full occupied log-odds.
  EXPECT_NEAR(model.hitUpdate(r, r, 0.0, kHalf), model.logOddsOccupied(), 0.05);
  // No information beyond the return.
  EXPECT_NEAR(model.hitUpdate(r, r + 2.0 * sigma, 0.0, kHalf), 0.0f, 1e-4);
  EXPECT_EQ(model.hitUpdate(r, r + 2.01 * sigma, 0.0, kHalf), 0.0f);
  EXPECT_EQ(model.hitUpdate(r, r + 1.0, 0.0, kHalf), 0.0f);
  // Smooth: no jumps between samples sigma/50 apart anywhere from the sensor to behind the return.
  float previous = model.hitUpdate(r, 0.0, 0.0, kHalf);
  float max_step = 0.0f;
  for (double d = sigma / 50; d < r + 3.0 * sigma; d += sigma / 50) {  // across the far cut-off too
    const float v = model.hitUpdate(r, d, 0.0, kHalf);
    max_step = std::max(max_step, std::abs(v - previous));
    previous = v;
  }
  EXPECT_LT(max_step, 0.05f);
  // Rising from valley to peak.
  EXPECT_LT(model.hitUpdate(r, r - 3 * sigma, 0.0, kHalf), model.hitUpdate(r, r - sigma, 0.0, kHalf));
  EXPECT_LT(model.hitUpdate(r, r - sigma, 0.0, kHalf), model.hitUpdate(r, r, 0.0, kHalf));
  // Falling behind the return.
  EXPECT_GT(model.hitUpdate(r, r + sigma, 0.0, kHalf), model.hitUpdate(r, r + 2 * sigma, 0.0, kHalf));
}

TEST(InverseSensorModel, PeakThicknessFollowsRangeUncertainty) {
  InverseSensorModel model;
  auto positiveWidth = [&](double r) {
    double width = 0.0;
    for (double d = 0.0; d < r + 1.0; d += 0.0005) {
      if (model.hitUpdate(r, d, 0.0, kHalf) > 0.0f) width += 0.0005;
    }
    return width;
  };
  const double near = positiveWidth(1.0), far = positiveWidth(5.0);
  EXPECT_GT(near, 0.0);
  EXPECT_GT(far, 1.5 * near);
  EXPECT_GT(model.sigmaAt(5.0, 0.0, kHalf), model.sigmaAt(1.0, 0.0, kHalf));
}

TEST(InverseSensorModel, AcrossTheCone) {
  InverseSensorModel model;
  const double r = 3.0, d = 1.0;
  EXPECT_NEAR(model.hitUpdate(r, d, 0.0, kHalf), model.logOddsFree(), 1e-3);
  // Outside the cone: nothing, for free space and for the return alike.
  EXPECT_EQ(model.hitUpdate(r, d, kHalf, kHalf), 0.0f);
  EXPECT_EQ(model.hitUpdate(r, d, 2 * kHalf, kHalf), 0.0f);
  EXPECT_EQ(model.hitUpdate(r, r, 1.5 * kHalf, kHalf), 0.0f);
  // Smooth, monotone fade towards the cone's edge.
  float previous = model.hitUpdate(r, d, 0.0, kHalf);
  for (double a = 0.0; a <= kHalf; a += kHalf / 100) {
    const float v = model.hitUpdate(r, d, a, kHalf);
    EXPECT_GE(v, previous - 1e-6f) << "free evidence must only weaken off axis (a=" << a << ")";
    EXPECT_LT(std::abs(v - previous), 0.1f);
    previous = v;
  }
  // Transitions widen with the angle off the axis.
  EXPECT_GT(model.sigmaAt(r, 0.8 * kHalf, kHalf), model.sigmaAt(r, 0.0, kHalf));
}

TEST(InverseSensorModel, ConeIsTheBeamsOwnUnlessAskedToCoverTheScanStep) {
  InverseSensorModelOptions o;
  o.beam_opening_angle = 0.001;
  EXPECT_NEAR(InverseSensorModel(o).halfAngleFor(0.0175), 0.0005, 1e-12);
  o.cone_covers_angle_step = true;
  InverseSensorModel model(o);
  EXPECT_NEAR(model.halfAngleFor(0.0175), 0.5 * 0.0175, 1e-12);  // 1 deg scans tile the plane
  EXPECT_NEAR(model.halfAngleFor(0.0001), 0.0005, 1e-12);
}

// For voxels, the occupied part of an update is the share of the peak's mass inside the voxel:
// the voxels along the axis hold one peak's worth between them wherever the return falls in its
// voxel, and the voxel in front of a return that lies mid-voxel gets net free evidence (a peak
// value per voxel marked it occupied too, and walls grew towards the sensor).
TEST(InverseSensorModel, VoxelsAlongTheAxisShareOnePeak) {
  const double voxel = 0.05, r = 2.0;
  const InverseSensorModel model({}, voxel);
  for (double offset = -0.5; offset < 0.5; offset += 0.1) {
    double occupied = 0.0;
    for (int i = -10; i <= 10; ++i) {
      const double centre = r + (i + offset) * voxel;
      occupied += model.hitUpdate(r, centre, 0.0, kHalf) - model.noReturnUpdate(r, centre, 0.0, kHalf);
    }
    // B fades the far flank (u > 1) by the voxel's centre: the voxel behind the return loses its
    // part, up to half the peak for a return on a boundary with sigma at its quarter-voxel floor.
    EXPECT_GT(occupied, 0.5 * model.logOddsOccupied() - 1e-6) << offset;
    EXPECT_LT(occupied, 1.0 * model.logOddsOccupied() + 1e-6) << offset;
  }
  EXPECT_GT(model.hitUpdate(r, r, 0.0, kHalf), 0.8f * model.logOddsOccupied());
  EXPECT_LT(model.hitUpdate(r, r - voxel, 0.0, kHalf), 0.0f);
  // The voxel behind the return gets nothing once it is 2 sigma behind.
  EXPECT_EQ(model.hitUpdate(r, r + voxel, 0.0, kHalf), 0.0f);
  // Off the axis a voxel holds only its share: a smaller occupied part, the same free part.
  EXPECT_NEAR(model.hitUpdate(r, r - 0.3, 0.0, kHalf, 0.25), model.logOddsFree(), 1e-3);
  EXPECT_LT(model.hitUpdate(r, r, 0.0, kHalf, 0.25), 0.5f * model.hitUpdate(r, r, 0.0, kHalf));
}

TEST(InverseSensorModel, NoReturnClearsButNeverMarksOccupied) {
  InverseSensorModel model;
  const double clear = 4.0;
  for (double d = 0.0; d < 6.0; d += 0.01) {
    EXPECT_LE(model.noReturnUpdate(clear, d, 0.0, kHalf), 0.0f) << d;
  }
  EXPECT_NEAR(model.noReturnUpdate(clear, 2.0, 0.0, kHalf), model.logOddsFree(), 1e-3);
  EXPECT_EQ(model.noReturnUpdate(clear, 4.5, 0.0, kHalf), 0.0f);
}

TEST(InverseSensorModel, PriorIsSubtracted) {
  InverseSensorModelOptions o;
  o.prior = 0.3;
  o.p_free = 0.2;
  o.p_occupied = 0.8;
  InverseSensorModel model(o);
  EXPECT_NEAR(model.logOddsFree(), logOdds(0.2) - logOdds(0.3), 1e-6);
  EXPECT_NEAR(model.logOddsOccupied(), logOdds(0.8) - logOdds(0.3), 1e-6);
  // Where the model knows nothing it returns the prior: the update is exactly zero.
  EXPECT_EQ(model.hitUpdate(2.0, 1.0, 1.0, kHalf), 0.0f);
  EXPECT_EQ(model.hitUpdate(2.0, 3.0, 0.0, kHalf), 0.0f);
}

TEST(InverseSensorModel, RejectsInconsistentOptions) {
  InverseSensorModelOptions o;
  o.p_free = 0.6;
  EXPECT_THROW(InverseSensorModel{o}, std::invalid_argument);
  o = {};
  o.p_occupied = 1.0;
  EXPECT_THROW(InverseSensorModel{o}, std::invalid_argument);
  o = {};
  o.sigma_base = 0.0;
  EXPECT_THROW(InverseSensorModel{o}, std::invalid_argument);
}

// hitUpdate interpolates tables of the axis profile: it stays within 1e-4 of the formula over
// the whole transition, for points and for voxels (a coarser table or an off-by-one index would
// not).
TEST(InverseSensorModel, TabulatedProfileMatchesTheFormula) {
  for (double voxel : {0.0, 0.05, 0.02}) {
    const InverseSensorModel model({}, voxel);
    for (double r : {0.5, 3.0, 12.0}) {
      const double sigma = model.sigmaAt(r, 0.0, kHalf), k = 0.5 * voxel / sigma;
      double worst = 0.0;
      for (double u = -8.0; u < 2.0; u += 0.0013) {
        const double exact = model.hitProfileExact(u, k);
        worst = std::max(worst, std::abs(model.hitUpdate(r, r + u * sigma, 0.0, kHalf) - exact));
      }
      EXPECT_LT(worst, 1e-4) << voxel << " " << r;
    }
  }
  EXPECT_NEAR(InverseSensorModel().hitProfileExact(0.0, 0.0), InverseSensorModel().logOddsOccupied(), 0.05);
}

// The tracer evaluates the model from q = tan(off-axis angle) / tan(half-angle) with the cone
// tabulated: it must agree with the direct formula across the cone and along the beam, for hits
// and no-returns, and give nothing at and beyond the cone's edge.
TEST(InverseSensorModel, TabulatedConeMatchesTheDirectModel) {
  const InverseSensorModel model;
  const InverseSensorModel::ConeTable cone(model, kHalf);
  double worst = 0.0;
  int nonzero = 0;
  for (double q = 0.0; q < 1.0; q += 0.00731) {
    const double angle = std::atan(q * cone.tanHalf());
    for (double along = 0.5; along < 3.3; along += 0.0037) {
      const float direct = model.hitUpdate(3.0, along, angle, kHalf);
      worst = std::max(worst, double(std::abs(model.hitUpdateInCone(3.0, along, q, cone) - direct)));
      worst = std::max(worst, double(std::abs(model.noReturnUpdateInCone(3.0, along, q, cone) -
                                              model.noReturnUpdate(3.0, along, angle, kHalf))));
      nonzero += direct != 0.0f;
    }
  }
  EXPECT_LT(worst, 1e-4);
  EXPECT_GT(nonzero, 10000);
  EXPECT_EQ(model.hitUpdateInCone(3.0, 3.0, 1.0, cone), 0.0f);
  EXPECT_EQ(model.hitUpdateInCone(3.0, 1.0, 1.7, cone), 0.0f);
  EXPECT_EQ(model.hitUpdateInCone(3.0, -0.1, 0.0, cone), 0.0f);
}

// The tracer evaluates a beam's axis with its per-beam constants worked out once (axisProfile):
// the same floats as the tabulated model at q = 0, to the bit (a map must not change), for hits
// and no-returns, short and long beams, at voxel size and for points, behind the sensor too.
TEST(InverseSensorModel, AxisProfileIsTheTabulatedModelOnTheAxisToTheBit) {
  for (double voxel : {0.0, 0.05}) {
    InverseSensorModelOptions options;
    options.sigma_angle_gain = 0.5;  // a widening that q = 0 must not apply
    const InverseSensorModel model(options, voxel);
    const InverseSensorModel::ConeTable cone(model, kHalf);
    int nonzero = 0;
    for (double range : {0.31, 1.7, 4.4, 12.9}) {
      const InverseSensorModel::AxisProfile hit = model.axisProfile(range, cone, 1.0);
      const InverseSensorModel::AxisProfile none = model.axisProfile(range, cone, -1.0);
      for (double along = -0.05; along < range + 0.5; along += 0.00173) {
        const float expected = model.hitUpdateInCone(range, along, 0.0, cone);
        EXPECT_EQ(model.onAxis(hit, along), expected) << voxel << " " << range << " " << along;
        EXPECT_EQ(model.onAxis(none, along), model.noReturnUpdateInCone(range, along, 0.0, cone))
            << voxel << " " << range << " " << along;
        nonzero += expected != 0.0f;
      }
    }
    EXPECT_GT(nonzero, 5000);
  }
}
