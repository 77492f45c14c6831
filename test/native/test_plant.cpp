// The simulated plant: the model's boxes forward, plus each hidden effect doing what its name
// says, sensor noise and the rig's quantisation.
#include <gtest/gtest.h>
#include <math.h>
#include <vector>
#include "sma_host/plant.hpp"

namespace {
const sma::Params kP;
}

TEST(Plant, WithoutEffectsItIsThePapersModel) {
  sma::Plant plant(kP);
  const sma::PhaseCurves<double> curves(kP);
  for (int k = 0; k < 6000; ++k) plant.step(1.45, 0.01);  // 60 s = 15 tau at 1.45 V
  EXPECT_NEAR(plant.temperature(), 79.94, 0.01);
  EXPECT_NEAR(plant.fraction(), curves.eps_heat(plant.temperature()), 1e-12);
  EXPECT_NEAR(plant.displacement(), kP.g * plant.fraction(), 1e-12);
  EXPECT_EQ(plant.measure(), plant.displacement());  // ideal sensor
}

TEST(Plant, SensorDelayShiftsTheSignalByExactlyTheDelay) {
  sma::Effects fx;
  fx.sensor_delay_s = 0.12;
  sma::Plant delayed(kP, fx), truth(kP);
  std::vector<double> d;
  for (int k = 0; k < 3000; ++k) {
    delayed.step(1.6, 0.01);
    truth.step(1.6, 0.01);
    d.push_back(truth.displacement());
    if (k >= 12) {
      ASSERT_NEAR(delayed.measure_clean(), d[static_cast<size_t>(k - 12)], 1e-12);
    }
  }
}

TEST(Plant, SensorLagIsAFirstOrderLowPass) {
  sma::Effects fx;
  fx.sensor_lag_s = 0.5;
  sma::Plant lagged(kP, fx), truth(kP);
  for (int k = 0; k < 2000; ++k) {  // heat well into austenite and hold there
    lagged.step(2.0, 0.01);
    truth.step(2.0, 0.01);
  }
  EXPECT_NEAR(lagged.measure_clean(), truth.displacement(), 1e-6);  // settled
  // Cool: the true position falls, the lagged reading trails and approaches it.
  double gap_prev = 0;
  for (int k = 0; k < 300; ++k) {
    lagged.step(0.0, 0.01);
    truth.step(0.0, 0.01);
    const double gap = lagged.measure_clean() - truth.displacement();
    ASSERT_GE(gap, -1e-12);
    if (k > 150) {
      ASSERT_LE(gap, gap_prev + 1e-9);
    }
    gap_prev = gap;
  }
}

TEST(Plant, SensorCalibrationIsGainAndOffset) {
  sma::Effects fx;
  fx.sensor_gain = 1.1;
  fx.sensor_offset_mm = -0.05;
  sma::Plant plant(kP, fx);
  for (int k = 0; k < 1500; ++k) plant.step(1.6, 0.01);
  EXPECT_NEAR(plant.measure_clean(), 1.1 * plant.displacement() - 0.05, 1e-12);
}

TEST(Plant, AmbientOffsetAndConvectionMoveTheSteadyState) {
  sma::Effects warm;
  warm.ambient_offset_K = 4.0;
  sma::Plant a(kP, warm);
  for (int k = 0; k < 10000; ++k) a.step(1.0, 0.01);
  EXPECT_NEAR(a.temperature(), 49.56 + 4.0, 0.01);
  sma::Effects conv;
  conv.convection_beta_per_K = 0.01;
  sma::Plant c(kP, conv);
  for (int k = 0; k < 10000; ++k) c.step(1.0, 0.01);
  // Steady state solves G dT (1 + beta dT) = V^2 / R.
  const double G = kP.conductance(), b = 0.01;
  const double dT = (-1 + sqrt(1 + 4 * b * 1.0 / G)) / (2 * b);
  EXPECT_NEAR(c.temperature(), 22.0 + dT, 0.01);
}

