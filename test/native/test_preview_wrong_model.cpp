// The preview controller (preview.hpp) with a model on the board that is far from the wire: issue
// 13's "zero steady-state error kept, also when the model on the board is a fitted one and not the
// plant". Rig-like, float, default settings, the multi-step; the steady-state error of every hold
// (metrics.hpp's sse_mm: the best 2 s mean in each step's second half, the worst step) within
// 10 um = 5 ADC steps.
//
// OPEN (docs/control.md section 16): both cases fail on today's code, so the test is disabled;
// run it with --gtest_also_run_disabled_tests. Today: the e2e wire holds 0.2 mm at 0.363 mm (SSE
// 0.16 mm), the latent-heat wire drifts 0.09 mm below the 0.5 mm hold. Both are the offset
// estimate (the integral action) taking a transient gap between the wire and the model wire for a
// steady one and driving the model wire past the setpoint on a branch that cannot come back.
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

// The end-to-end flow's wire (tools/vrig/e2e_flow.py WIRE: transformation 4 K higher, h 190,
// 5 % more stroke, a heat loss that grows faster than linearly, beta 0.006 /K) with the model
// `sma fit` leaves without that effect (docs/flow.md: h 219, T_AS 55.8, T_AF 88.8, g 0.997; its
// steady states match the wire's, its heating transient is slower than the wire's).
TEST(PreviewWrongModel, DISABLED_FittedModelWithoutTheWiresConvectionHoldsEveryStep) {
  sma_host::RunSetup s = steps_rig_like();
  s.plant_params.T_AS = 54.0;
  s.plant_params.T_AF = 84.0;
  s.plant_params.h = 190.0;
  s.plant_params.g = 1.05;
  s.plant_effects.convection_beta_per_K = 0.006;
  s.model_params.T_AS = 55.8;
  s.model_params.T_AF = 88.8;
  s.model_params.h = 219.0;
  s.model_params.g = 0.997;
  EXPECT_LE(steady_error(s), 0.01);
}

// A wire with 1 J of latent heat and a model without it: the wire cools more slowly than the
// model wire through the transformation (eq 1 with the latent heat), so after a down-step it lags.
TEST(PreviewWrongModel, DISABLED_ModelWithoutTheLatentHeatHoldsEveryStep) {
  sma_host::RunSetup s = steps_rig_like();
  s.plant_effects.latent_heat_J = 1.0;
  EXPECT_LE(steady_error(s), 0.01);
}

}  // namespace
