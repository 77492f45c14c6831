// Inverse model (eqs 14-17): H(H^-1(u)) = u along heating, cooling and minor-loop paths, where u
// is reachable; its loop memory agrees with an independent forward model; eq 17 on the path.
#include <gtest/gtest.h>
#include <math.h>
#include "sma/inverse.hpp"
#include "sma_host/plant.hpp"

namespace {
const sma::Params kP;

// A reference path with nested reversals: heat, partial cool, reheat past, cool, ...
double path(double t) {
  const double knots_t[] = {0, 20, 35, 55, 75, 90, 110, 130};
  const double knots_u[] = {0.05, 0.70, 0.45, 0.85, 0.30, 0.55, 0.15, 0.60};
  for (int k = 1; k < 8; ++k)
    if (t < knots_t[k]) {
      const double w = (t - knots_t[k - 1]) / (knots_t[k] - knots_t[k - 1]);
      return knots_u[k - 1] + w * (knots_u[k] - knots_u[k - 1]);
    }
  return knots_u[7];
}
}  // namespace

TEST(Inverse, ForwardOfInverseIsIdentityWhereReachable) {
  sma::InverseModel<double> inv(kP);
  const sma::PhaseCurves<double> curves(kP);
  sma::Hysteresis<double> forward(curves, kP.T_amb);  // independent walker along T_d
  const double dt = 0.01;
  int checked_heat = 0, checked_cool = 0;
  double T_prev = kP.T_amb;
  for (int k = 0; k < 13000; ++k) {
    const double u = path(k * dt);
    inv.step(u);
    const double Td = inv.desired_temperature();
    const double eps = forward.update(Td);
    // Same loop memory: the inverse's own walker and the independent one agree.
    ASSERT_NEAR(inv.memory().eps(), eps, 1e-12);
    const bool heating_on_curve = Td > T_prev && Td > kP.T_AS && Td < kP.T_AF;
    const sma::CoolingLoop<double> L = forward.loop();
    const bool cooling_on_branch = Td < T_prev && Td < L.T_MSi && Td > kP.T_MF;
    if (heating_on_curve || cooling_on_branch) {
      ASSERT_NEAR(kP.g * eps, u, 1e-9) << "t=" << k * dt << " Td=" << Td;
      (heating_on_curve ? checked_heat : checked_cool)++;
    }
    T_prev = Td;
  }
  // The check ran on both branches, over a good part of the path.
  EXPECT_GT(checked_heat, 2000);
  EXPECT_GT(checked_cool, 1000);
}

TEST(Inverse, ReferenceReversalOpensTheSameMinorLoopAsThePlant) {
  // Heat to 0.65 mm, reverse: the inverse's loop has the forward model's T_i, T_MSi and top.
  sma::InverseModel<double> inv(kP);
  for (int k = 0; k <= 1000; ++k) inv.step(0.65 * k / 1000.0);
  const double T_i = inv.desired_temperature();
  inv.step(0.649);  // 1 um down: past the inverse's reversal deadband (0.1 um)
  const sma::CoolingLoop<double> L = inv.memory().loop();
  const sma::PhaseCurves<double> curves(kP);
  const sma::CoolingLoop<double> expect = curves.make_loop(T_i, curves.eps_heat(T_i));
  EXPECT_NEAR(L.T_i, expect.T_i, 1e-12);
  EXPECT_NEAR(L.T_MSi, expect.T_MSi, 1e-12);
  EXPECT_NEAR(L.top, expect.top, 1e-12);
  // Eq 16 on this loop: T = T_MF + (T_MSi - T_MF) / pi acos(1 - 2 eps_d / (eps_i + j_i)).
  const double eps_d = 0.649 / kP.g;
  EXPECT_NEAR(inv.desired_temperature(),
              kP.T_MF + (L.T_MSi - kP.T_MF) / M_PI * acos(1 - 2 * eps_d / L.top), 1e-9);
  sma::InverseModel<double> inv3(kP);
  for (int k = 0; k <= 1000; ++k) inv3.step(0.65 * k / 1000.0);
  inv3.step(0.64);  // eps_d = 0.668 < eps_i: on the eq-11 branch, above T_MF
  EXPECT_GT(inv3.desired_temperature(), kP.T_MF);
}

TEST(Inverse, FeedforwardAloneTracksASlowReferenceOnTheIdealPlant) {
  // Open loop, model = plant: the inverse alone must track a slow heating ramp on the major
  // curve closely; the error is the thermal lag that eq 17 compensates.
  sma::InverseModel<double> inv(kP);
  sma::Plant plant(kP);
  double max_err = 0;
  for (int k = 0; k < 6000; ++k) {  // 0.1 -> 0.7 mm in 60 s
    const double u = 0.1 + 0.6 * k / 6000.0;
    plant.step(inv.step(u), 0.01);
    if (k > 1000) max_err = fmax(max_err, fabs(plant.displacement() - 0.1 - 0.6 * (k + 1) / 6000.0));
  }
  EXPECT_LT(max_err, 0.005);
}

TEST(Inverse, VoltageIsNeverNegativeNorAboveVmaxNorNaN) {
  sma::InverseModel<double> inv(kP);
  sma::Noise rng(3);
  for (int k = 0; k < 50000; ++k) {
    double u = (rng.uniform() - 0.2) * 2.0;  // also outside 0..g
    if (k % 997 == 0) u = NAN;
    if (k % 1009 == 0) u = INFINITY;
    const double v = inv.step(u);
    ASSERT_TRUE(std::isfinite(v));
    ASSERT_GE(v, 0.0);
    ASSERT_LE(v, 2.0);
  }
}
