// Effects in the controller (issue 7): a model that knows the wire's fitted effects controls it
// better than the paper's model. Thermal effects enter eq 17 and the feedforward's model wire;
// sensor effects are compensated by the SensorPredictor (calibration inverted, Smith predictor
// for lag and delay). Each controller is tuned for its own best result (sma_host::tune_pid).
#include <gtest/gtest.h>
#include <algorithm>
#include "sma/fixed.hpp"
#include "sma/sensor.hpp"
#include "sma_host/tune.hpp"

namespace {
using sma_host::Condition;
using sma_host::RunSetup;

// Max |error| while heating, tuned, with the model blind to the effect and aware of it.
struct Pair {
  double blind, aware;
};
Pair compare(const sma::Effects& fx, bool sine) {
  RunSetup s;
  s.condition = Condition::rig_like();
  s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
  s.plant_effects = fx;
  const sma_host::TuneResult blind = sma_host::tune_pid(s);
  s.model_effects = fx;
  const sma_host::TuneResult aware = sma_host::tune_pid(s);
  EXPECT_TRUE(std::isfinite(aware.cost));
  EXPECT_TRUE(std::isfinite(blind.cost));
  return {blind.metrics.max_heat_mm, aware.metrics.max_heat_mm};
}
}  // namespace

TEST(EffectsInController, SensorCalibrationIsInvertedExactly) {
  // measured = 1.1 D - 0.03: a PID on the raw reading holds the wrong position.
  sma::Effects fx;
  fx.sensor_gain = 1.1;
  fx.sensor_offset_mm = -0.03;
  RunSetup s;
  s.reference.kind = sma::RefKind::Trajectory;  // a 30 s ramp to 0.5 mm: no step, no overshoot
  s.reference.add_point(0.0, 0.0);
  s.reference.add_point(30.0, 0.5);
  s.duration_s = 60;
  s.plant_effects = fx;
  s.config.gains.kp = 12.1;
  s.config.gains.ki = 3.13;
  const std::vector<sma_host::Sample> blind = sma_host::run_closed_loop<double>(s);
  // (blind: the PID holds the *measurement* at 0.5)
  s.model_effects = fx;
  const std::vector<sma_host::Sample> aware = sma_host::run_closed_loop<double>(s);
  // Blind: the measurement is held at 0.5, so the wire sits at (0.5 + 0.03) / 1.1.
  EXPECT_NEAR(blind.back().truth, (0.5 + 0.03) / 1.1, 0.003);
  EXPECT_NEAR(aware.back().truth, 0.5, 0.003);
}

TEST(EffectsInController, SmithPredictorRemovesMostOfASensorLag) {
  sma::Effects fx;
  fx.sensor_lag_s = 0.5;
  const Pair p = compare(fx, true);
  EXPECT_LE(p.aware, 0.8 * p.blind) << p.blind << " -> " << p.aware;
}

TEST(EffectsInController, SmithPredictorHelpsWithASensorDelay) {
  sma::Effects fx;
  fx.sensor_delay_s = 0.2;  // modelled as part of a first-order lag: less than for a lag
  const Pair p = compare(fx, true);
  EXPECT_LE(p.aware, 0.9 * p.blind) << p.blind << " -> " << p.aware;
}

TEST(EffectsInController, ConvectionInEq17LetsTheStepsSettle) {
  // More heat lost when hot: the paper's eq 17 misjudges every holding voltage, and no tuning
  // of the PID reaches zero steady-state error on the multi-step (it may not cool a wire on a
  // heating branch, nor heat one on a cooling branch). Knowing the effect, it does.
  sma::Effects conv;
  conv.convection_beta_per_K = 0.008;
  RunSetup s;
  s.condition = Condition::rig_like();
  s.reference = sma::Reference::multi_step();
  s.plant_effects = conv;
  const sma_host::TuneResult blind = sma_host::tune_pid(s);
  s.model_effects = conv;
  const sma_host::TuneResult aware = sma_host::tune_pid(s);
  EXPECT_FALSE(std::isfinite(blind.cost));
  ASSERT_TRUE(std::isfinite(aware.cost));
  EXPECT_LT(aware.metrics.sse_mm, 0.005);
  EXPECT_LT(aware.metrics.max_heat_mm, 0.005);
}

