// The heat-loss observer (heat_gain.hpp) and its use by the preview controller: a model h that
// is off is learned as k = h_wire / h_model, a shift of the curves' temperatures is not.
#include <gtest/gtest.h>
#include "sma/heat_gain.hpp"
#include "sma/thermal.hpp"
#include "sma_host/metrics.hpp"

namespace {

// Eq 1 for a wire (params `wire`) and the model wire (params `model`, with the observer's
// k^ G loss, as the preview walks it) on the same voltage: heating ramps to three levels, each
// followed by free cooling. While both heat, the observer sees T_wire - T_model + shift (what
// the position on the heating curve says, shift = the model curves' temperature error).
double learned_gain(const sma::Params& wire, const sma::Params& model, double shift_K) {
  const double dt = 0.01, sample = 0.1;
  sma::HeatLossObserver<double> obs(model, dt, sample, 60.0, 1.0, 0.03);
  const sma::ThermalStep<double> wire_step(wire, dt), model_step(model, dt);
  const double T_a = model.T_amb;
  double Tw = T_a, Tm = T_a, last_w = Tw, last_m = Tm;
  int n = 0;
  for (double v_top : {1.0, 1.3, 1.6, 1.2, 1.5})
    for (double t = 0.0; t < 30.0; t += dt) {
      const double v = t < 10.0 ? v_top * t / 10.0 : (t < 15.0 ? v_top : 0.0);
      Tw = wire_step(Tw, v);
      Tm = model_step(Tm, v) - obs.loss_correction() * (Tm - T_a);
      obs.tick(Tm - T_a);
      if (++n % static_cast<int>(sample / dt) == 0) {
        if (Tw > last_w + 0.05 && Tm > last_m + 0.05) obs.add(Tw - Tm + shift_K, 0.04);
        last_w = Tw;
        last_m = Tm;
      }
    }
  return obs.gain();
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

// In closed loop (rig-like, float): with the model's h 10 % low, the observer brings the sine's
// whole-period RMS below 0.6x what the preview reaches without it; with the exact model it changes
// nothing.
TEST(PreviewHeatLoss, SineWithModelHLowTracksBetter) {
  sma_host::RunSetup s;
  s.mode = sma::Mode::Preview;
  s.reference = sma::Reference::sine();
  s.condition = sma_host::Condition::rig_like();
  auto rms = [&](double h_scale, bool observe) {
    sma_host::RunSetup r = s;
    r.model_params.h *= h_scale;
    if (!observe) r.preview.heat_gain_memory_s = 0.0;
    return sma_host::sine_metrics(sma_host::run_closed_loop<float>(r), s.reference.sine_period_s).rms_mm;
  };
  EXPECT_LT(rms(0.9, true), 0.6 * rms(0.9, false));
  EXPECT_EQ(rms(1.0, true), rms(1.0, false));
}

}  // namespace
