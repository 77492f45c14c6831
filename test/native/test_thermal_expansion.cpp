// Thermal expansion of the wire (effects.hpp, mechanics.hpp): D = g eps - 1000 alpha L0 (T - T_a).
// Physics: once the wire has fully transformed, further heating lengthens it and the position
// falls; cooling above the martensite start shortens it and the position rises, both by
// 1000 alpha L0 mm per kelvin. The inverse (eq 14) inverts it: forward(inverse(u)) = u.
#include <gtest/gtest.h>
#include <math.h>
#include "sma/inverse.hpp"
#include "sma_host/plant.hpp"

namespace {
const sma::Params kP;               // the paper's wire: L0 = 0.14 m, T_AF = 80.1 degC
const double kAlpha = 1.1e-5;       // NiTi austenite, 1/K
const double kMmPerK = 1000.0 * kAlpha * kP.L0;  // 1.54 um per kelvin

sma::Effects expansion() {
  sma::Effects fx;
  fx.thermal_expansion_per_K = kAlpha;
  return fx;
}
}  // namespace

TEST(ThermalExpansion, HeatedFullyTransformedWireMeasuresLowerAsItHeats) {
  sma::Plant plant(kP, expansion());
  EXPECT_NEAR(plant.measure_clean(), 0.0, 1e-12);  // at ambient eq 12 holds: D = g eps = 0
  // 2 V: steady state 132 degC, far past T_AF.
  double T_prev = 0.0, D_prev = 0.0;
  int checked = 0;
  for (int k = 0; k < 4000; ++k) {
    plant.step(2.0, 0.01);
    if (plant.fraction() < 1.0) continue;
    const double T = plant.temperature(), D = plant.measure_clean();
    if (checked > 0) {
      ASSERT_GT(T, T_prev);
      ASSERT_LT(D, D_prev) << "t=" << plant.time();
      ASSERT_NEAR(D_prev - D, kMmPerK * (T - T_prev), 1e-9);
    }
    T_prev = T;
    D_prev = D;
    ++checked;
  }
  ASSERT_GT(checked, 1000);
  // 132 - 22 = 110 K above ambient: 0.17 mm below the stroke.
  EXPECT_NEAR(D_prev, kP.g - kMmPerK * (plant.temperature() - kP.T_amb), 1e-9);
  EXPECT_GT(kP.g - D_prev, 0.15);
}

TEST(ThermalExpansion, CoolingAboveMartensiteStartRaisesThePosition) {
  sma::Plant plant(kP, expansion());
  for (int k = 0; k < 4000; ++k) plant.step(2.0, 0.01);  // 40 s: fully transformed, hot
  ASSERT_EQ(plant.fraction(), 1.0);
  double D_prev = plant.measure_clean();
  int rising = 0;
  for (int k = 0; k < 3000; ++k) {
    plant.step(0.0, 0.01);  // heater off
    const double T_MSi = plant.hysteresis().loop().T_MSi;  // of the loop this cooling opened
    const double D = plant.measure_clean();
    if (plant.temperature() > T_MSi + 1.0) {
      ASSERT_GT(D, D_prev) << "the shortening wire must raise the position, T=" << plant.temperature();
      ++rising;
    }
    D_prev = D;
  }
  EXPECT_GT(rising, 100);
  // Back near ambient in martensite: the position returns to ~0.
  EXPECT_LT(plant.measure_clean(), 0.05);
}

TEST(ThermalExpansion, AmbientOffsetIsTheReference) {
  // The expansion counts from the true ambient (T_amb + ambient_offset): a wire at rest there
  // measures 0.
  sma::Effects fx = expansion();
  fx.ambient_offset_K = 5.0;
  sma::Plant plant(kP, fx);
  EXPECT_NEAR(plant.measure_clean(), 0.0, 1e-12);
  const sma::Mechanics<double> mech(kP, fx);
  EXPECT_NEAR(mech.displacement(1.0, kP.T_amb + 5.0 + 10.0), kP.g - 10.0 * kMmPerK, 1e-12);
  EXPECT_NEAR(mech.fraction(kP.g - 10.0 * kMmPerK, kP.T_amb + 15.0), 1.0, 1e-12);
}

TEST(ThermalExpansion, InverseRoundTripWithTheEffect) {
  // The reference path's desired temperature, walked through an independent forward model with
  // the same expansion, gives back the reference wherever it is on a branch.
  const sma::Effects fx = expansion();
  sma::InverseModel<double> inv(kP, fx);
  const sma::PhaseCurves<double> curves(kP);
  sma::Hysteresis<double> forward(curves, kP.T_amb);
  const double dt = 0.01;
  double T_prev = kP.T_amb, worst = 0.0, worst_plain = 0.0;
  int checked = 0;
  for (int k = 0; k < 9000; ++k) {
    const double t = k * dt;
    // Heat 0.05 -> 0.85 mm in 40 s, cool back to 0.10 mm in 40 s, hold.
    const double u = t < 40 ? 0.05 + 0.8 * t / 40 : (t < 80 ? 0.85 - 0.75 * (t - 40) / 40 : 0.10);
    inv.step(u);
    const double Td = inv.desired_temperature();
    const double eps = forward.update(Td);
    const bool heating_on_curve = Td > T_prev && Td > kP.T_AS + 0.5 && Td < kP.T_AF - 0.5;
    const bool cooling_on_branch = Td < T_prev && Td < forward.loop().T_MSi - 0.5 && Td > kP.T_MF + 0.5;
    if (heating_on_curve || cooling_on_branch) {
      const double D = kP.g * eps - kMmPerK * (Td - kP.T_amb);
      worst = fmax(worst, fabs(D - u));
      worst_plain = fmax(worst_plain, fabs(kP.g * eps - u));
      ++checked;
    }
    T_prev = Td;
  }
  EXPECT_GT(checked, 4000);
  // Three fixed-point steps: within 0.1 um, a twentieth of the rig's 2 um noise.
  EXPECT_LT(worst, 1e-4) << "forward(inverse(u)) with expansion";
  // Without the fixed-point steps the error would be the expansion itself (~0.07 mm at 70 degC):
  // the check has teeth.
  EXPECT_GT(worst_plain, 0.05);
}
