// Inverse + PID with the known future (LeadConfig::lead_s, issue 13): the peak rule stops
// a heating where the minor-loop rise (eqs 5-6) carries the wire to the coming peak, the wire
// rides the rise up, and the cooling branch is taken lead_s before the reference falls.
// The firmware's default gains (console::default_gains) throughout: the settings the Uno runs.
#include <gtest/gtest.h>
#include <cmath>
#include <vector>
#include "sma/console.hpp"
#include "sma/fixed.hpp"
#include "sma_host/metrics.hpp"

namespace {
using sma_host::Condition;
using sma_host::Metrics;
using sma_host::RunSetup;
using sma_host::Sample;

RunSetup setup(sma::Mode mode, bool sine, double lead_s) {
  RunSetup s;
  s.mode = mode;
  s.condition = Condition::rig_like();
  s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
  s.config.gains = sma::console::default_gains(mode);
  s.lead.lead_s = lead_s;
  return s;
}

Metrics metrics(const RunSetup& s, const std::vector<Sample>& r) {
  return s.reference.kind == sma::RefKind::Sine ? sma_host::sine_metrics(r, s.reference.sine_period_s)
                                                : sma_host::step_metrics(r, s.reference.step_s);
}

// The highest true position after the first (start-up) period of the sine.
double highest_after_first_period(const RunSetup& s, const std::vector<Sample>& r) {
  double top = 0.0;
  for (const Sample& x : r)
    if (x.t >= s.reference.sine_period_s) top = std::max(top, x.truth);
  return top;
}

// The sine's peaks: without the future the wire is heated to the peak and the cooling that
// follows opens a minor loop whose rise (eqs 5-6, ~0.15 mm here) carries it past the peak
// (Fig. 12). With it, the heating stops where that rise ends at the peak.
TEST(Lead, RiseOfTheMinorLoopEndsAtTheSinePeak) {
  const RunSetup paper = setup(sma::Mode::FeedforwardPid, true, 0.0);
  const RunSetup lead = setup(sma::Mode::FeedforwardPid, true, 3.0);
  const double hi = paper.reference.sine_hi_mm;
  const double over_paper = highest_after_first_period(paper, sma_host::run_closed_loop<double>(paper)) - hi;
  const double over_lead = highest_after_first_period(lead, sma_host::run_closed_loop<double>(lead)) - hi;
  std::printf("past the peak: lead 0 %.4f mm, lead 3 s %.4f mm\n", over_paper, over_lead);
  EXPECT_GT(over_paper, 0.1);   // the paper's controller: the whole rise past the peak
  EXPECT_LT(over_lead, 0.02);   // the rise spent below the peak
}

// While the wire rides the rise, the feedforward cools it: the desired temperature falls while
// the desired fraction (the reference) rises, the one branch of the hysteresis where a lower
// temperature means a longer wire.
TEST(Lead, RidingTheRiseCoolsWhileTheReferenceRises) {
  for (int f = 0; f < 2; ++f) {
    const RunSetup s = setup(sma::Mode::FeedforwardPid, true, 3.0);
    sma::Controller<double> ctl(s.model_params, s.model_effects, s.config);
    sma::ReferenceGen<double> gen(s.reference, s.config.dt);
    ctl.set_mode(sma::Mode::FeedforwardPid, 0.0);
    const uint32_t lead = s.lead.lead_ticks(s.config.dt), window = s.lead.sample_ticks(s.config.dt);
    int riding = 0;
    double T_prev = 0.0, r_prev = 0.0;
    bool was_riding = false;
    // The model wire as the plant: the inverse's own wire (ideal tracking) is the measurement.
    double d = 0.0;
    for (uint32_t k = 0; k < 15000; ++k) {
      const double r = gen.at_tick(k, s.config.dt);
      ctl.step(r, d, f ? gen.lookahead(k, lead, window, s.config.dt) : sma::Lookahead<double>{r, r, r}, f == 1);
      const sma::InverseModel<double>& inv = ctl.inverse();
      d = inv.mechanics().displacement(inv.memory().eps());
      if (inv.riding()) {
        ++riding;
        if (was_riding) {
          EXPECT_LE(inv.desired_temperature(), T_prev + 1e-12) << "tick " << k;
          EXPECT_GE(r, r_prev - 1e-12) << "tick " << k;
        }
        T_prev = inv.desired_temperature();
        r_prev = r;
      }
      was_riding = inv.riding();
      ctl.prepare_next_tick();
    }
    if (f) EXPECT_GT(riding, 3 * 100) << "a second or more of riding in each of the 3 periods";
    else EXPECT_EQ(riding, 0) << "the paper's controller never rides";
  }
}

// At a valley of the sine the reference lead_s ahead turns up while the present one still falls.
// On the cooling stage the inverse's path is the present reference's (the lead ends where the wire
// moves: InverseModel::step), and the branch does not reverse against the future: one turn to
// heating per valley, where the present reference comes back up past its lowest point (the
// deadband, 0.1 um: ~0.2 s after the valley of the paper's sine), never before it (a turn on the
// point ahead, half the lead early, held the wire on the flat stage above the falling reference:
// the wire stopped ~0.004 mm above the valley, then overshot the rise). The flat stage between the
// cooling and the heating curve (eq 4) takes ~2 s of heating at V_max from the valley's 26 C, while
// the reference rises 0.25 (1 - cos(2 pi 2 / 50)) = 0.008 mm: the wire lags the rise by about
// that much, not more.
TEST(Lead, TheValleyIsTurnedOnceWhereThePresentReferenceTurns) {
  RunSetup s = setup(sma::Mode::FeedforwardPid, true, 3.0);
  sma::Controller<double> ctl(s.model_params, s.model_effects, s.config);
  sma::ReferenceGen<double> gen(s.reference, s.config.dt);
  ctl.set_mode(sma::Mode::FeedforwardPid, 0.0);
  const uint32_t lead = s.lead.lead_ticks(s.config.dt), window = s.lead.sample_ticks(s.config.dt);
  const double P = s.reference.sine_period_s;
  // The model wire as the plant (ideal tracking): the turns are the inverse's own. One second past
  // the third period, so that its valley is in the run.
  double d = 0.0;
  bool heating = true;
  std::vector<double> to_heating;
  for (uint32_t k = 0; k < 15100; ++k) {
    const double t = k * s.config.dt;
    ctl.step(gen.at_tick(k, s.config.dt), d, gen.lookahead(k, lead, window, s.config.dt), true);
    const sma::InverseModel<double>& inv = ctl.inverse();
    d = inv.mechanics().displacement(inv.memory().eps());
    if (inv.heating() && !heating) to_heating.push_back(t);
    heating = inv.heating();
    ctl.prepare_next_tick();
  }
  // The valleys: t = P, 2P, 3P (the sine starts at its valley, t = 0).
  ASSERT_EQ(to_heating.size(), 3u) << "one turn to heating per valley";
  for (size_t i = 0; i < to_heating.size(); ++i) {
    const double after = to_heating[i] - static_cast<double>(i + 1) * P;
    std::printf("valley %zu: turned to heating %.2f s after it\n", i + 1, after);
    EXPECT_GE(after, 0.0) << "not before the present reference turns";
    EXPECT_LT(after, 0.5) << "the deadband's 0.1 um: ~0.2 s";
  }
  // Closed loop (rig-like, float, the sine's board lead): the error within 5 s of each valley.
  s.lead = sma::lead_for(sma::RefKind::Sine);
  const std::vector<Sample> r = sma_host::run_closed_loop<float>(s);
  double worst = 0.0;
  for (const Sample& x : r) {
    const double phase = std::fmod(x.t, P);
    if (x.t >= P - 5.0 && (phase < 5.0 || phase > P - 5.0)) worst = std::max(worst, std::fabs(x.truth - x.ref));
  }
  std::printf("valleys: max error %.4f mm\n", worst);
  // The flat stage's 0.008 mm, the sensor's delay and noise (rig-like) and the PID's answer to
  // them. (A turn half the 5.25 s lead early: 0.015 mm above the valley, then behind the rise.)
  EXPECT_LT(worst, 0.013);
}

// After the sine's top the wire reaches its cooling stage (T_MSi) while the reference already
// falls; from there it moves with its temperature. A path still lead_s ahead of the reference
// carried it below the falling reference at once, as fast as it cooled (0.031 mm with the sine's
// 5.25 s lead, 0.015 mm with 3.25 s), and the PID, which may not heat a cooling branch past V_hold,
// caught it late. On the cooling stage the path is the present reference's: the wire comes down
// onto it. Rig-like, float, the board's lead and gains; the falling halves after the first period.
TEST(Lead, OnTheCoolingStageTheWireFollowsThePresentReference) {
  RunSetup s = setup(sma::Mode::FeedforwardPid, true, 0.0);
  s.lead = sma::lead_for(sma::RefKind::Sine);
  const std::vector<Sample> r = sma_host::run_closed_loop<float>(s);
  const double P = s.reference.sine_period_s;
  double below = 0.0;  // the deepest the wire went below a falling reference
  for (size_t k = 1; k < r.size(); ++k)
    if (r[k].t >= P && r[k].ref < r[k - 1].ref) below = std::max(below, r[k].ref - r[k].truth);
  std::printf("below the falling reference: %.4f mm\n", below);
  // The sensor's noise (2 um) and delay, and the V_hold cap's (Controller): 3 ADC steps.
  EXPECT_LT(below, 0.006);
  const Metrics m = metrics(s, r);
  std::printf("whole run: max %.4f / RMS %.5f mm\n", m.max_mm, m.rms_mm);
}

// The peak rule waits until the heating it stops has been applied (the model wire on its path):
// a reversal opens a minor loop with its rise only after a heating that transformed, and at a
// valley the path reaches the heating curve ~2 s before the wire does. Stopped on the path alone,
// a wire a hair behind the model had transformed nothing and never rose: a 0.45-0.55 mm sine,
// parked 0.1 mm below it on 4 of 8 noise seeds (RMS 0.25 mm); the paper's wire on a 100 s sine,
// 0.070 mm RMS, behind the paper's inverse + PID (0.043). Rig-like, float, the board's lead and
// gains, whole run after the first period, each noise seed.
TEST(Lead, ThePeakRuleWaitsForTheHeatingToBeApplied) {
  struct Case {
    double lo, hi, period, cycles, rms_max;
  };
  // The bounds: below PID alone's and the paper's inverse + PID's (0.053 / 0.065 mm and
  // 0.064 / 0.043 mm, bench_tracking_excitations).
  const Case cases[] = {{0.45, 0.55, 50.0, 3.0, 0.04}, {0.2, 0.7, 100.0, 2.0, 0.02}};
  for (const Case& c : cases) {
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      RunSetup s = setup(sma::Mode::FeedforwardPid, true, 0.0);
      s.lead = sma::lead_for(sma::RefKind::Sine);
      s.reference.sine_lo_mm = c.lo;
      s.reference.sine_hi_mm = c.hi;
      s.reference.sine_period_s = c.period;
      s.reference.sine_cycles = c.cycles;
      s.condition.rig.seed = seed;
      const Metrics m = sma_host::reference_metrics(sma_host::run_closed_loop<float>(s), c.period);
      std::printf("sine %.2f-%.2f mm, %g s, seed %d: RMS %.4f mm\n", c.lo, c.hi, c.period, static_cast<int>(seed),
                  m.rms_mm);
      EXPECT_LT(m.rms_mm, c.rms_max) << c.period << " s, seed " << seed;
    }
  }
}

