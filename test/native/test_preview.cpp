// The preview controller (preview.hpp) in closed loop on the simulated plant: the targets of
// the issue "use the known future", on whole-run metrics (metrics.hpp, true position).
#include <gtest/gtest.h>
#include <math.h>
#include <string.h>
#include "sma/console.hpp"
#include "sma/fixed.hpp"
#include "sma/preview.hpp"
#include "sma/reference.hpp"
#include "sma_host/metrics.hpp"

namespace {
using sma_host::Condition;
using sma_host::Metrics;
using sma_host::RunSetup;

RunSetup preview_setup(bool sine, bool rig_like) {
  RunSetup s;
  s.mode = sma::Mode::Preview;
  s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
  s.condition = rig_like ? Condition::rig_like() : Condition::ideal();
  return s;
}

template <class T>
Metrics run(const RunSetup& s, std::vector<sma_host::Sample>* out = nullptr) {
  const std::vector<sma_host::Sample> r = sma_host::run_closed_loop<T>(s);
  if (out) *out = r;
  return s.reference.kind == sma::RefKind::Sine ? sma_host::sine_metrics(r, s.reference.sine_period_s)
                                                : sma_host::step_metrics(r, s.reference.step_s);
}

// Sine 0.2-0.7 mm, rig-like, in the firmware's float: the whole period after the first,
// rising and falling alike (the targets: max <= 0.12 mm, RMS <= 0.05 mm; inverse + PID
// has ~0.24 mm while the reference falls).
TEST(Preview, SineWholePeriodRigLike) {
  const Metrics m = run<float>(preview_setup(true, true));
  EXPECT_LE(m.max_mm, 0.12);
  EXPECT_LE(m.rms_mm, 0.05);
  EXPECT_LE(m.max_fall_mm, 0.12);
}

// Multi-step, rig-like: whole-run RMS <= 0.05 mm and below PID alone's (the firmware's
// default PID gains), no wrong-way move after a down-step beyond 0.03 mm, zero SSE.
TEST(Preview, MultiStepRigLike) {
  const Metrics m = run<float>(preview_setup(false, true));
  RunSetup pid = preview_setup(false, true);
  pid.mode = sma::Mode::Pid;
  pid.config.gains = sma::console::default_gains(sma::Mode::Pid);
  const Metrics mp = run<float>(pid);
  EXPECT_LE(m.rms_mm, 0.05);
  EXPECT_LT(m.rms_mm, mp.rms_mm);
  EXPECT_LE(m.wrong_way_mm, 0.03);
  EXPECT_LE(m.wrong_way_before_mm, 0.03);
  EXPECT_LT(m.sse_mm, 0.005);
}

// Before the 0.8 -> 0.5 mm down-step the wire must not first go up: heated to 0.8 mm on the
// heating branch, any cooling starts with the minor-loop rise j_i (eqs 5-6, ~0.08 mm here).
// Rig-like, float, on the exact model and on a wire with latent heat with its exact model:
// no move past a held setpoint away from the next one beyond 0.03 mm (the wrong-way
// target), none after the step either. Without the look beyond the horizon
// (lookahead_s = 0) the plan leaves 0.8 mm upwards ~14 s early: the check can fail.
TEST(Preview, NoRiseBeforeADownStep) {
  for (double latent_J : {0.0, 1.0}) {
    RunSetup s = preview_setup(false, true);
    s.plant_effects.latent_heat_J = latent_J;
    s.model_effects = s.plant_effects;
    const Metrics m = run<float>(s);
    EXPECT_LE(m.wrong_way_before_mm, 0.03) << latent_J;
    EXPECT_LE(m.wrong_way_mm, 0.03) << latent_J;
    EXPECT_LT(m.sse_mm, 0.005) << latent_J;
    s.preview.lookahead_s = 0.0;
    EXPECT_GT(run<float>(s).wrong_way_before_mm, 0.05) << latent_J;
  }
}

// Zero steady-state error with the exact model (the offset estimate is the integral action;
// with a fitted model that is not the plant see docs/control.md: not yet met).
TEST(Preview, ZeroSteadyStateErrorExactModel) {
  const Metrics m = run<float>(preview_setup(false, false));
  EXPECT_LT(m.sse_mm, 0.005);
}

// A wire with latent heat, and the exact model of it on the board: no up-step overshoots its
// setpoint by more than 0.01 mm in its first 10 s (later in a step the controller may leave the
// setpoint on purpose, to take the next step from the flat side of a minor loop).
TEST(Preview, NoOvershootWithExactLatentHeatModel) {
  RunSetup s = preview_setup(false, true);
  s.plant_effects.latent_heat_J = 1.0;
  s.model_effects = s.plant_effects;
  std::vector<sma_host::Sample> r;
  const Metrics m = run<float>(s, &r);
  double over = 0, prev = 0, cur = r.front().ref;
  for (const sma_host::Sample& x : r) {
    if (x.ref != cur) {
      prev = cur;
      cur = x.ref;
    }
    if (cur > prev && fmod(x.t, s.reference.step_s) < 10.0) over = fmax(over, x.truth - x.ref);
  }
  EXPECT_LE(over, 0.01);
  EXPECT_LT(m.sse_mm, 0.005);
}

// A wire with latent heat (1 J) and models of it from none to exact: a more exact model never
// tracks worse (whole-run RMS on both references, the sine's max, the steps' SSE and overshoot
// past each new setpoint within 10 s of its step), and the exact one overshoots no step by more
// than 0.01 mm. (The steps' whole-run max is the 0.2 mm jump at t = 0 plus its transient.) An
// overshoot within rise_margin_mm (5 um, where the preview lands a hold it approaches on the
// rise: the exact model's own) ranks no model: a less exact model's wire, slower through its
// unmodelled latent heat, may still be short of its hold after 10 s where a faster one has
// passed it by a few um, and ends as high or higher.
TEST(Preview, MoreExactLatentHeatModelNeverTracksWorse) {
  const double models_J[] = {0.0, 0.5, 1.0};
  Metrics prev_sine, prev_steps;
  double prev_over = 0;
  for (int i = 0; i < 3; ++i) {
    RunSetup s = preview_setup(false, true);
    s.plant_effects.latent_heat_J = 1.0;
    s.model_effects.latent_heat_J = models_J[i];
    std::vector<sma_host::Sample> r;
    const Metrics ms = run<float>(s, &r);
    const double over = sma_host::step_overshoot_mm(r, s.reference.step_s, 10.0);
    s.reference = sma::Reference::sine();
    const Metrics mn = run<float>(s);
    if (i > 0) {
      EXPECT_LE(ms.rms_mm, prev_steps.rms_mm) << models_J[i];
      EXPECT_LE(ms.sse_mm, prev_steps.sse_mm + 0.001) << models_J[i];
      const double margin = sma::PreviewConfig().rise_margin_mm;
      EXPECT_LE(fmax(over, margin), fmax(prev_over, margin) + 0.001) << models_J[i];
      EXPECT_LE(mn.rms_mm, prev_sine.rms_mm) << models_J[i];
      EXPECT_LE(mn.max_mm, prev_sine.max_mm) << models_J[i];
    }
    prev_steps = ms;
    prev_sine = mn;
    prev_over = over;
  }
  EXPECT_LE(prev_over, 0.01);
  EXPECT_LE(prev_steps.rms_mm, 0.05);
  EXPECT_LT(prev_steps.sse_mm, 0.005);
}

// A model that is not the wire (a fit a little off): the steps still reach their setpoints
// and the whole run stays within the targets and below PID alone's RMS.
// Not yet met for a convection coefficient h 10 % low (docs/control.md, open points).
TEST(Preview, PerturbedModelKeepsTheSetpoints) {
  RunSetup pid = preview_setup(false, true);
  pid.mode = sma::Mode::Pid;
  pid.config.gains = sma::console::default_gains(sma::Mode::Pid);
  const Metrics mp = run<float>(pid);
  for (int k = 0; k < 3; ++k) {
    RunSetup s = preview_setup(false, true);
    if (k == 0) s.model_params.T_AS += 2.0, s.model_params.T_AF += 2.0;
    if (k == 1) s.model_params.T_AS -= 2.0, s.model_params.T_AF -= 2.0;
    if (k == 2) s.model_params.g *= 1.03;
    const Metrics m = run<float>(s);
    EXPECT_LE(m.rms_mm, 0.05) << k;
    EXPECT_LT(m.rms_mm, mp.rms_mm) << k;
    EXPECT_LE(m.sse_mm, 0.011) << k;
  }
}

// Float tracks like double; Q16.16 runs the same plan without blowing up (it is still
// behind float on the sine: docs/control.md, open points).
TEST(Preview, FixedAndFloatTrackLikeDouble) {
  for (bool sine : {true, false}) {
    const RunSetup s = preview_setup(sine, false);
    const Metrics md = run<double>(s), mf = run<float>(s), mx = run<sma::Fixed>(s);
    EXPECT_NEAR(mf.rms_mm, md.rms_mm, 0.005) << sine;
    EXPECT_LT(mx.rms_mm, 0.1) << sine;
  }
}

// Q16.16 on the ideal multi-step tracks like double, with and without commit_switch. (Before
// the down-step was approached on the rise, Q16.16 needed commit_switch here: the early switch
// before the 0.8 -> 0.5 mm step was postponed by every new plan on tied costs, RMS ~0.095 mm.
// No early switch is needed now; commit_switch costs ~5 um RMS in double and Q16.16 alike:
// a committed heating during the falls, docs/control.md section 14.)
TEST(Preview, FixedMultiStepTracksLikeDouble) {
  for (bool commit : {false, true}) {
    RunSetup s = preview_setup(false, false);
    s.preview.commit_switch = commit;
    const Metrics md = run<double>(s), mx = run<sma::Fixed>(s);
    EXPECT_LE(mx.rms_mm, 0.05) << commit;
    EXPECT_NEAR(mx.rms_mm, md.rms_mm, 0.005) << commit;
    EXPECT_LE(mx.wrong_way_mm, 0.03) << commit;
    EXPECT_LE(mx.wrong_way_before_mm, 0.03) << commit;
  }
}

// Planning in the board's idle time (plan_in_step = false, plan_step() after each tick: the
// next tick's lead sample, then as many grid steps as the tick planned) tracks like planning
// inside the tick; with no idle time
// at all the controller never switches early and the sine falls behind (the plan matters).
TEST(Preview, IdlePlanningTracksLikeInTickPlanning) {
  for (bool sine : {true, false}) {
    const RunSetup s = preview_setup(sine, true);
    RunSetup idle = s;
    idle.preview.plan_in_step = false;
    idle.idle_plan_steps = s.preview.steps_per_tick + 1;
    const Metrics m = run<float>(s), mi = run<float>(idle);
    EXPECT_NEAR(mi.rms_mm, m.rms_mm, 0.003) << sine;
    EXPECT_LE(mi.max_mm, m.max_mm + 0.01) << sine;
    if (sine) {
      idle.idle_plan_steps = 0;
      EXPECT_GT(run<float>(idle).max_mm, 0.1);
    }
  }
}

// Planning between ticks, the host's loop gives plan_step() the passes of the config it runs
// (PreviewConfig::plan_passes, the board's rule): with 2 grid steps a tick, a lead sample and 2
// grid steps, whatever the default config plans. The run equals one with 3 passes set by hand and
// not one with the default config's 5 (so the pass count shows in the run).
TEST(Preview, IdlePassesFollowTheConfig) {
  RunSetup s = preview_setup(true, true);
  s.duration_s = 30.0;
  s.preview.plan_in_step = false;
  s.preview.steps_per_tick = 2;
  RunSetup three = s, five = s;
  three.idle_plan_steps = 3;
  five.idle_plan_steps = 1 + sma::PreviewConfig().steps_per_tick;
  ASSERT_NE(five.idle_plan_steps, 3);
  std::vector<sma_host::Sample> a, b, c;
  run<float>(s, &a);
  run<float>(three, &b);
  run<float>(five, &c);
  ASSERT_EQ(a.size(), b.size());
  bool differs = false;
  for (size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].v, b[k].v) << "tick " << k;
    differs = differs || a[k].v != c[k].v;
  }
  EXPECT_TRUE(differs);
}