TEST(Plant, LatentHeatSlowsTheTransformation) {
  sma::Effects fx;
  fx.latent_heat_J = 2.0;
  sma::Plant latent(kP, fx), plain(kP);
  double t_plain = -1, t_latent = -1;
  for (int k = 0; k < 6000; ++k) {
    latent.step(1.6, 0.01);
    plain.step(1.6, 0.01);
    if (t_plain < 0 && plain.fraction() > 0.5) t_plain = k * 0.01;
    if (t_latent < 0 && latent.fraction() > 0.5) t_latent = k * 0.01;
  }
  ASSERT_GT(t_plain, 0);
  ASSERT_GT(t_latent, 0);
  // Absorbing ~1 J at ~1.4 W net takes extra time: well over a second here.
  EXPECT_GT(t_latent - t_plain, 0.5);
  // Same steady state: latent heat only matters while eps changes.
  EXPECT_NEAR(latent.temperature(), plain.temperature(), 0.01);
}

TEST(Plant, ResistanceThatChangesWithPhaseChangesThePower) {
  sma::Effects fx;
  fx.resistance_k = -0.2;  // austenite conducts better: more power at the same V when hot
  sma::Plant p(kP, fx), plain(kP);
  for (int k = 0; k < 10000; ++k) {
    p.step(1.8, 0.01);
    plain.step(1.8, 0.01);
  }
  EXPECT_NEAR(p.fraction(), 1.0, 1e-12);
  EXPECT_NEAR(p.temperature() - 22.0, (plain.temperature() - 22.0) / 0.8, 0.01);
}

TEST(Plant, NoiseAndAdcQuantisationHaveTheStatedSize) {
  sma::RigOptions rig;
  rig.noise_mm = 0.002;
  sma::Plant noisy(kP, sma::Effects(), rig);
  double sum = 0, sum2 = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const double e = noisy.measure() - noisy.displacement();
    sum += e;
    sum2 += e * e;
  }
  EXPECT_NEAR(sum / n, 0.0, 1e-4);
  EXPECT_NEAR(sqrt(sum2 / n), 0.002, 1e-4);
  rig = sma::RigOptions();
  rig.adc_step_mm = 0.002;
  sma::Plant q(kP, sma::Effects(), rig);
  for (int k = 0; k < 500; ++k) {
    q.step(1.6, 0.01);
    const double y = q.measure();
    ASSERT_NEAR(y / 0.002, floor(y / 0.002 + 0.5), 1e-6);
    ASSERT_LE(fabs(y - q.displacement()), 0.001 + 1e-12);
  }
}

TEST(Plant, PwmQuantisationFollowsTheDutyMap) {
  sma::RigOptions rig;
  rig.pwm_top = 15999;
  sma::Plant p(kP, sma::Effects(), rig);
  for (double V = 0.0; V <= 2.0; V += 0.0137) {
    const double a = p.applied_voltage(V);
    const double duty = (a / 5.0) * (a / 5.0);
    ASSERT_NEAR(duty * 15999, floor(duty * 15999 + 0.5), 1e-6);  // an integer count
    ASSERT_LE(fabs(duty - (V / 5.0) * (V / 5.0)), 0.5 / 15999 + 1e-12);
  }
  EXPECT_EQ(p.applied_voltage(-1.0), 0.0);
  EXPECT_EQ(p.applied_voltage(NAN), 0.0);
}

TEST(Plant, SubsteppedNonLinearThermalModelIsAccurate) {
  // All three non-linear thermal effects at once: 10 ms steps (5 ms sub-steps) against 0.1 ms.
  sma::Effects fx;
  fx.latent_heat_J = 2.0;
  fx.convection_beta_per_K = 0.005;
  fx.resistance_k = -0.1;
  sma::Plant coarse(kP, fx), fine(kP, fx);
  double worst = 0;
  for (int k = 0; k < 20000; ++k) {
    const double V = (k / 1500) % 2 ? 0.3 : 1.5 + 0.1 * ((k / 3000) % 3);
    coarse.step(V, 0.01);
    for (int j = 0; j < 100; ++j) fine.step(V, 1e-4);
    worst = fmax(worst, fabs(coarse.displacement() - fine.displacement()));
  }
  EXPECT_LT(worst, 0.0005);
}