// A hold reached on the ride (the reference's fraction equals the memory's, up to rounding) is
// still ridden in every scalar: the board's float decides as the host's double. A ramp to a hold,
// then a ramp down (a user's traj); the lead of a trajectory (3 s). With the memory's fraction
// walked back from the ride's temperature (not the reference's own), double left the ride at the
// hold by rounding and float did not: whole-run RMS 0.0284 against 0.0306 mm, the fall's max
// 0.015 against 0.087 mm.
TEST(Lead, AHoldOnTheRideIsDecidedAlikeInEveryScalar) {
  RunSetup s = setup(sma::Mode::FeedforwardPid, true, 3.0);
  s.reference = sma::Reference();
  s.reference.kind = sma::RefKind::Trajectory;
  const double pts[][2] = {{0, 0.2}, {10, 0.2}, {30, 0.7}, {50, 0.7}, {60, 0.3}, {80, 0.3}};
  for (const auto& p : pts) ASSERT_TRUE(s.reference.add_point(p[0], p[1]));
  const Metrics d = sma_host::reference_metrics(sma_host::run_closed_loop<double>(s));
  const Metrics f = sma_host::reference_metrics(sma_host::run_closed_loop<float>(s));
  const Metrics q = sma_host::reference_metrics(sma_host::run_closed_loop<sma::Fixed>(s));
  std::printf("RMS / fall max mm: double %.4f / %.4f, float %.4f / %.4f, Q16.16 %.4f / %.4f\n", d.rms_mm,
              d.max_fall_mm, f.rms_mm, f.max_fall_mm, q.rms_mm, q.max_fall_mm);
  EXPECT_NEAR(f.rms_mm, d.rms_mm, 0.0005);
  EXPECT_NEAR(f.max_fall_mm, d.max_fall_mm, 0.005);
  EXPECT_NEAR(q.rms_mm, d.rms_mm, 0.001);
  EXPECT_NEAR(q.max_fall_mm, d.max_fall_mm, 0.01);
}