TEST(EffectsInController, PhaseDependentResistanceKnownTracksAsWellAsNoEffect) {
  // R(eps) = R (1 + k_R eps) in the plant and in the model: the controller must track the
  // multi-step as well as it does a wire without the effect (eq 17 and V_hold use R(eps)). Found
  // by the end-to-end flow: V_hold, the PID's lower bound while heating, used R(0), so at
  // k_R = -0.05 the wire was held hotter than asked and the overshoot locked in (0.654 mm max
  // error, against 0.088 mm with the model blind to the effect).
  auto run = [](double k) {
    sma::Effects fx;
    fx.resistance_k = k;
    RunSetup s;
    s.condition = Condition::rig_like();
    s.reference = sma::Reference::multi_step();
    s.plant_effects = fx;
    s.model_effects = fx;
    sma::PidGains g;  // the tuner's multi-step optimum (README): nearly feedforward alone
    g.kp = 0.03125;
    g.kd = 0.064;
    return sma_host::evaluate<double>(s, g);
  };
  const sma_host::Metrics none = run(0.0);
  for (double k : {-0.05, 0.05}) {
    const sma_host::Metrics m = run(k);
    // 3 ADC steps each (the sensor's 0.002 mm): the steady state of a PID without integral (the
    // tuner's ki = 0) is where the approach's overshoot locked in, and an effect known to the
    // model moves that approach by a step or two either way.
    EXPECT_LE(m.max_heat_mm, none.max_heat_mm + 0.006) << "k_R " << k;
    EXPECT_LE(m.sse_mm, none.sse_mm + 0.006) << "k_R " << k;
  }
}

TEST(EffectsInController, FixedPointComputesTheSameWithEffects) {
  // The effect-aware controller and the sensor predictor in Q16.16, fed the same inputs as in
  // double: the same voltages (bounds as in test_fixed_controller.cpp).
  sma::Effects fx;
  fx.convection_beta_per_K = 0.008;
  fx.resistance_k = 0.1;
  fx.latent_heat_J = 1.0;
  fx.sensor_lag_s = 0.3;
  RunSetup s;
  s.condition = Condition::rig_like();
  s.plant_effects = fx;
  s.model_effects = fx;
  s.config.gains.kp = 12.1;
  s.config.gains.ki = 3.13;
  const std::vector<sma_host::Sample> run = sma_host::run_closed_loop<double>(s);
  sma::Controller<double> cd(s.model_params, fx, s.config);
  sma::Controller<sma::Fixed> cf(s.model_params, fx, s.config);
  sma::SensorPredictor<double> sd(cd.inverse().curves(), s.model_params, fx, s.config.dt);
  sma::SensorPredictor<sma::Fixed> sf(cf.inverse().curves(), s.model_params, fx, s.config.dt);
  cd.set_mode(s.mode, run[0].meas);
  cf.set_mode(s.mode, sma::from_double<sma::Fixed>(run[0].meas));
  std::vector<double> dv;
  for (const sma_host::Sample& x : run) {
    const double a = cd.step(x.ref, sd.correct(x.meas, cd.wire_temperature()));
    const sma::Fixed m = sma::from_double<sma::Fixed>(x.meas);
    const double b = sma::to_double(cf.step(sma::from_double<sma::Fixed>(x.ref), sf.correct(m, cf.wire_temperature())));
    dv.push_back(fabs(a - b));
  }
  const size_t big = static_cast<size_t>(std::count_if(dv.begin(), dv.end(), [](double d) { return d > 0.1; }));
  std::sort(dv.begin(), dv.end());
  EXPECT_LT(dv[dv.size() * 99 / 100], 0.010);
  EXPECT_LE(big, 12u);
}

TEST(SensorPredictor, WithoutSensorDynamicsItOnlyInvertsTheCalibration) {
  const sma::Params p;
  sma::Effects fx;
  fx.sensor_gain = 2.0;
  fx.sensor_offset_mm = 0.1;
  const sma::PhaseCurves<double> curves(p);
  sma::SensorPredictor<double> sp(curves, p, fx, 0.01);
  EXPECT_FALSE(sp.dynamic());
  EXPECT_DOUBLE_EQ(sp.correct(0.9, 60.0), 0.4);
  // With a lag, at rest (model and sensor agree) the correction vanishes.
  fx = sma::Effects();
  fx.sensor_lag_s = 0.5;
  sma::SensorPredictor<double> lag(curves, p, fx, 0.01);
  double y = 0;
  for (int k = 0; k < 2000; ++k) y = lag.correct(0.3, 22.0);
  EXPECT_NEAR(y, 0.3, 1e-9);
}
