// Controller (eq 18): modes, limits, safe outputs on bad input.
#include <gtest/gtest.h>
#include <math.h>
#include "sma/controller.hpp"
#include "sma_host/plant.hpp"

namespace {
const sma::Params kP;
sma::ControllerConfig config() {
  sma::ControllerConfig c;
  c.gains.kp = 12.8;
  c.gains.ki = 4.0;
  c.gains.kd = 0.09;
  return c;
}
}  // namespace

TEST(Controller, OffAtStartAndOpenLoopIsClampedToVmax) {
  sma::Controller<double> ctl(kP, sma::Effects(), config());
  EXPECT_EQ(ctl.mode(), sma::Mode::Off);
  EXPECT_EQ(ctl.step(0.5, 0.0), 0.0);  // heater off until commanded
  ctl.set_mode(sma::Mode::OpenLoop, 0.0);
  ctl.set_voltage(1.3);
  EXPECT_EQ(ctl.step(0.5, 0.0), 1.3);
  ctl.set_voltage(7.0);
  EXPECT_EQ(ctl.step(0.5, 0.0), 2.0);  // eq 18
  ctl.set_voltage(-1.0);
  EXPECT_EQ(ctl.step(0.5, 0.0), 0.0);
  ctl.set_voltage(NAN);
  EXPECT_EQ(ctl.step(0.5, 0.0), 0.0);
}

TEST(Controller, EveryModeKeepsVInsideZeroToVmaxUnderGarbage) {
  sma::Noise rng(11);
  for (sma::Mode m : {sma::Mode::Pid, sma::Mode::Feedforward, sma::Mode::FeedforwardPid}) {
    sma::Controller<double> ctl(kP, sma::Effects(), config());
    ctl.set_mode(m, 0.0);
    for (int k = 0; k < 20000; ++k) {
      double ref = (rng.uniform() - 0.3) * 3.0, meas = (rng.uniform() - 0.3) * 3.0;
      if (k % 101 == 0) ref = NAN;
      if (k % 103 == 0) meas = NAN;
      if (k % 107 == 0) meas = -INFINITY;
      const double v = ctl.step(ref, meas);
      ASSERT_TRUE(std::isfinite(v)) << sma::mode_name(m);
      ASSERT_GE(v, 0.0);
      ASSERT_LE(v, 2.0);
      if (!std::isfinite(ref) || !std::isfinite(meas)) {
        ASSERT_EQ(v, 0.0);  // heater off
      }
    }
  }
}

TEST(Controller, OutOfRangeSetpointIsClampedToTheStroke) {
  // A setpoint past the stroke g is treated as g, below 0 as 0: defined and bounded output.
  sma::Controller<double> a(kP, sma::Effects(), config()), b(kP, sma::Effects(), config());
  a.set_mode(sma::Mode::FeedforwardPid, 0.0);
  b.set_mode(sma::Mode::FeedforwardPid, 0.0);
  for (int k = 0; k < 500; ++k) EXPECT_EQ(a.step(5.0, 0.3), b.step(kP.g, 0.3));
  sma::Controller<double> c(kP, sma::Effects(), config());
  c.set_mode(sma::Mode::Pid, 0.0);
  EXPECT_EQ(c.step(-3.0, 0.0), 0.0);
}

TEST(Controller, FeedforwardIsV1AndFeedforwardPidAddsV2) {
  sma::Controller<double> ff(kP, sma::Effects(), config());
  ff.set_mode(sma::Mode::Feedforward, 0.0);
  const double v = ff.step(0.3, 0.0);
  EXPECT_EQ(v, ff.v1());
  EXPECT_EQ(ff.v2(), 0.0);
  sma::Controller<double> both(kP, sma::Effects(), config());
  both.set_mode(sma::Mode::FeedforwardPid, 0.1);
  double vb = 0;
  for (int k = 0; k < 2000; ++k) vb = both.step(0.3, 0.29);  // settled, 10 um short
  EXPECT_LT(both.v1(), 2.0);
  EXPECT_NEAR(vb, sma::clamp(both.v1() + both.v2(), 0.0, 2.0), 1e-12);
  EXPECT_GT(both.v2(), 0.0);  // the PID adds heat to close the gap
}

TEST(Controller, BumplessSwitchFromOpenLoopToPid) {
  sma::Controller<double> ctl(kP, sma::Effects(), config());
  ctl.set_mode(sma::Mode::OpenLoop, 0.4);
  ctl.set_voltage(1.2);
  ctl.step(0.4, 0.4);
  ctl.set_mode(sma::Mode::Pid, 0.4);
  EXPECT_NEAR(ctl.step(0.4, 0.4), 1.2, 1e-9);  // zero error: the voltage carries over
}

TEST(Controller, WireTemperatureEstimateFollowsEq1) {
  sma::Controller<double> ctl(kP, sma::Effects(), config());
  ctl.set_mode(sma::Mode::OpenLoop, 0.0);
  ctl.set_voltage(1.0);
  for (int k = 0; k < 10000; ++k) ctl.step(0.0, 0.0);  // 100 s = 24 tau
  EXPECT_NEAR(ctl.wire_temperature(), 49.56, 0.01);
}

TEST(Controller, NonPhysicalParametersKeepTheHeaterOff) {
  sma::Params bad;
  bad.T_AF = bad.T_AS;  // would divide by zero in eqs 2 and 15
  sma::Controller<double> ctl(bad, sma::Effects(), config());
  EXPECT_FALSE(ctl.valid());
  ctl.set_mode(sma::Mode::FeedforwardPid, 0.0);
  EXPECT_EQ(ctl.mode(), sma::Mode::Off);
  for (int k = 0; k < 100; ++k) EXPECT_EQ(ctl.step(0.5, 0.1), 0.0);
  sma::ControllerConfig c = config();
  c.gains.kp = -1;
  EXPECT_FALSE(sma::Controller<double>(kP, sma::Effects(), c).valid());
  sma::Effects fx;
  fx.sensor_lag_s = NAN;
  EXPECT_FALSE(sma::Controller<double>(kP, fx, config()).valid());
  EXPECT_TRUE(sma::Controller<double>(kP, sma::Effects(), config()).valid());
}