// The Uno's choice (issue 13): the compact use of the future beats PID alone and the paper's
// inverse + PID on both tests by the whole-run max and RMS, with the firmware's gains.
TEST(Lead, BeatsPidAloneAndInversePlusPidOverTheWholeRun) {
  for (int sine = 1; sine >= 0; --sine) {
    const double lead_s = sine ? 3.0 : 10.0;
    const RunSetup pid = setup(sma::Mode::Pid, sine, 0.0), paper = setup(sma::Mode::FeedforwardPid, sine, 0.0),
                   lead = setup(sma::Mode::FeedforwardPid, sine, lead_s);
    const Metrics mp = metrics(pid, sma_host::run_closed_loop<float>(pid));
    const Metrics mf = metrics(paper, sma_host::run_closed_loop<float>(paper));
    const Metrics ml = metrics(lead, sma_host::run_closed_loop<float>(lead));
    std::printf("%s: max / RMS mm: PID %.4f / %.4f, inverse + PID %.4f / %.4f, lead %.0f s %.4f / %.4f\n",
                sine ? "sine" : "steps", mp.max_mm, mp.rms_mm, mf.max_mm, mf.rms_mm, lead_s, ml.max_mm, ml.rms_mm);
    EXPECT_LT(ml.rms_mm, mp.rms_mm);
    EXPECT_LT(ml.rms_mm, mf.rms_mm);
    EXPECT_LT(ml.max_mm, mp.max_mm);
    EXPECT_LT(ml.max_mm, mf.max_mm);
    if (sine) {  // issue 13's sine limits: max over the whole period <= 0.12 mm, RMS <= 0.05 mm
      EXPECT_LE(ml.max_mm, 0.12);
      EXPECT_LE(ml.rms_mm, 0.05);
    } else {     // and the multi-step's RMS <= 0.05 mm
      EXPECT_LE(ml.rms_mm, 0.05);
    }
  }
}