// NaN in: heater off.
TEST(Preview, NanGivesZeroVolts) {
  const sma::Params p;
  sma::PreviewController<float> c(p, sma::Effects(), sma::PreviewConfig());
  auto future = [](float) { return 0.5f; };
  EXPECT_GT(c.step(0.5f, future, 0.0f), 0.0f);
  EXPECT_EQ(c.step(NAN, future, 0.0f), 0.0f);
  EXPECT_EQ(c.step(0.5f, future, NAN), 0.0f);
}

// The work a board runs after the PWM write (prepare_next_tick: the model wire's hysteresis,
// the cooling loop ahead, the heat-loss sample's first part) changes no number: a caller that
// calls it after every tick and one that leaves it to step() / plan_step() command the same
// voltages, bit for bit (sine and multi-step, idle planning, PWM rounding, observer on). The
// measurement is the reference 0.3 s late and 20 um low, the same for both.
TEST(Preview, PreparingTheNextTickChangesNoNumber) {
  for (const sma::Reference& r : {sma::Reference::sine(), sma::Reference::multi_step()}) {
    sma::PreviewConfig cfg;
    cfg.plan_in_step = false;
    cfg.pwm_top = 15999;
    sma::PreviewController<float> a(sma::Params(), sma::Effects(), cfg), b(sma::Params(), sma::Effects(), cfg);
    const sma::ReferenceGen<float> ref(r);
    int differ = 0, heated = 0;
    for (int k = 0; k < 6000; ++k) {
      const double t = 0.01 * k;
      auto future = [&](float tau) { return ref.at(t + static_cast<double>(tau)); };
      const float measured = t < 0.3 ? 0.0f : ref.at(t - 0.3) - 0.02f;
      const float va = a.step(ref.at(t), future, measured), vb = b.step(ref.at(t), future, measured);
      a.prepare_next_tick();
      for (int i = 0; i < 5; ++i) {
        a.plan_step(future);
        b.plan_step(future);
      }
      if (memcmp(&va, &vb, sizeof va) != 0) ++differ;
      if (va > 0.0f) ++heated;
    }
    EXPECT_EQ(differ, 0);
    EXPECT_GT(heated, 1000);  // the runs do drive the wire
  }
}

}  // namespace

