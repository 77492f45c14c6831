// The heat-loss observer (heat_gain.hpp) and its use by the preview controller: a model h that
// is off is learned as k = h_wire / h_model, a shift of the curves' temperatures is not.
#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <vector>
#include "sma/fixed.hpp"
#include "sma/heat_gain.hpp"
#include "sma/thermal.hpp"
#include "sma_host/metrics.hpp"

namespace {

// Eq 1 for a wire (params `wire`) and the model wire (params `model`, with the observer's
// k^ G loss, as the preview walks it) on the same voltage: heating ramps to three levels, each
// followed by free cooling. While both heat, the observer sees T_wire - T_model + shift (what
// the position on the heating curve says, shift = the model curves' temperature error) at a
// curve slope `slope` (mm/K), or at slopes cycling through 10..50 um/K (the preview's range)
// when it is 0. The model wire and the observer in scalar T; the gain after each sample.
template <class T>
std::vector<double> gain_path(const sma::Params& wire, const sma::Params& model, double shift_K,
                              double slope = 0.04) {
  const double dt = 0.01, sample = 0.1;
  sma::HeatLossObserver<T> obs(model, dt, sample, 60.0, 1.0, 0.03);
  const sma::ThermalStep<double> wire_step(wire, dt);
  const sma::ThermalStep<T> model_step(model, dt);
  const T T_a = sma::from_double<T>(model.T_amb);
  double Tw = model.T_amb, last_w = Tw;
  T Tm = T_a, last_m = Tm;
  std::vector<double> path;
  int n = 0;
  for (double v_top : {1.0, 1.3, 1.6, 1.2, 1.5})
    for (double t = 0.0; t < 30.0; t += dt) {
      const double v = t < 10.0 ? v_top * t / 10.0 : (t < 15.0 ? v_top : 0.0);
      Tw = wire_step(Tw, v);
      Tm = model_step(Tm, sma::from_double<T>(v)) - obs.loss_correction() * (Tm - T_a);
      obs.tick(Tm - T_a);
      if (++n % static_cast<int>(sample / dt) == 0) {
        const double s = slope > 0.0 ? slope : 0.01 * (1 + (n / 10) % 5);
        if (Tw > last_w + 0.05 && Tm > last_m + sma::from_double<T>(0.05)) {
          obs.add(sma::from_double<T>(Tw - sma::to_double(Tm) + shift_K), sma::from_double<T>(s));
          path.push_back(sma::to_double(obs.gain()));
        }
        last_w = Tw;
        last_m = Tm;
      }
    }
  return path;
}

double learned_gain(const sma::Params& wire, const sma::Params& model, double shift_K) {
  return gain_path<double>(wire, model, shift_K).back();
}

TEST(PreviewHeatLoss, LearnsTheWiresHeatLossGain) {
  const sma::Params wire;
  for (double scale : {0.9, 1.1}) {
    sma::Params model = wire;
    model.h *= scale;
    const double k = learned_gain(wire, model, 0.0);
    EXPECT_NEAR(k, 1.0 / scale, 0.02 / scale) << "model h x" << scale;
  }
}

// A shift of the curves adds a constant to the gap: the gain stays the model's (within the
// dead zone it is exactly 1).
TEST(PreviewHeatLoss, CurveShiftIsNotAHeatLossError) {
  const sma::Params wire;
  for (double shift : {-2.0, 2.0}) EXPECT_EQ(learned_gain(wire, wire, shift), 1.0) << "shift " << shift;
}

// One temperature cannot separate a heat-loss error from a shift: no estimate from a single
// level (the ramps all reach the same temperature).
TEST(PreviewHeatLoss, NoEstimateWithoutATemperatureSpread) {
  sma::HeatLossObserver<double> obs(sma::Params(), 0.01, 0.1, 60.0, 1.0, 0.03);
  for (int i = 0; i < 1000; ++i) {
    obs.tick(40.0);
    obs.add(4.0, 0.04);
  }
  EXPECT_EQ(obs.gain(), 1.0);
}

// Q16.16 (the Uno's scalar: LSB 1.5e-5, the regression's raw means move by ~1e-6 a sample)
// learns the same gain as double, sample for sample, from slopes across the preview's range:
// h_wire / h_model within 2 % at the end, and within 0.005 of double's gain at every sample
// (the model wire's own Q16.16 rounding included; the dead zone is 0.03).
TEST(PreviewHeatLoss, FixedLearnsTheGainAsDouble) {
  const sma::Params wire;
  for (double scale : {0.9, 1.1}) {
    sma::Params model = wire;
    model.h *= scale;
    const std::vector<double> d = gain_path<double>(wire, model, 0.0, 0.0);
    const std::vector<double> x = gain_path<sma::Fixed>(wire, model, 0.0, 0.0);
    ASSERT_GT(x.size(), 100u) << "model h x" << scale;
    EXPECT_NEAR(x.back(), 1.0 / scale, 0.02 / scale) << "model h x" << scale;
    double worst = 0.0;
    for (size_t i = 0; i < d.size() && i < x.size(); ++i) worst = std::max(worst, std::fabs(x[i] - d[i]));
    EXPECT_LE(worst, 0.005) << "model h x" << scale;
  }
}

sma_host::RunSetup closed_loop(bool sine, double h_scale, bool observe) {
  sma_host::RunSetup s;
  s.mode = sma::Mode::Preview;
  s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
  s.condition = sma_host::Condition::rig_like();
  s.model_params.h *= h_scale;
  if (!observe) s.preview.heat_gain_memory_s = 0.0;
  return s;
}

// In closed loop (rig-like), the model's h 10 % off either way: every step of the multi-step is
// held (SSE <= 0.01 mm) and none overshoots by more than 0.03 mm within 10 s; the sine's
// whole-period max stays <= 0.12 mm. In float and in Q16.16 (without the observer: float SSE
// 0.11 mm, overshoot 0.18 mm, sine 0.24 mm; Q16.16 SSE 0.035 mm, overshoot 0.18 mm, sine 0.23 mm).
template <class T>
void holds_the_setpoints_with_h_off(const char* scalar) {
  for (double h_scale : {0.9, 1.1}) {
    const sma_host::RunSetup st = closed_loop(false, h_scale, true);
    const std::vector<sma_host::Sample> r = sma_host::run_closed_loop<T>(st);
    EXPECT_LE(sma_host::step_metrics(r, st.reference.step_s).sse_mm, 0.01) << scalar << ", model h x" << h_scale;
    EXPECT_LE(sma_host::step_overshoot_mm(r, st.reference.step_s, 10.0), 0.03) << scalar << ", model h x" << h_scale;
    const sma_host::RunSetup ss = closed_loop(true, h_scale, true);
    EXPECT_LE(sma_host::sine_metrics(sma_host::run_closed_loop<T>(ss), ss.reference.sine_period_s).max_mm, 0.12)
        << scalar << ", model h x" << h_scale;
  }
}

TEST(PreviewHeatLoss, ModelHOffTenPercentHoldsTheSetpoints) { holds_the_setpoints_with_h_off<float>("float"); }
TEST(PreviewHeatLoss, FixedModelHOffTenPercentHoldsTheSetpoints) {
  holds_the_setpoints_with_h_off<sma::Fixed>("Q16.16");
}

// The preview's gain in closed loop (rig-like multi-step, model h 10 % off either way), once a
// second: Q16.16 learns what double learns. From 30 s on (the first steps' samples fall on other
// ticks in the two scalars) within 0.005 of double's gain, and 1 / 0.9 or 1 / 1.1 within 3 %.
template <class T>
std::vector<double> closed_loop_gain(double h_scale) {
  const sma_host::RunSetup s = closed_loop(false, h_scale, true);
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  std::vector<double> gain;
  int tick = 0;
  sma_host::run_preview_loop_on<T>(plant, s, [&](const sma::PreviewController<T>& c) {
    if (++tick % 100 == 0) gain.push_back(sma::to_double(c.heat_loss_gain()));
  });
  return gain;
}

TEST(PreviewHeatLoss, FixedGainInClosedLoopFollowsDouble) {
  for (double h_scale : {0.9, 1.1}) {
    const std::vector<double> d = closed_loop_gain<double>(h_scale), x = closed_loop_gain<sma::Fixed>(h_scale);
    ASSERT_EQ(d.size(), x.size());
    ASSERT_GT(x.size(), 100u);
    EXPECT_NEAR(x.back(), 1.0 / h_scale, 0.03 / h_scale) << "model h x" << h_scale;
    double worst = 0.0;
    for (size_t i = 30; i < d.size(); ++i) worst = std::max(worst, std::fabs(x[i] - d[i]));
    EXPECT_LE(worst, 0.005) << "model h x" << h_scale;
  }
}

// With the exact model the observer changes nothing (its estimate stays in the dead zone), in
// float and in Q16.16.
template <class T>
void exact_model_as_without_the_observer() {
  for (bool sine : {false, true}) {
    const std::vector<sma_host::Sample> on = sma_host::run_closed_loop<T>(closed_loop(sine, 1.0, true));
    const std::vector<sma_host::Sample> off = sma_host::run_closed_loop<T>(closed_loop(sine, 1.0, false));
    ASSERT_EQ(on.size(), off.size());
    for (size_t i = 0; i < on.size(); ++i) ASSERT_EQ(on[i].truth, off[i].truth) << "t " << on[i].t;
  }
}

TEST(PreviewHeatLoss, ExactModelTracksAsWithoutTheObserver) { exact_model_as_without_the_observer<float>(); }
TEST(PreviewHeatLoss, FixedExactModelTracksAsWithoutTheObserver) {
  exact_model_as_without_the_observer<sma::Fixed>();
}

}  // namespace