// The start of a user's trajectory (bench_tracking_excitations' traj-random): a hold, a move down
// to 0.212 mm, a jump to 0.513 mm held 6.3 s (the lead: 5.25 s), a hold at
// 0.335 mm; the Uno's default, float or Q16.16.
std::vector<Sample> jump_after_a_move_down(bool fixed) {
  RunSetup s = setup(sma::Mode::FeedforwardPid, false, 0.0);
  s.reference = sma::Reference();
  s.reference.kind = sma::RefKind::Trajectory;
  for (const auto& p : {std::make_pair(0.0, 0.345), {7.95, 0.345}, {7.96, 0.212}, {14.41, 0.212}, {14.42, 0.513},
                        {20.69, 0.513}, {20.70, 0.335}, {35.37, 0.335}})
    EXPECT_TRUE(s.reference.add_point(p.first, p.second));
  s.lead = sma::lead_for(s.reference.kind);
  return fixed ? sma_host::run_closed_loop<sma::Fixed>(s) : sma_host::run_closed_loop<float>(s);
}

// A user's trajectory (bench_tracking_excitations' traj-random, its start): after a move down to
// 0.212 mm the reference jumps to 0.513 mm. The heating starts on the flat stage (eq 4), where
// the model wire keeps the valley's fraction; on a hold approached on the heating branch the PID
// acts on the gap to the model wire, and read on the heating curve at its temperature (~0 mm
// there) that gap said the wire was 0.21 mm ahead: the PID cut the feedforward's 2 V to V_hold
// (0.66 V) until the cooling lead turned the branch 1.2 s later.
TEST(Lead, TheHeatingOfAJumpIsNotCutOnTheFlatStage) {
  for (int f = 0; f < 2; ++f) {
    const std::vector<Sample> r = jump_after_a_move_down(f != 0);
    double v_sum = 0.0;
    int n = 0;
    for (const Sample& x : r)
      if (x.t >= 14.5 && x.t < 15.5) {
        v_sum += x.v;
        ++n;
      }
    std::printf("%s: mean voltage in the jump's first second %.3f V\n", f ? "Q16.16" : "float", v_sum / n);
    EXPECT_GT(v_sum / n, 1.5) << f;  // was 0.66 V (V_hold): the feedforward's 2 V now reaches the wire
  }
}

