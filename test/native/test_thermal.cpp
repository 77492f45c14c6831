// Thermal model (eq 1) and its inverse (eq 17): steady states, exact discretisation, energy.
#include <gtest/gtest.h>
#include <math.h>
#include "sma_host/plant.hpp"
#include "sma/fixed.hpp"
#include "sma/thermal.hpp"

namespace {
const sma::Params kP;
}

TEST(Thermal, SteadyStatesOfEq1MatchModelMd) {
  const sma::Thermal<double> th(kP);
  EXPECT_NEAR(th.steady_state(1.0), 49.56, 5e-3);
  EXPECT_NEAR(th.steady_state(1.45), 79.94, 5e-3);
  EXPECT_NEAR(th.steady_state(2.0), 132.24, 5e-3);
  // At the steady state the rate of eq 1 is zero.
  EXPECT_NEAR(th.rate(th.steady_state(1.3), 1.3), 0.0, 1e-12);
}

TEST(Thermal, RateHasTheSignOfThePowerBalance) {
  const sma::Thermal<double> th(kP);
  EXPECT_GT(th.rate(22.0, 1.0), 0.0);  // heating from ambient
  EXPECT_LT(th.rate(60.0, 0.0), 0.0);  // cooling with heater off
  EXPECT_NEAR(th.rate(22.0, 0.0), 0.0, 1e-15);
}

TEST(Thermal, ExactStepMatchesFineIntegration) {
  const sma::ThermalStep<double> step(kP, 0.01);
  const sma::Thermal<double> th(kP);
  double T_exact = 22.0, T_fine = 22.0;
  for (int k = 0; k < 1000; ++k) {  // 10 s at 1.5 V
    T_exact = step(T_exact, 1.5);
    for (int j = 0; j < 100; ++j) {  // RK2 at 0.1 ms
      const double r1 = th.rate(T_fine, 1.5);
      const double r2 = th.rate(T_fine + 1e-4 * r1, 1.5);
      T_fine += 0.5e-4 * (r1 + r2);
    }
  }
  EXPECT_NEAR(T_exact, T_fine, 1e-6);
  // After 10 s (2.4 tau) the first-order response is 1 - exp(-10/tau) of the way.
  const double Tss = th.steady_state(1.5);
  EXPECT_NEAR((T_exact - 22.0) / (Tss - 22.0), 1.0 - exp(-10.0 / 4.1206), 1e-4);
}

TEST(Thermal, InverseEq17GivesTheVoltageThatProducesTheRequestedSlope) {
  const sma::Thermal<double> th(kP);
  for (double T = 25; T < 120; T += 7.3)
    for (double slope = -0.5; slope < 20; slope += 1.7) {
      const double V = th.voltage_for(T, slope);
      if (V > 0) {
        EXPECT_NEAR(th.rate(T, V), slope, 1e-9) << T << " " << slope;
      } else {
        EXPECT_LE(slope, th.rate(T, 0.0) + 1e-12);  // faster cooling than passive: V = 0
      }
    }
  // Steady holding voltage: eq 17 with dT/dt = 0 inverts the steady state.
  EXPECT_NEAR(th.voltage_for(th.steady_state(1.2), 0.0), 1.2, 1e-12);
  EXPECT_EQ(th.voltage_for(NAN, 0.0), 0.0);
}

TEST(Thermal, EffectsChangeThePowerBalanceAsNamed) {
  sma::Effects fx;
  fx.ambient_offset_K = 3.0;
  EXPECT_NEAR(sma::Thermal<double>(kP, fx).steady_state(0.0), 25.0, 1e-12);
  fx = sma::Effects();
  fx.convection_beta_per_K = 0.01;  // more loss when hot: lower steady state at 1.5 V
  const sma::Thermal<double> conv(kP, fx), plain(kP);
  EXPECT_GT(conv.heat_loss(80.0), plain.heat_loss(80.0));
  EXPECT_NEAR(conv.heat_loss(80.0), plain.heat_loss(80.0) * (1 + 0.01 * 58.0), 1e-12);
  fx = sma::Effects();
  fx.resistance_k = 0.2;  // R(eps = 1) = 1.2 R: less power at the same V
  const sma::Thermal<double> res(kP, fx);
  EXPECT_NEAR(res.heat_in(1.0, 1.0), 1.0 / 1.2, 1e-12);
  EXPECT_NEAR(res.heat_in(1.0, 0.0), 1.0, 1e-12);
  // Eq 17 with the effect still inverts its own forward model.
  EXPECT_NEAR(res.rate(60.0, res.voltage_for(60.0, 3.0, 0.5), 0.5), 3.0, 1e-9);
}

// Energy balance of the plant: electrical energy in - heat lost = C_th dT (+ L d(eps) with
// latent heat), integrated along a run that crosses the transformation both ways.
class EnergyBalance : public ::testing::TestWithParam<double> {};

