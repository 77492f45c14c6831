// The preview controller (preview.hpp) with a model on the board that is far from the wire: issue
// 13's "zero steady-state error kept, also when the model on the board is a fitted one and not the
// plant". Rig-like, float, default settings, the multi-step; the steady-state error of every hold
// (metrics.hpp's sse_mm: the best 2 s mean in each step's second half, the worst step) within
// 10 um = 5 ADC steps.
//
// Open (docs/control.md section 16; measured by bench_tracking_model_error's rows "e2e wire,
// fitted without its convection" and "latent heat 1 J, model 0.0 J", not asserted here): the e2e
// wire with its fit alone holds 0.2 mm at 0.363 mm (SSE 0.16 mm); the latent-heat wire's 0.5 mm
// hold is 0.012 mm low. Both start with the offset estimate (the integral action) taking a
// transient gap between the wire and the model wire for a steady one and driving the model wire
// past the setpoint on a branch that cannot come back.
#include <gtest/gtest.h>
#include <vector>
#include "sma_host/metrics.hpp"

namespace {

sma_host::RunSetup steps_rig_like() {
  sma_host::RunSetup s;
  s.mode = sma::Mode::Preview;
  s.reference = sma::Reference::multi_step();
  s.condition = sma_host::Condition::rig_like();
  return s;
}

double steady_error(const sma_host::RunSetup& s) {
  return sma_host::step_metrics(sma_host::run_closed_loop<float>(s), s.reference.step_s).sse_mm;
}

// The lag guard (PreviewConfig::lag_guard_mm): after the 0.8 -> 0.5 mm step the wire, slowed by
// its unmodelled latent heat, lags the model wire by up to 0.14 mm; an offset estimate that takes
// the lag drives the model wire that far below the hold, and the wire follows onto its cooling
// curve, where the cooling branch cannot raise it. Guarded, the hold stays within 1.5 x the
// issue's 10 um (the rest is open, see the top); without the guard it is 0.09 mm low.
TEST(PreviewWrongModel, ALagIsNotTakenForAnOffset) {
  sma_host::RunSetup s = steps_rig_like();
  s.plant_effects.latent_heat_J = 1.0;
  EXPECT_LE(steady_error(s), 0.015);
  s.preview.lag_guard_mm = 0.0;
  EXPECT_GT(steady_error(s), 0.05);
}

// The model's heating curve 2 K off either way (T_AS and T_AF; the cooling side as the wire's):
// the offset, moved into a shift of the heating curve at rest on it
// (PreviewConfig::curve_shift_tau_s), holds every step as closely as the exact model does (SSE
// < 5 um, Preview.ZeroSteadyStateErrorExactModel's bound). As a position offset alone it must
// change along the path of every move (0.097 mm at 0.8 mm, 0.055 at 0.5 mm) and misses by ~10 um.
TEST(PreviewWrongModel, AHeatingCurveOffByTwoKelvinIsHeldLikeTheExactModel) {
  for (double dT : {2.0, -2.0}) {
    sma_host::RunSetup s = steps_rig_like();
    s.model_params.T_AS += dT;
    s.model_params.T_AF += dT;
    EXPECT_LT(steady_error(s), 0.005) << dT;
    if (dT > 0) {
      s.preview.curve_shift_tau_s = 0.0;
      EXPECT_GT(steady_error(s), 0.005) << dT;
    }
  }
}

}  // namespace
