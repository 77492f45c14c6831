// The heater's fault latch (sma/safety.hpp), alone and around the controller.
#include <gtest/gtest.h>

#include <math.h>

#include <algorithm>

#include "sma/console.hpp"
#include "sma/controller.hpp"
#include "sma/safety.hpp"

using sma::Fault;
using sma::Safety;
using sma::SafetyConfig;
using sma::SafetyInput;

namespace {
SafetyInput good(double v = 1.0) {
  SafetyInput in;
  in.sensor_v = 2.5;
  in.samples_in_range = true;
  in.measured_mm = 0.5;
  in.wire_temp_C = 60.0;
  in.command_v = v;
  in.heating = true;
  return in;
}
}  // namespace

TEST(Safety, PassesTheCommandWhenAllIsWell) {
  Safety s;
  s.boot(false);
  EXPECT_DOUBLE_EQ(s.gate(good(1.5)), 1.5);
  EXPECT_DOUBLE_EQ(s.gate(good(0.0)), 0.0);
  EXPECT_DOUBLE_EQ(s.gate(good(-0.3)), 0.0);  // never negative
  EXPECT_FALSE(s.tripped());
  EXPECT_EQ(s.fault(), Fault::None);
  EXPECT_EQ(s.trips(), 0);
}

TEST(Safety, WatchdogResetAtBootLatches) {
  Safety s;
  s.boot(true);
  EXPECT_TRUE(s.tripped());
  EXPECT_EQ(s.fault(), Fault::Watchdog);
  EXPECT_DOUBLE_EQ(s.gate(good(1.0)), 0.0);
  s.clear();
  EXPECT_DOUBLE_EQ(s.gate(good(1.0)), 1.0);
}

TEST(Safety, SensorOutOfRangeTripsAndLatches) {
  for (double v : {0.0, 0.099, 4.901, 5.0, -1.0}) {
    Safety s;
    s.boot(false);
    SafetyInput in = good();
    in.sensor_v = v;
    EXPECT_DOUBLE_EQ(s.gate(in), 0.0) << v;
    EXPECT_EQ(s.fault(), Fault::Sensor) << v;
    // The condition goes away: the latch stays.
    EXPECT_DOUBLE_EQ(s.gate(good()), 0.0);
    EXPECT_EQ(s.fault(), Fault::Sensor);
  }
  // Range ends are valid.
  Safety s;
  SafetyInput in = good();
  in.sensor_v = 0.1;
  EXPECT_DOUBLE_EQ(s.gate(in), 1.0);
  in.sensor_v = 4.9;
  EXPECT_DOUBLE_EQ(s.gate(in), 1.0);
}

TEST(Safety, OneBadSampleInTheWindowTrips) {
  Safety s;
  SafetyInput in = good();
  in.samples_in_range = false;  // the average looks fine, one conversion did not
  EXPECT_DOUBLE_EQ(s.gate(in), 0.0);
  EXPECT_EQ(s.fault(), Fault::Sensor);
}

TEST(Safety, NonFiniteInputsTrip) {
  for (int which = 0; which < 4; ++which) {
    for (double bad : {static_cast<double>(NAN), static_cast<double>(INFINITY), -static_cast<double>(INFINITY)}) {
      Safety s;
      SafetyInput in = good();
      if (which == 0) in.sensor_v = bad;
      if (which == 1) in.measured_mm = bad;
      if (which == 2) in.wire_temp_C = bad;
      if (which == 3) in.command_v = bad;
      EXPECT_DOUBLE_EQ(s.gate(in), 0.0);
      EXPECT_EQ(s.fault(), Fault::NotFinite) << which;
    }
  }
}

TEST(Safety, OverTemperature) {
  Safety s;
  SafetyInput in = good();
  in.wire_temp_C = 110.0;  // at the limit: fine
  EXPECT_DOUBLE_EQ(s.gate(in), 1.0);
  in.wire_temp_C = 110.01;
  EXPECT_DOUBLE_EQ(s.gate(in), 0.0);
  EXPECT_EQ(s.fault(), Fault::OverTemp);
  // A configurable limit.
  Safety t;
  EXPECT_TRUE(t.set_limit(80.0));
  in.wire_temp_C = 85.0;
  EXPECT_DOUBLE_EQ(t.gate(in), 0.0);
  EXPECT_EQ(t.fault(), Fault::OverTemp);
  // Out-of-range limits are refused and change nothing.
  Safety u;
  EXPECT_FALSE(u.set_limit(29.0));
  EXPECT_FALSE(u.set_limit(151.0));
  EXPECT_FALSE(u.set_limit(NAN));
  EXPECT_DOUBLE_EQ(u.t_limit_C(), 110.0);
}

TEST(Safety, FirstFaultIsKept) {
  Safety s;
  SafetyInput in = good();
  in.wire_temp_C = 200.0;
  s.gate(in);
  in.sensor_v = 6.0;
  s.gate(in);
  EXPECT_EQ(s.fault(), Fault::OverTemp);
  EXPECT_EQ(s.trips(), 2);
  EXPECT_EQ(s.classify(in), Fault::Sensor);
}