TEST_P(EnergyBalance, PlantConservesEnergy) {
  sma::Effects fx;
  fx.latent_heat_J = GetParam();
  sma::Plant plant(kP, fx);
  const sma::Thermal<double> th(kP, fx);
  const double dt = 1e-3;  // the plant sub-steps at 1 ms, integrate the books at the same rate
  double e_in = 0, e_loss = 0;
  const double T0 = plant.temperature(), eps0 = plant.fraction();
  for (int k = 0; k < 60000; ++k) {
    const double V = k < 30000 ? 1.6 : 0.2;
    const double T_before = plant.temperature();
    plant.step(V, dt);
    const double T_mid = 0.5 * (T_before + plant.temperature());
    e_in += th.heat_in(V) * dt;
    e_loss += th.heat_loss(T_mid) * dt;
  }
  const double stored = th.C * (plant.temperature() - T0) + fx.latent_heat_J * (plant.fraction() - eps0);
  // Budget: the run moves ~ 60 J through the wire; trapezoidal books at 1 ms are good to 1e-3.
  EXPECT_NEAR(e_in - e_loss, stored, 0.05) << "in " << e_in << " loss " << e_loss;
}
INSTANTIATE_TEST_SUITE_P(WithAndWithoutLatentHeat, EnergyBalance, ::testing::Values(0.0, 1.0, 3.0));

// The AVR's decay factors exp(-dt / tau) come from exp_neg_compact (scalar.hpp): against libm in
// double, relative error small where the factors live (x = dt / tau up to a few), underflow to 0
// for a vanishing time constant, NaN kept, a negative argument the reciprocal.
TEST(ExpNegCompact, MatchesDoubleExp) {
  double worst_small = 0.0, worst_large = 0.0;
  for (int i = 0; i <= 20000; ++i) {
    const double x = 20.0 * i / 20000.0;
    const double want = std::exp(-x);
    const double rel = std::fabs(static_cast<double>(sma::exp_neg_compact(static_cast<float>(x))) -
                                 want) / want;
    if (x <= 1.0) worst_small = std::max(worst_small, rel);
    worst_large = std::max(worst_large, rel);
  }
  EXPECT_LT(worst_small, 3e-6);
  EXPECT_LT(worst_large, 1e-4);
  EXPECT_EQ(sma::exp_neg_compact(1e7f), 0.0f);
  EXPECT_TRUE(std::isnan(sma::exp_neg_compact(NAN)));
  EXPECT_NEAR(sma::exp_neg_compact(-2.0f), std::exp(2.0), 1e-5 * std::exp(2.0));
  EXPECT_EQ(sma::exp_neg_compact(0.0f), 1.0f);
}

// The controller's temperature estimate (WireStep, eq 1 over a tick) fed the voltage that eq 17
// says holds its temperature (V_hold, the PID's floor on a hold) must stay there: a step whose
// gain disagrees with V_hold walks the estimate, and the floor with it, tick after tick. In
// Q16.16 an a rounded apart from b (1 - a ~0.0024, ~160 raw steps) walks it ~2 K in 4 min.
template <class T>
double hold_walk_K(const sma::Params& p, double T0, int ticks) {
  const sma::Effects fx;
  const double C = p.heat_capacity(), G = p.conductance();
  const sma::Thermal<T> th(p, fx, C, G);
  const sma::WireStep<T> step(th, p, 0.01, C, G);
  T Tw = sma::from_double<T>(T0);
  for (int k = 0; k < ticks; ++k) Tw = step(Tw, th.hold_voltage(Tw));
  return sma::to_double(Tw) - T0;
}

TEST(Thermal, TheEstimateHeldAtItsOwnVHoldStaysPutInEveryScalar) {
  struct Wire {
    double h, R, d0;
  };
  for (const Wire& w : {Wire{165, 1.0, 0.5e-3}, Wire{120, 1.0, 0.5e-3}, Wire{219, 1.0, 0.5e-3}, Wire{300, 1.0, 0.5e-3},
                        Wire{165, 1.37, 0.5e-3}, Wire{165, 1.0, 0.25e-3}, Wire{165, 0.3, 1.0e-3}}) {
    sma::Params p;
    p.h = w.h;
    p.R = w.R;
    p.d0 = w.d0;
    for (double T0 : {35.0, 62.0, 85.0}) {
      const int ten_minutes = 60000;
      EXPECT_NEAR(hold_walk_K<double>(p, T0, ten_minutes), 0.0, 1e-6) << "h " << w.h << " R " << w.R << " T " << T0;
      EXPECT_NEAR(hold_walk_K<float>(p, T0, ten_minutes), 0.0, 0.05) << "h " << w.h << " R " << w.R << " T " << T0;
      EXPECT_NEAR(hold_walk_K<sma::Fixed>(p, T0, ten_minutes), 0.0, 0.05)
          << "Q16.16, h " << w.h << " R " << w.R << " d0 " << w.d0 << " T " << T0;
    }
  }
}
