// Plant B (host/include/sma_host/plant_b.hpp, an independently written plant for the discrepancy
// benchmark) against model.md's check values and against physics: steady states, the thermal
// time constant, energy balance with latent heat and quadratic convection, the hysteresis check
// table, and the sensor effects.
#include <gtest/gtest.h>
#include <math.h>
#include <vector>
#include "sma_host/plant_b.hpp"
#include "sma_host/plant_b_sensor.hpp"

namespace {

using sma_host::plant_b::Sensor;
using sma_host::plant_b::SensorEffects;
using sma_host::plant_b::Transformation;
using sma_host::plant_b::Wire;
using sma_host::plant_b::WireEffects;
using sma_host::plant_b::WirePlant;

constexpr double kDt = 0.01;

double settle(WirePlant& p, double V, double seconds) {
  for (int k = 0; k < static_cast<int>(lround(seconds / kDt)); ++k) p.step(V, kDt);
  return p.temperature();
}

// Walks the phase memory along a temperature path in 0.01 K steps, ending exactly at `to`.
void walk(Transformation& tr, double from, double to) {
  const int n = static_cast<int>(ceil(fabs(to - from) / 0.01));
  for (int k = 1; k <= n; ++k) tr.update(from + (to - from) * k / n);
}

TEST(PlantB, ThermalConstantsOfTableII) {
  const Wire w;
  EXPECT_NEAR(w.heat_capacity(), 0.14952, 1e-5);
  EXPECT_NEAR(w.conductance(), 0.036285, 1e-6);
  EXPECT_NEAR(w.heat_capacity() / w.conductance(), 4.1206, 1e-4);
}

TEST(PlantB, SteadyStatesOfEq1) {
  const double V[3] = {1.0, 1.45, 2.0}, T[3] = {49.56, 79.94, 132.24};  // model.md
  for (int i = 0; i < 3; ++i) {
    const Wire w;
    WirePlant p(w, WireEffects());
    EXPECT_NEAR(settle(p, V[i], 80.0), T[i], 0.01) << V[i] << " V";
  }
}

TEST(PlantB, StepResponseHasTheTimeConstantTau) {
  // below T_AS nothing transforms: eq 1 alone, T - T_amb = dT_ss (1 - exp(-t / tau))
  const Wire w;
  WirePlant p(w, WireEffects());
  const double tau = w.heat_capacity() / w.conductance();
  const double t = 4.0;
  settle(p, 1.0, t);
  EXPECT_NEAR(p.temperature() - 22.0, (49.56 - 22.0) * (1.0 - exp(-t / tau)), 2e-3);
}

TEST(PlantB, SteadyStatesWithTheWireEffects) {
  const Wire w;
  const double G = w.conductance();
  {  // ambient offset: the whole curve moves by the offset
    WireEffects fx;
    fx.ambient_offset_K = -4.5;
    WirePlant p(w, fx);
    EXPECT_NEAR(settle(p, 1.0, 80.0), 49.56 - 4.5, 0.01);
  }
  {  // quadratic convection: V^2 / R = G dT + G2 dT^2
    WireEffects fx;
    fx.G2_W_per_K2 = 0.01 * G;
    WirePlant p(w, fx);
    const double P = 2.0 * 2.0 / w.R, a = fx.G2_W_per_K2;
    const double dT = (-G + sqrt(G * G + 4.0 * a * P)) / (2.0 * a);
    EXPECT_NEAR(settle(p, 2.0, 80.0), 22.0 + dT, 0.01);
  }
  {  // resistance of the fully transformed wire R (1 + k_R); latent heat changes no steady state
    WireEffects fx;
    fx.k_R = -0.2;
    fx.latent_K = 20.0;
    WirePlant p(w, fx);
    EXPECT_NEAR(settle(p, 2.0, 80.0), 22.0 + 4.0 / (w.R * 0.8 * G), 0.01);
    EXPECT_NEAR(p.fraction(), 1.0, 1e-12);
  }
}

TEST(PlantB, EnergyBalanceWithLatentHeatAndQuadraticConvection) {
  // Heat through the whole band (no minor-loop rise), then cool back: the electrical energy in
  // equals the heat lost plus the sensible and the latent heat stored.
  const Wire w;
  WireEffects fx;
  fx.latent_K = 20.0;  // L = 3 J over C_th = 0.1495 J/K
  fx.G2_W_per_K2 = 0.005 * w.conductance();
  fx.k_R = -0.2;
  WirePlant p(w, fx);
  const double C = w.heat_capacity(), T0 = p.temperature(), e0 = p.fraction();
  double in = 0.0, out = 0.0;
  double peak_eps = 0.0;
  for (int k = 0; k < 6000; ++k) {
    const double V = k < 2500 ? 1.6 : 0.0;
    // trapezoid over the tick, with fine ticks the heat flows change little within one
    const double pin0 = p.heating_W(V, p.fraction()), pout0 = p.loss_W(p.temperature());
    p.step(V, kDt);
    in += 0.5 * kDt * (pin0 + p.heating_W(V, p.fraction()));
    out += 0.5 * kDt * (pout0 + p.loss_W(p.temperature()));
    peak_eps = fmax(peak_eps, p.fraction());
    if (k == 2499 || k == 5999) {  // at the end of the heating (fully transformed) and of the run
      const double stored = C * (p.temperature() - T0) + fx.latent_K * C * (p.fraction() - e0);
      EXPECT_NEAR(in - out, stored, 1e-3 * in) << "t = " << (k + 1) * kDt;
    }
  }
  EXPECT_NEAR(peak_eps, 1.0, 1e-9);
  EXPECT_LT(p.fraction(), 0.5);  // cooled back through part of the band
}

TEST(PlantB, LatentHeatDelaysHeatingThroughTheBand) {
  const Wire w;
  WireEffects fx;
  fx.latent_K = 20.0;
  WirePlant with(w, fx), without(w, WireEffects());
  double t_with = -1, t_without = -1;
  for (int k = 0; k < 3000 && (t_with < 0 || t_without < 0); ++k) {
    with.step(2.0, kDt);
    without.step(2.0, kDt);
    if (t_with < 0 && with.temperature() > 85.0) t_with = k * kDt;
    if (t_without < 0 && without.temperature() > 85.0) t_without = k * kDt;
  }
  ASSERT_GT(t_without, 0.0);
  // L = 20 K x C_th absorbed at a net heating power of roughly V^2/R - G (65 - 22) = 2.44 W
  const double expect = 20.0 * w.heat_capacity() / (4.0 - w.conductance() * 43.0);
  EXPECT_NEAR(t_with - t_without, expect, 0.35 * expect);
}

TEST(PlantB, HeatingCurveCheckValues) {
  const Wire w;
  const Transformation tr(w);
  EXPECT_NEAR(tr.heating_curve(55.0), 0.0623, 1e-3);
  EXPECT_NEAR(tr.heating_curve(60.8), 0.2793, 1e-3);
  EXPECT_NEAR(tr.heating_curve(63.1), 0.3931, 1e-3);
  EXPECT_NEAR(tr.heating_curve(68.5), 0.6724, 1e-3);
  EXPECT_NEAR(tr.heating_curve(75.9), 0.9521, 1e-3);
}

TEST(PlantB, MartensiteStartOfEachLoop) {
  const Wire w;
  const Transformation tr(w);
  const double Ti[7] = {60.8, 63.1, 68.5, 71.5, 75.9, 80.1, 55.0};
  const double Tms[7] = {51.333, 39.357, 31.768, 29.812, 29.338, 27.772, 55.0};
  for (int i = 0; i < 7; ++i)
    EXPECT_NEAR(tr.branch_from(Ti[i], tr.heating_curve(Ti[i])).T_MSi, Tms[i], 1e-3) << Ti[i];
}

TEST(PlantB, MinorLoopCheckValues) {
  const Wire w;
  {
    Transformation tr(w);
    walk(tr, 22.0, 68.5);
    EXPECT_NEAR(tr.fraction(), 0.6724, 1e-3);
    const double T[6] = {60.0, 59.1, 40.0, 31.768, 30.0, 25.0}, eps[6] = {0.8442, 0.8624, 0.8624, 0.8624, 0.7945, 0.1856};
    double at = 68.5;
    for (int i = 0; i < 6; ++i) {
      walk(tr, at, T[i]);
      at = T[i];
      EXPECT_NEAR(tr.fraction(), eps[i], 1e-3) << T[i];
    }
    walk(tr, at, 22.0);
    EXPECT_NEAR(tr.fraction(), 0.0, 1e-9);
  }
  {
    Transformation tr(w);
    walk(tr, 22.0, 63.1);
    const double T[5] = {50.0, 39.357, 35.0, 30.0, 25.0}, eps[5] = {0.5531, 0.5531, 0.4715, 0.2427, 0.0398};
    double at = 63.1;
    for (int i = 0; i < 5; ++i) {
      walk(tr, at, T[i]);
      at = T[i];
      EXPECT_NEAR(tr.fraction(), eps[i], 1e-3) << T[i];
    }
  }
}

TEST(PlantB, ReheatShortOfTransformationOpensANewLoop) {
  // Plant B's reading (docs/plant2.md): every reversal fixes a new cooling branch at its peak
  // (eqs 7-10), also after a re-heat that transformed nothing.
  const Wire w;
  Transformation tr(w);
  walk(tr, 22.0, 68.5);
  walk(tr, 68.5, 45.0);
  EXPECT_NEAR(tr.fraction(), 0.8624, 1e-3);
  walk(tr, 45.0, 55.0);  // eps_h(55) = 0.06: below the wire's fraction, nothing transforms
  EXPECT_NEAR(tr.fraction(), 0.8624, 1e-3);
  walk(tr, 55.0, 30.0);
  // the loop of T_i = 55: T_MSi clamped to 55 (model.md), no rise, eq 11 from 55 down to T_MF
  EXPECT_NEAR(tr.branch().T_MSi, 55.0, 1e-9);
  EXPECT_NEAR(tr.fraction(), 0.8624 * 0.5 * (1.0 - cos(M_PI * (30.0 - 22.0) / (55.0 - 22.0))), 1e-3);
}

TEST(PlantB, ReturnPointMemoryKeepsTheLoop) {
  // The library's reading, selectable: a re-heat that transforms nothing leaves the loop it
  // interrupted in place; cooling again rejoins that loop's branch.
  Wire w;
  w.return_point_memory = true;
  Transformation tr(w);
  walk(tr, 22.0, 68.5);
  walk(tr, 68.5, 45.0);
  walk(tr, 45.0, 55.0);
  EXPECT_NEAR(tr.fraction(), 0.8624, 1e-3);
  walk(tr, 55.0, 30.0);
  EXPECT_NEAR(tr.fraction(), 0.7945, 1e-3);  // the 68.5 loop's value at 30 degC
  // a re-heat that does transform starts a new loop at its own peak
  walk(tr, 30.0, 75.0);
  const double eps75 = tr.fraction();
  EXPECT_NEAR(eps75, tr.heating_curve(75.0), 1e-9);
  walk(tr, 75.0, 74.0);
  EXPECT_NEAR(tr.branch().T_i, 75.0, 1e-9);
  EXPECT_GT(tr.fraction(), eps75);  // the rise of the new loop
}

TEST(PlantB, DisplacementAndThermalExpansion) {
  const Wire w;
  WireEffects fx;
  fx.alpha_per_K = 1.1e-5;
  WirePlant p(w, fx);
  EXPECT_NEAR(p.displacement_mm(), 0.0, 1e-12);
  settle(p, 2.0, 80.0);
  EXPECT_NEAR(p.displacement_mm(), 0.958 - 1000.0 * 1.1e-5 * 0.140 * (132.24 - 22.0), 1e-4);
}

TEST(PlantB, SensorDelayIsFractionalAndExact) {
  SensorEffects fx;
  fx.delay_s = 0.255;
  Sensor s(fx, kDt, 1);
  for (int k = 0; k < 200; ++k) {
    const double t = k * kDt, y = s.read(t);  // a ramp: linear interpolation is exact
    if (t > 0.3) {
      EXPECT_NEAR(y, t - 0.255, 1e-9) << t;
    }
  }
}

TEST(PlantB, SensorLagIsFirstOrder) {
  SensorEffects fx;
  fx.lag_s = 0.6;
  Sensor s(fx, kDt, 1);
  s.read(0.0);
  double y = 0.0;
  for (int k = 1; k <= 60; ++k) y = s.read(1.0);
  EXPECT_NEAR(y, 1.0 - exp(-1.0), 5e-3);  // one time constant after a unit step
}

TEST(PlantB, SensorCalibrationNoiseAndAdc) {
  SensorEffects fx;
  fx.gain = 1.15;
  fx.offset_mm = 0.04;
  fx.noise_mm = 0.002;
  Sensor s(fx, kDt, 7);
  double sum = 0, sum2 = 0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const double y = s.read(0.5) - (1.15 * 0.5 + 0.04);
    sum += y;
    sum2 += y * y;
  }
  EXPECT_NEAR(sum / n, 0.0, 1e-4);
  EXPECT_NEAR(sqrt(sum2 / n), 0.002, 1e-4);
  SensorEffects q;
  q.adc_mm = 2.0 / 1024.0;
  Sensor a(q, kDt, 1);
  const double y = a.read(0.3);
  EXPECT_NEAR(y / q.adc_mm, round(y / q.adc_mm), 1e-9);
  EXPECT_NEAR(y, 0.3, q.adc_mm / 2);
}

}  // namespace