TEST(Safety, ClearUnlatchesButAPersistingConditionTripsAgain) {
  Safety s;
  SafetyInput in = good();
  in.sensor_v = 5.0;
  s.gate(in);
  s.clear();
  EXPECT_FALSE(s.tripped());
  EXPECT_DOUBLE_EQ(s.gate(in), 0.0);
  EXPECT_TRUE(s.tripped());
  s.clear();
  EXPECT_DOUBLE_EQ(s.gate(good(0.7)), 0.7);
}

TEST(Safety, LinkLossIsOffByDefault) {
  Safety s;
  for (int k = 0; k < 100000; ++k) EXPECT_DOUBLE_EQ(s.gate(good()), 1.0);
  EXPECT_FALSE(s.tripped());
  EXPECT_EQ(s.ticks_since_rx(), 100000u);
}

TEST(Safety, LinkLossWhenConfigured) {
  SafetyConfig c;
  c.link_timeout_s = 1.0;  // 100 ticks
  ASSERT_EQ(c.check(), nullptr);
  Safety s(c);
  s.boot(false);
  for (int k = 0; k < 100; ++k) ASSERT_DOUBLE_EQ(s.gate(good()), 1.0) << k;
  EXPECT_DOUBLE_EQ(s.gate(good()), 0.0);  // tick 101 without a byte
  EXPECT_EQ(s.fault(), Fault::LinkLoss);
  // A byte every 0.5 s keeps it alive.
  Safety t(c);
  for (int k = 0; k < 1000; ++k) {
    if (k % 50 == 0) t.on_rx();
    ASSERT_DOUBLE_EQ(t.gate(good()), 1.0) << k;
  }
  // Not heating: no link fault (nothing to stop).
  Safety u(c);
  SafetyInput idle = good(0.0);
  idle.heating = false;
  for (int k = 0; k < 1000; ++k) u.gate(idle);
  EXPECT_FALSE(u.tripped());
}

TEST(Safety, ConfigCheck) {
  SafetyConfig c;
  EXPECT_EQ(c.check(), nullptr);
  c.t_limit_C = 200;
  EXPECT_NE(c.check(), nullptr);
  c = SafetyConfig();
  c.sensor_v_min = 3;
  c.sensor_v_max = 2;
  EXPECT_NE(c.check(), nullptr);
  c = SafetyConfig();
  c.link_timeout_s = -1;
  EXPECT_NE(c.check(), nullptr);
  c = SafetyConfig();
  c.dt = 0;
  EXPECT_NE(c.check(), nullptr);
}

TEST(Safety, FaultNames) {
  EXPECT_STREQ(sma::fault_name(Fault::None), "none");
  EXPECT_STREQ(sma::fault_name(Fault::Sensor), "sensor");
  EXPECT_STREQ(sma::fault_name(Fault::NotFinite), "nan");
  EXPECT_STREQ(sma::fault_name(Fault::OverTemp), "overtemp");
  EXPECT_STREQ(sma::fault_name(Fault::LinkLoss), "link");
  EXPECT_STREQ(sma::fault_name(Fault::Watchdog), "watchdog");
}

// The firmware's loop in miniature: console state -> controller -> latch. Open loop at the
// maximum 2 V heats the wire towards 132 degC (model.md); the latch must stop it at 110 degC
// and keep it off, and the console must refuse to heat until `stop`.
TEST(SafetyWithController, OverTemperatureStopsOpenLoopHeating) {
  namespace con = sma::console;
  sma::ControllerConfig cfg;
  cfg.gains = con::default_gains(sma::Mode::FeedforwardPid);
  sma::Controller<float> ctl(sma::Params(), sma::Effects(), cfg);
  Safety safety;
  safety.boot(false);
  con::State st;
  con::Reply r;
  ASSERT_EQ(st.active_mode(), sma::Mode::Off);  // heater off at boot
  ASSERT_TRUE(con::execute("volt 2", st, safety.fault(), r));
  ctl.set_mode(st.active_mode(), 0.0f);
  ctl.set_voltage(static_cast<float>(st.volt));
  double trip_t = -1, max_T = 0;
  for (int k = 0; k < 6000; ++k) {  // 60 s
    const float v = ctl.step(0.0f, 0.3f);
    SafetyInput in = good(v);
    in.wire_temp_C = ctl.wire_temperature();
    in.heating = st.heat;
    const double out = safety.gate(in);
    max_T = std::max(max_T, static_cast<double>(ctl.wire_temperature()));
    if (safety.tripped() && st.heat) {
      st.heat = false;
      ctl.set_mode(sma::Mode::Off, 0.3f);
      trip_t = k * 0.01;
    }
    if (trip_t >= 0) {
      ASSERT_DOUBLE_EQ(out, 0.0);
    }
  }
  EXPECT_EQ(safety.fault(), Fault::OverTemp);
  EXPECT_GT(trip_t, 1.0);
  EXPECT_LT(trip_t, 15.0);
  EXPECT_LT(max_T, 110.5);  // one tick past the limit at most
  EXPECT_FALSE(con::execute("volt 1", st, safety.fault(), r));
  EXPECT_STREQ(r.text, "ERR fault overtemp: send stop");
  ASSERT_TRUE(con::execute("stop", st, safety.fault(), r));
  safety.clear();
  EXPECT_TRUE(con::execute("volt 1", st, safety.fault(), r));
}