// The preview's settings: the defaults are valid; a setting out of its range or NaN is refused
// with a message naming it, and a controller built from such a set stays off (0 V).
TEST(PreviewConfig, OutOfRangeSettingsAreRefusedByName) {
  EXPECT_EQ(sma::PreviewConfig().check(), nullptr);
  struct Bad {
    double sma::PreviewConfig::*field;
    double value;
    const char* name;
  };
  const Bad bad[] = {{&sma::PreviewConfig::lookahead_s, -1.0, "lookahead_s"},
                     {&sma::PreviewConfig::lookahead_s, 100.0, "lookahead_s"},
                     {&sma::PreviewConfig::lookahead_s, NAN, "lookahead_s"},
                     {&sma::PreviewConfig::rise_margin_mm, -0.001, "rise_margin_mm"},
                     {&sma::PreviewConfig::rise_margin_mm, 0.5, "rise_margin_mm"},
                     {&sma::PreviewConfig::ride_margin_mm, -0.001, "ride_margin_mm"},
                     {&sma::PreviewConfig::ride_margin_mm, 0.2, "ride_margin_mm"},
                     {&sma::PreviewConfig::ride_margin_mm, NAN, "ride_margin_mm"},
                     {&sma::PreviewConfig::cool_weight, 101.0, "cool_weight"},
                     {&sma::PreviewConfig::lag_guard_mm, 0.2, "lag_guard_mm"},
                     {&sma::PreviewConfig::curve_shift_tau_s, 0.001, "curve_shift_tau_s"},  // below dt
                     {&sma::PreviewConfig::reapproach_mm, -0.01, "reapproach_mm"},
                     {&sma::PreviewConfig::reapproach_mm, NAN, "reapproach_mm"},
                     {&sma::PreviewConfig::stale_offset_mm, 2.0, "stale_offset_mm"},
                     {&sma::PreviewConfig::stale_offset_mm, NAN, "stale_offset_mm"},
                     {&sma::PreviewConfig::heat_gain_latent_spread, -0.01, "heat_gain_latent_spread"},
                     {&sma::PreviewConfig::heat_gain_latent_spread, 11.0, "heat_gain_latent_spread"},
                     {&sma::PreviewConfig::heat_gain_latent_spread, NAN, "heat_gain_latent_spread"}};
  for (const Bad& b : bad) {
    sma::PreviewConfig c;
    c.*b.field = b.value;
    const char* why = c.check();
    ASSERT_NE(why, nullptr) << b.name << " = " << b.value;
    EXPECT_NE(strstr(why, b.name), nullptr) << why;
    const sma::Params p;
    sma::PreviewController<double> ctl(p, sma::Effects(), c);
    EXPECT_EQ(ctl.step(0.5, [](double) { return 0.5; }, 0.2), 0.0) << b.name;
  }
}
