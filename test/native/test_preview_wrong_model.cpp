// The preview controller (preview.hpp) with a model on the board that is far from the wire: issue
// 13's "zero steady-state error kept, also when the model on the board is a fitted one and not the
// plant". Rig-like, float, default settings, the multi-step; the steady-state error of every hold
// (metrics.hpp's sse_mm: the best 2 s mean in each step's second half, the worst step) within
// 10 um = 5 ADC steps.
//
#include <gtest/gtest.h>
#include <cmath>
#include <initializer_list>
#include <vector>
#include "sma_host/e2e_wire.hpp"
#include "sma_host/metrics.hpp"

namespace {

sma_host::RunSetup steps_rig_like() {
  sma_host::RunSetup s;
  s.mode = sma::Mode::Preview;
  s.reference = sma::Reference::multi_step();
  s.condition = sma_host::Condition::rig_like();
  return s;
}

// The multi-step on the end-to-end flow's wire (sma_host::e2e_wire) with a model of it.
sma_host::RunSetup e2e_steps(const sma::Params& model, const sma::Effects& model_fx) {
  sma_host::RunSetup s = steps_rig_like();
  s.plant_params = sma_host::e2e_wire();
  s.plant_effects = sma_host::e2e_wire_effects();
  s.model_params = model;
  s.model_effects = model_fx;
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

// The latent-heat wire (1 J) with a model without latent heat: its h is the model's, so the
// heat-loss observer must keep k = 1 (within its dead zone, 3 %). The unmodelled latent heat
// (eq 1's L deps/dt) slows the wire's transformation, and the gap it opens while both wires rise
// on the heating curve grows with the transformation the way a larger heat loss's does; the
// observer's second regressor, the latent heat's sensitivity dT/dL
// (PreviewConfig::heat_gain_latent_spread), takes it. Given to k instead (1.06-1.07 in the first
// heating), a gain the wire does not have moves the model wire ~2 K off the wire's temperature in
// the hold, and when it is unlearned on the next step the re-anchoring drives the model wire past
// the 0.4 mm hold on the heating branch, which cannot come back: every hold within the issue's
// 10 um only with the second regressor.
TEST(PreviewWrongModel, AnUnmodelledLatentHeatIsNotReadAsAHeatLoss) {
  for (double spread : {0.07, 0.0}) {
    sma_host::RunSetup s = steps_rig_like();
    s.plant_effects.latent_heat_J = 1.0;
    s.preview.heat_gain_latent_spread = spread;
    sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
    double k_off = 0.0;
    const std::vector<sma_host::Sample> r = sma_host::run_preview_loop_on<float>(
        plant, s, [&](const sma::PreviewController<float>& c) { k_off = fmax(k_off, fabs(c.heat_loss_gain() - 1.0)); });
    const double sse = sma_host::step_metrics(r, s.reference.step_s).sse_mm;
    if (spread > 0.0) {
      EXPECT_LT(k_off, s.preview.heat_gain_dead_zone);
      EXPECT_LE(sse, 0.010);
    } else {
      EXPECT_GT(k_off, s.preview.heat_gain_dead_zone);
      EXPECT_GT(sse, 0.010);
    }
  }
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

// The end-to-end flow's wire (sma_host::e2e_wire: a heat loss that grows faster than linearly
// with the temperature rise, its transformation ~2 K below the fit's) with the model `sma fit`
// leaves without that effect: after the flow's step 5 the fitted model is the board's only model,
// and issue 13 asks for every hold within 10 um with it. The wire heats faster than the fitted
// model wire: on the first step it passes 0.2 mm, and the voltage that holds the model wire there
// holds the wire 1.3-2 K below its peak, so it rides its minor-loop rise (eqs 5-6) to ~0.36 mm,
// which the heating branch cannot take back. The re-approach (PreviewConfig::reapproach_mm) cools
// it down its loop to the hold; without it the hold is missed by ~0.16 mm.
TEST(PreviewWrongModel, TheEndToEndWireIsHeldWithItsFitAlone) {
  sma_host::RunSetup s = e2e_steps(sma_host::e2e_fit_without_convection(), sma::Effects());
  EXPECT_LE(steady_error(s), 0.010);
  s.preview.reapproach_mm = 0.0;
  EXPECT_GT(steady_error(s), 0.05);
}

// The same wire with the model the e2e flow uploads to the board (sma_host::e2e_flow_fit: every key
// of its fit, the cooling side and the minor loops included). Its cooling curve is not the wire's
// (eq 11's top 0.70 against the wire's 0.80 after the 0.8 mm peak) and its heat loss is linear
// where the wire's grows with the temperature rise, so the position offset on the cooling curve
// is 0.26 mm at the 0.8 mm hold and ~0.18 at 0.5 mm: taken along the move down, the larger one
// drives the model wire past the 0.5 mm hold and the wire sinks onto its cooling curve, where no
// cooling raises it (0.405 mm). Approached from above (PreviewConfig::stale_offset_mm), the
// steady-state error (sse_mm: the best 2 s mean in each hold's second half) is within the issue's
// 10 um (the 0.5 mm hold still creeps ~10 um low by its end); without it the 0.5 mm hold is
// missed by ~0.09 mm.
TEST(PreviewWrongModel, TheEndToEndWireIsHeldWithTheModelTheFlowUploads) {
  sma_host::RunSetup s = e2e_steps(sma_host::e2e_flow_fit(), sma_host::e2e_flow_fit_effects());
  EXPECT_LE(steady_error(s), 0.010);
  s.preview.stale_offset_mm = 0.0;
  EXPECT_GT(steady_error(s), 0.05);
}

// The flow's fit (e2e_flow_fit) leaves its third minor loop (T_i 71.5 C) almost without a rise
// (j 0.0001), where the wire's loop there rises j 0.10 (Table II, which e2e_wire keeps). Peaks
// near it are met on the 0.8 mm step (the model wire peaks at 74.6 C) and at the sine's top
// (71.8 C): the plan stops the heating where the fit's loop has no rise, the wire rides its own
// (eqs 5-6) 0.036 mm past the 0.8 mm hold (issue 13: <= 0.03 mm before the down-step) and ~0.07 mm
// past the sine's top (max over a period 0.114 mm). With the wire's j at that knot and nothing
// else changed, the same controller meets the limits (issue 13: sine max <= 0.12 mm) with the
// sine's max lower by more than that limit's margin over the rise: the cause is the model the flow
// uploads, which no learning within the run can know before its first peak there (docs/control.md
// section 21).
TEST(PreviewWrongModel, TheFlowsFitMissesTheRiseOfItsThirdLoop) {
  sma::Params fit = sma_host::e2e_flow_fit();
  double sine_max[2];
  for (bool wire_rise : {true, false}) {
    fit.loops[2].j = wire_rise ? sma_host::e2e_wire().loops[2].j : sma_host::e2e_flow_fit().loops[2].j;
    sma_host::RunSetup s = e2e_steps(fit, sma_host::e2e_flow_fit_effects());
    const double before = sma_host::step_metrics(sma_host::run_closed_loop<float>(s), s.reference.step_s).wrong_way_before_mm;
    s.reference = sma::Reference::sine();
    sine_max[wire_rise] = sma_host::sine_metrics(sma_host::run_closed_loop<float>(s), s.reference.sine_period_s).max_mm;
    if (wire_rise) EXPECT_LE(before, 0.03);
    else EXPECT_GT(before, 0.03);
  }
  EXPECT_LE(sine_max[1], 0.12);
  // The rise the fit misses (the wire's j 0.10 at the knot) shows as a larger error at the top.
  EXPECT_GT(sine_max[0] - sine_max[1], 0.03);
}

// A more exact model never tracks worse (issue 13) needs tracking continuous in the model: keys
// moved far below what a fit resolves (T_AF +-0.02 .. 0.05 K, h -0.2 .. +0.1 %, against the fit's
// 95 % intervals of +-0.26 K and +-0.3 %) move the model's heating curve (eq 4) by < 0.1 K, a few
// um of position at its steepest. The plan's switch off before the sine's top must not jump with
// them: when "now" had to win outright, the heating ran on in some of them until it did, 2 s and
// ~1 K of peak later, and the wire rode its rise 0.04 mm past the top (max 0.056 -> 0.097 mm;
// docs/control.md sections 23, 25). The flow's fit with the wire's rise at its third loop (the
// counterfactual of the test above, whose j puts the top's switch where it matters).
TEST(PreviewWrongModel, TheSinesTopIsContinuousInTheModel) {
  sma::Params base = sma_host::e2e_flow_fit();
  base.loops[2].j = sma_host::e2e_wire().loops[2].j;
  base.loops[2].T_ii = 65.2;  // where the start of the flow's fit puts it (docs/control.md section 23)
  const double dT_AF[] = {0.0, 0.02, -0.02, 0.05, 0.0, 0.0, 0.0};
  const double dh[] = {0.0, 0.0, 0.0, 0.0, 5e-4, 1e-3, -2e-3};
  double lo = 1.0, hi = 0.0;
  for (int k = 0; k < 7; ++k) {
    sma::Params m = base;
    m.T_AF += dT_AF[k];
    m.h *= 1.0 + dh[k];
    sma_host::RunSetup s = e2e_steps(m, sma_host::e2e_flow_fit_effects());
    s.reference = sma::Reference::sine();
    const double mx = sma_host::sine_metrics(sma_host::run_closed_loop<float>(s), s.reference.sine_period_s).max_mm;
    lo = fmin(lo, mx);
    hi = fmax(hi, mx);
  }
  EXPECT_LE(hi, 0.12);                // issue 13's limit, at every one of them
  EXPECT_LE(hi - lo, 0.02) << lo << " .. " << hi;  // 10 ADC steps: ~5x what the model change itself moves
}

// A model a fraction of a fit's own 95 % intervals away from it: h x (1 + dh), T_AF + dT_AF.
struct Near {
  double dh, dT_AF;
};

// The multi-step's metrics on a model near a fit (the fit itself: Near{0, 0}).
sma_host::Metrics steps_near(const sma::Params& fit, const sma::Effects& fx, const Near& n) {
  sma::Params p = fit;
  p.h *= 1.0 + n.dh;
  p.T_AF += n.dT_AF;
  const sma_host::RunSetup s = e2e_steps(p, fx);
  return sma_host::step_metrics(sma_host::run_closed_loop<float>(s), s.reference.step_s);
}

// Issue 13's "a more exact model never tracks worse" needs tracking that moves continuously
// with the model below what a fit resolves. The flow's fit and models a sixth to two thirds of
// its own 95 % intervals away (h +-0.3 %, T_AF +-0.26 K): on each the wire rides a rise past the
// 0.2 mm hold and is re-approached down its loop (eqs 5-6, 11); the re-heat before the 0.4 mm
// step starts when the wire is back at the hold, so the step starts from the heating curve on
// every one of them. Within 2.5 ADC steps (2 um each) of the fit's own run in the wrong-way move
// before a step, within the 10 um in the whole run's RMS. (Left to the plan's tie
// between switch times, the re-heat started 1.6 s before the step on three of them, the wire
// rode the 0.4 mm hold's rise and was re-approached again: 16-18 um and 14-15 um apart.)
TEST(PreviewWrongModel, TheFirstHoldsReapproachDoesNotFlipOnAHundredthOfTheFit) {
  const sma::Params fit = sma_host::e2e_flow_fit();
  const sma::Effects fx = sma_host::e2e_flow_fit_effects();
  const sma_host::Metrics at = steps_near(fit, fx, Near{0.0, 0.0});
  for (const Near& n : {Near{0.0005, 0.0}, Near{0.001, 0.0}, Near{-0.002, 0.0}, Near{0.0, 0.05}}) {
    const sma_host::Metrics m = steps_near(fit, fx, n);
    EXPECT_NEAR(m.wrong_way_before_mm, at.wrong_way_before_mm, 0.005) << n.dh << " " << n.dT_AF;
    EXPECT_NEAR(m.rms_mm, at.rms_mm, 0.010) << n.dh << " " << n.dT_AF;
  }
}

// The same on the fit without the wire's convection (sma_host::e2e_fit_without_convection): its
// 0.8 mm hold is approached on the rise and held on the cooling branch, the model wire slides down
// a cooling curve the wire does not follow (the offset takes the gap). Heating there only raises
// the fraction (eq 4); in the plan it opens a new loop from the cap's peak (eqs 5-11), which the
// model scores ~0.016 (0.1 mm)^2 better than waiting, the switch margin itself. Where it won (T_AF
// -0.05 K), the wire was re-heated to the peak 9 s before the 0.5 mm step and left the hold 1.5 s
// late (max 0.266 -> 0.309 mm). Over keys a fraction of the fit's own intervals, the run's max
// within 5 ADC steps (10 um) of the fit's run, its RMS within the 10 um.
TEST(PreviewWrongModel, AHoldBeforeAMoveDownIsNotReheatedOnAHundredthOfTheFit) {
  const sma::Params fit = sma_host::e2e_fit_without_convection();
  const sma_host::Metrics at = steps_near(fit, sma::Effects(), Near{0.0, 0.0});
  for (const Near& n : {Near{0.0, -0.05}, Near{0.0, -0.1}, Near{-0.0005, 0.0}, Near{0.0005, 0.0}}) {
    const sma_host::Metrics m = steps_near(fit, sma::Effects(), n);
    EXPECT_NEAR(m.max_mm, at.max_mm, 0.010) << n.dh << " " << n.dT_AF;
    EXPECT_NEAR(m.rms_mm, at.rms_mm, 0.010) << n.dh << " " << n.dT_AF;
  }
}

}  // namespace