// The same trajectory after the jump: 1.2 s into it the cooling lead turns the inverse to the
// 0.335 mm hold ahead, and its model wire cools along its loop to that hold, while the wire, its
// heating cut short on the flat stage (eq 4), stays at 0.21 mm. On a cooling branch cooling
// cannot raise the wire and the PID may not heat past V_hold: before the inverse restarted on a
// parked wire, the wire sat 0.126 mm under the hold for all its 14.7 s.
TEST(Lead, AWireParkedUnderItsHoldIsTakenUp) {
  for (int f = 0; f < 2; ++f) {
    const std::vector<Sample> r = jump_after_a_move_down(f != 0);
    double worst = 0.0;
    for (const Sample& x : r)
      if (x.t >= 20.7 && x.t < 35.3) worst = std::max(worst, std::fabs(x.truth - 0.335));
    std::printf("%s: worst error over the 0.335 mm hold %.4f mm\n", f ? "Q16.16" : "float", worst);
    EXPECT_LT(worst, 0.015) << f;  // was 0.126 mm, the whole hold
  }
}

TEST(Lead, ConfigRefusesALeadOutOfRange) {
  sma::LeadConfig c;
  c.lead_s = -1.0;
  EXPECT_STREQ(c.check(), "lead_s must be in 0..20");
  c.lead_s = NAN;
  EXPECT_STREQ(c.check(), "lead_s must be in 0..20");
  c.lead_s = 10.0;
  c.peak_window_s = 0.0;
  EXPECT_STREQ(c.check(), "peak_window_s must be in 0..20");
  c.peak_window_s = 10.0;
  EXPECT_EQ(c.check(), nullptr);
}
}  // namespace
