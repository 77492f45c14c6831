// PID: derivative on measurement, filtered derivative, anti-windup, limits, bumpless changes.
#include <gtest/gtest.h>
#include <math.h>
#include "sma/pid.hpp"

namespace {
sma::PidGains gains(double kp, double ki, double kd) {
  sma::PidGains g;
  g.kp = kp;
  g.ki = ki;
  g.kd = kd;
  g.i_zone_mm = 0.0;  // always integrate unless a test says otherwise
  return g;
}
}  // namespace

TEST(Pid, ProportionalAndIntegralActions) {
  sma::Pid<double> pid(gains(2.0, 10.0, 0.0), 0.01);
  pid.start(0.0, 0.0, 0.0);
  EXPECT_NEAR(pid.step(0.1, 0.0, -10, 10), 2.0 * 0.1 + 10.0 * 0.01 * 0.1, 1e-12);
  // A constant error integrates linearly.
  double out = 0;
  for (int k = 0; k < 99; ++k) out = pid.step(0.1, 0.0, -10, 10);
  EXPECT_NEAR(out, 0.2 + 10.0 * 0.1 * 1.0, 1e-9);
}

TEST(Pid, SetpointStepGivesNoDerivativeKick) {
  sma::Pid<double> pid(gains(0.0, 0.0, 1.0), 0.01);
  pid.start(0.3, 0.0, 0.0);
  // The error jumps (setpoint step) but the measurement does not move: no derivative.
  EXPECT_EQ(pid.step(0.5, 0.3, -10, 10), 0.0);
  // The measurement moves: derivative on measurement, opposing the motion, filtered.
  const double out = pid.step(0.5, 0.31, -10, 10);
  EXPECT_LT(out, 0.0);
  EXPECT_GT(out, -1.0 * 0.01 / 0.01);  // the low-pass takes a fraction of the raw kick
}

TEST(Pid, OutputRespectsLimits) {
  sma::Pid<double> pid(gains(100.0, 100.0, 0.0), 0.01);
  pid.start(0.0, 0.0, 0.0);
  for (int k = 0; k < 100; ++k) {
    const double out = pid.step(1.0, 0.0, -0.5, 1.5);
    ASSERT_LE(out, 1.5);
    ASSERT_GE(out, -0.5);
  }
}

TEST(Pid, AntiWindupRecoversAtOnceAfterSaturation) {
  // 10 s of saturation with a large error; then the error reverses. Without anti-windup the
  // integrator would hold ki * 10 s * error and keep the output saturated for seconds.
  sma::Pid<double> pid(gains(1.0, 5.0, 0.0), 0.01);
  pid.start(0.0, 0.0, 0.0);
  for (int k = 0; k < 1000; ++k) pid.step(1.0, 0.0, 0.0, 2.0);
  EXPECT_LE(pid.integral(), 2.0);
  int ticks_saturated = 0;
  while (pid.step(-0.2, 1.2, 0.0, 2.0) >= 2.0 && ticks_saturated < 1000) ++ticks_saturated;
  EXPECT_LT(ticks_saturated, 50);  // leaves saturation within 0.5 s
}

TEST(Pid, IntegralZoneStopsIntegrationFarFromSetpoint) {
  sma::PidGains g = gains(0.0, 10.0, 0.0);
  g.i_zone_mm = 0.05;
  sma::Pid<double> pid(g, 0.01);
  pid.start(0.0, 0.0, 0.0);
  for (int k = 0; k < 100; ++k) pid.step(0.2, 0.0, -5, 5);
  EXPECT_EQ(pid.integral(), 0.0);
  for (int k = 0; k < 100; ++k) pid.step(0.02, 0.0, -5, 5);
  EXPECT_NEAR(pid.integral(), 10.0 * 0.01 * 0.02 * 100, 1e-9);
}

TEST(Pid, BumplessStartAndGainChange) {
  sma::Pid<double> pid(gains(3.0, 1.0, 0.0), 0.01);
  // Start while the loop was delivering 0.8 V with an error of 0.05: the first output is 0.8.
  pid.start(0.45, 0.05, 0.8);
  EXPECT_NEAR(pid.step(0.05, 0.45, -5, 5), 0.8 + 1.0 * 0.01 * 0.05, 1e-12);
  // A new kp does not make the output jump.
  const double before = pid.step(0.05, 0.45, -5, 5);
  pid.set_gains(gains(6.0, 1.0, 0.0), 0.01);
  const double after = pid.step(0.05, 0.45, -5, 5);
  EXPECT_NEAR(after - before, 1.0 * 0.01 * 0.05, 1e-12);  // only the integral's own step
}

TEST(Pid, NaNGivesASafeOutput) {
  sma::Pid<double> pid(gains(1.0, 1.0, 1.0), 0.01);
  pid.start(0.0, 0.0, 0.5);
  EXPECT_EQ(pid.step(NAN, 0.0, 0.0, 2.0), 0.0);
  EXPECT_EQ(pid.step(0.1, NAN, 0.0, 2.0), 0.0);
  EXPECT_TRUE(std::isfinite(pid.integral()));
}

TEST(Pid, GainsAreValidated) {
  EXPECT_EQ(gains(1, 1, 1).check(), nullptr);
  EXPECT_NE(gains(-1, 1, 1).check(), nullptr);
  EXPECT_NE(gains(1, NAN, 1).check(), nullptr);
  EXPECT_NE(gains(1, 1, 1e6).check(), nullptr);
}
