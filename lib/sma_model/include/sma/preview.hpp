// A controller that uses the known future of the reference (preview / model-predictive).
//
// The inverse + PID (controller.hpp) reacts to the reference: it turns from heating to cooling
// when the reference turns. On this wire that is too late: cooling from a peak T_i first
// moves the wire UP by the minor-loop rise j_i (eqs 5-6) and then holds it flat down to T_MSi
// (eqs 7-10), seconds later. The board knows the reference in advance, so this controller
// plans the branch switch ahead:
//
//  - Model wire: the temperature estimate (WireStep, eq 1 with the model's effects, on the
//    commanded voltage) walks its own Hysteresis: the loop memory (T_i, eps_i, j_i, T_MSi).
//  - Execution (every tick): on the heating branch the wire is driven to the major-curve
//    temperature of the reference (eq 15), on the cooling branch to this loop's cooling-curve
//    temperature (eq 16; T_MSi when the reference is above the loop's top). The heating branch
//    never lowers the commanded temperature and the cooling branch never raises it (a move
//    against the branch would open a new loop). The voltage is eq 17 at the model wire with a
//    first-order pull onto that temperature (track_s), looking track_s ahead in the reference.
//  - Integral action: the offset d between the measured and the model position is estimated
//    by a low-pass (offset_tau_s) and subtracted from the reference before inversion, so a
//    fitted model that is not the plant still reaches every setpoint (offset-free, as in
//    disturbance-model MPC). Two refinements for a model far from the wire (docs/control.md
//    section 16): (a) in a hold, a gap the wire is still closing by itself (it lags the model
//    wire) is not taken into d: integrated, such a lag drives the model wire past the setpoint
//    on a branch that cannot come back (the hysteresis locks it in); (b) at rest on the major
//    heating curve, d is moved into a shift of that curve's temperatures (eq 15 of the wire's
//    fraction against the model wire's), which, unlike a position offset, stays right along the
//    whole curve, so the next move needs no new offset; (c) a hold the wire overshot on the
//    heating branch (it rode a minor-loop rise, eqs 5-6, which no heating can take back) is
//    re-approached: the model wire is re-anchored on the wire's loop, the branch turns to
//    cooling, and the heating curve is shifted by what the overshoot says of it; back at the
//    hold, the wire is re-heated below its loop's peak (which moves nothing) if the next move
//    is up, so that the move starts from the heating curve.
//    (d) A hold reached by a move down that started with a large offset is approached from
//    above: an offset measured at one point of a cooling curve that is not the model's is wrong
//    at another, and the cooling branch cannot raise a wire it took past the hold.
//  - Heat-loss observer (heat_gain.hpp): a position offset cannot stand for a heat-balance
//    error (a model h that is off heats the model wire to another temperature than the wire,
//    and its loop memory then belongs to another wire). While both wires transform on the
//    heating curve, the measured position gives the wire's temperature (eq 15); the gap to the
//    model wire is regressed on dT/dk (slope: the wire's heat-loss gain k = h_wire / h_model;
//    intercept: a shift of the curves, left to the offset). The model wire runs eq 1 and eq 17
//    with k G, and a new k re-anchors it on the heating curve at T + dk dT/dk.
//  - Planning (spread over ticks, steps_per_tick grid steps per tick): from copies of the model
//    wire's temperature and hysteresis, it simulates the same branch policy on a coarse grid
//    (grid_s, exact thermal limits: at most V_max, at least passive cooling) over the horizon,
//    for a few candidate times of the next branch switch (now, 1, 2, 4, 7 s, or when the
//    reference turns); the cost is the squared position error, errors while the reference
//    falls weighted by cool_weight (the one heating/cooling trade-off setting). The heating
//    stops before a peak once the best switch time (between the candidates) has come, at the
//    temperature whose rise carries the wire to the top; it restarts before a valley when
//    "switch now" wins.
//  - After a switch the branch follows the reference: it turns back only once the reference
//    has moved with it and then turns against it.
//  - A hold whose next move is down (seen in the plan's reference or at a few knots beyond the
//    horizon) is approached from below on the rise: the heating stops at the peak T_i* whose
//    minor-loop rise ends at the setpoint (a fixed point of eq 15 and the loop's j_i), so the
//    wire arrives there on the cooling branch and the move down starts without going up first.
//
// API for a board: PreviewController<T> c(params, effects, cfg); each tick
//   V = c.step(ref_now, future, measured)
// where future(tau_s) returns the reference tau_s seconds ahead (a functor; the board's
// ReferenceGen at t + tau). No heap, no STL; float, double and sma::Fixed.
#ifndef SMA_PREVIEW_HPP
#define SMA_PREVIEW_HPP

#if !defined(__AVR__)
#include <new>  // placement new of PreviewSlot (the AVR board provides its own, sma/board.hpp)
#endif
#include "effects.hpp"
#include "heat_gain.hpp"
#include "hysteresis.hpp"
#include "mechanics.hpp"
#include "params.hpp"
#include "scalar.hpp"
#include "thermal.hpp"

// The heat-loss observer (heat_gain.hpp); 0 leaves its code out of an image (~2 KB of AVR flash,
// docs/control.md section 12).
#ifndef SMA_PREVIEW_HEAT_LOSS
#define SMA_PREVIEW_HEAT_LOSS 1
#endif

// The options only the host and the AVR cycle harness use: planning inside step() (plan_in_step)
// and commit_switch. A board plans between ticks and does not commit (sma/board.hpp); 0 leaves
// their code out of its image (firmware/src/main.cpp) and refuses a config that asks for them.
#ifndef SMA_PREVIEW_HOST_OPTIONS
#define SMA_PREVIEW_HOST_OPTIONS 1
#endif

// One copy of the functions a board calls from several places (AVR flash).
#define SMA_PREVIEW_NOINLINE __attribute__((noinline))

namespace sma {

struct PreviewConfig {
  double dt = 0.01;            // tick, s
  double v_max = 2.0;          // eq 18
  double horizon_s = 16.0;     // planning horizon: a peak, its rise and flat stage (~7 s)
  double grid_s = 0.5;         // planning grid (thermal steps are exact at any grid)
  uint8_t steps_per_tick = 4;  // planning grid steps simulated per tick (cycle budget)
  // Plan inside step() (steps_per_tick grid steps a tick), or not: a board whose tick cannot
  // hold a grid step (~7-25 k AVR cycles) sets it false and calls plan_step() in its idle time.
  bool plan_in_step = true;
  // The passes a caller that plans between ticks gives plan_step() after each tick: the next
  // tick's lead sample, then the grid steps a tick that plans in step() simulates (one grid step
  // less lets the sine fall behind, docs/control.md section 19). The one pacing rule of the
  // board (Board::plan()) and the host's loops, for whatever config they run.
  constexpr uint8_t plan_passes() const { return steps_per_tick < 255 ? uint8_t(steps_per_tick + 1) : uint8_t(255); }
  double track_s = 0.4;        // pull of the model wire onto the commanded temperature, s
  double offset_tau_s = 1.0;   // integral action: time constant of the offset estimate, s
  double cool_weight = 1.0;    // trade-off: weight of errors while the reference falls
  double deadband_mm = 1e-4;   // a reference turn smaller than this is not a turn
  double switch_margin_mm = 0.0125;  // a switch must beat waiting by this RMS error over the
                                     // horizon: small offsets of a fitted model never switch
  // A setpoint held (>= 2 s) before a move down is approached from below on the rise: the
  // heating stops at the peak T_i* whose minor-loop rise (eqs 5-6) ends rise_margin_mm above
  // the setpoint, and the wire arrives on the cooling branch, where it is held on the loop's
  // cooling curve (eq 16); the move down then starts there instead of going up by j_i first.
  // (The margin: a rise that falls short could only be made up by heating again, which opens
  // a new loop; one that passes the setpoint a little is cooled back.) The hold's next move is
  // looked for in the plan's reference and beyond it, at kFar knots over lookahead_s after
  // the horizon (0 = off).
  double lookahead_s = 16.0;
  double rise_margin_mm = 0.005;
  // The resolution of riding a loop's rise (eqs 5-6) on the cooling branch. The model wire
  // follows the reference, so whether a reference that climbs lies just above it or just below
  // is a rounding (0.2 um decided it between double and Q16.16): up to ride_margin_mm below the
  // model wire a climbing reference is still ridden (the temperature held: the wire stays), not
  // taken as a move down (cooled through: the wire would first rise the whole rest of the rise).
  // (A held reference is not: cooling through at a hold is the plan's way to be at T_MSi when a
  // move down comes.) And a reference within ride_margin_mm of the rise's top is not ridden up
  // to it: the wire is cooled on through the flat stage, so that it reaches T_MSi as the
  // reference turns down instead of waiting at the top through it (it ends at most the margin
  // past the reference).
  double ride_margin_mm = 0.005;
  // The heater's PWM (duty = (V / v_supply)^2 in pwm_top levels; 0 = continuous). On the
  // cooling branch above the loop's T_MSi (the rise and the flat stage) the command is rounded
  // down to a level, so the PWM's rounding never re-heats a wire that is meant to cool or hold
  // there: a re-heat, however small, may open a new minor loop at its peak (model.md's literal
  // reading) and start a fresh rise j (eqs 5-10). Below T_MSi a new loop passes through the
  // wire's point with no rise (T_i < T_s), and a hold needs the PWM's nearest level: rounding
  // down there would hold one level (~0.05 K, ~7 um on the cooling curve) too cold.
  uint16_t pwm_top = 0;
  double v_supply = 5.0;
  // Make a planned switch when its time comes (the plan is ~0.6 s old when it is decided)
  // instead of only a switch planned for "now". Off by default: docs/control.md has the
  // trade (better rig-like sine and Q16.16 multi-step, worse ideal sine in double).
  bool commit_switch = false;
  // Heat-loss observer (heat_gain.hpp): the wire's heat-loss gain against the model's (k =
  // h_wire / h_model), learned apart from a shift of the curves and applied to the model wire, so
  // that its temperature, and the loop memory it walks, stay the wire's. memory 0 = off.
  double heat_gain_memory_s = 60.0;  // forgetting time of the regression, s
  double heat_gain_adapt_s = 0.3;    // time constant of the gain's move to the regression, s
  double heat_gain_dead_zone = 0.03;  // |k - 1| below this reads as the model's own h
  // Ticks from a command to the measurement that first sees it: the PWM of the next tick plus
  // the host's rig-like computation delay (a board: its PWM tick and ADC averaging, ~1.5).
  double heat_gain_lag_ticks = 2.0;
  // The latent heat the model lacks (eq 1's L deps/dt) slows the wire's transformation like a
  // larger heat loss: the observer regresses the gap on the latent heat's sensitivity dT/dL too,
  // with a ridge prior worth a spread of it of this much (K/J), so that k is not given it (0 = off).
  double heat_gain_latent_spread = 0.07;
  // The lag guard (a): in a hold, the measured position's move over ~0.4 s (two low-passes,
  // 0.2 s and 0.6 s) beyond this, towards the model wire, marks a lag: d does not take it
  // (0 = off).
  double lag_guard_mm = 0.002;
  // The heating curve's shift (b): time constant of moving d into it, s (0 = off).
  double curve_shift_tau_s = 1.0;
  // The re-approach (c): a hold the wire stays above by more than this (mm) for 3.5 s at rest
  // on the heating branch is approached again from its cooling loop, and re-heated once the
  // wire is back at it if the next move is up (0 = off).
  double reapproach_mm = 0.02;
  // (d) A hold reached by a move down on the cooling branch (which never raises the wire), with
  // an offset above this (mm) when the move started, is approached from above: the model wire
  // is not cooled further once the wire, extrapolated 1.6 s ahead at its rate, is at the hold
  // (0 = off).
  double stale_offset_mm = 0.1;

  const char* check() const {
    if (!(dt > 0.0 && dt <= 1.0)) return "dt must be in 0..1";
    if (!(v_max > 0.0 && v_max <= 5.0)) return "v_max must be in 0..5";
    if (!(grid_s >= dt && grid_s <= 5.0)) return "grid_s must be in dt..5";
    if (!(horizon_s >= grid_s && horizon_s / grid_s <= 32.0)) return "horizon_s must be in grid_s..32 grid_s";
    if (!(steps_per_tick >= 1)) return "steps_per_tick must be >= 1";
    if (!SMA_PREVIEW_HOST_OPTIONS && (plan_in_step || commit_switch))
      return "plan_in_step and commit_switch need SMA_PREVIEW_HOST_OPTIONS 1";
    if (!(track_s >= dt && track_s <= 10.0)) return "track_s must be in dt..10";
    if (!(offset_tau_s > 0.0 && offset_tau_s <= 100.0)) return "offset_tau_s must be in 0..100";
    if (!(cool_weight >= 0.0 && cool_weight <= 100.0)) return "cool_weight must be in 0..100";
    if (!(deadband_mm >= 0.0 && deadband_mm < 1.0)) return "deadband_mm must be in 0..1";
    if (!(switch_margin_mm >= 0.0 && switch_margin_mm < 1.0)) return "switch_margin_mm must be in 0..1";
    if (!(lookahead_s >= 0.0 && lookahead_s <= 64.0)) return "lookahead_s must be in 0..64";
    if (!(rise_margin_mm >= 0.0 && rise_margin_mm <= 0.1)) return "rise_margin_mm must be in 0..0.1";
    if (!(ride_margin_mm >= 0.0 && ride_margin_mm <= 0.1)) return "ride_margin_mm must be in 0..0.1";
    if (!(v_supply >= v_max && v_supply <= 50.0)) return "v_supply must be in v_max..50";
    if (!(heat_gain_memory_s == 0.0 || (heat_gain_memory_s >= 1.0 && heat_gain_memory_s <= 1000.0)))
      return "heat_gain_memory_s must be 0 or in 1..1000";
    if (!(heat_gain_dead_zone >= 0.0 && heat_gain_dead_zone <= 0.2)) return "heat_gain_dead_zone must be in 0..0.2";
    if (!(heat_gain_lag_ticks >= 0.0 && heat_gain_lag_ticks <= 10.0)) return "heat_gain_lag_ticks must be in 0..10";
    if (!(heat_gain_adapt_s >= 0.1 && heat_gain_adapt_s <= 1000.0)) return "heat_gain_adapt_s must be in 0.1..1000";
    if (!(heat_gain_latent_spread >= 0.0 && heat_gain_latent_spread <= 10.0))
      return "heat_gain_latent_spread must be in 0..10";
    if (!(lag_guard_mm >= 0.0 && lag_guard_mm <= 0.1)) return "lag_guard_mm must be in 0..0.1";
    if (!(curve_shift_tau_s == 0.0 || (curve_shift_tau_s >= dt && curve_shift_tau_s <= 100.0)))
      return "curve_shift_tau_s must be 0 or in dt..100";
    if (!(reapproach_mm >= 0.0 && reapproach_mm <= 0.5)) return "reapproach_mm must be in 0..0.5";
    if (!(stale_offset_mm >= 0.0 && stale_offset_mm <= 1.0)) return "stale_offset_mm must be in 0..1";
    return nullptr;
  }
};

// The controller on model boxes of its owner: the thermal model (eqs 1, 17) of a board's inverse
// model (sma/controller.hpp), which must outlive it, and a copy of its phase curves (the preview
// moves its heating curve by the learned shift, the inverse model's stays).
template <class T>
class PreviewCore {
 public:
  static constexpr uint8_t kMaxGrid = 32;  // the default 16 s horizon on a 0.5 s grid
  static constexpr uint8_t kCandidates = 7;
  static constexpr uint8_t kNever = 255;  // candidate: switch only when the reference turns
  static constexpr uint8_t kObserveTicks = 10;  // ticks between samples of the heat-loss observer
  static constexpr uint8_t kFar = 4;  // knots of the look beyond the horizon (lookahead_s)
  static_assert(kCandidates >= kFar + 2, "step_peak: one step in each of kFar candidates after the second");
  // The re-approach's re-heat (reheat_): none; the wire cooling down its loop to the hold; the
  // wire back at the hold, the re-heat due if the reference's next move is up.
  static constexpr uint8_t kReheatNone = 0, kReheatCooling = 1, kReheatDue = 2;

  // curves and thermal: built from p and fx. model_valid: the caller's verdict on p and fx
  // (Params::check, Effects::check), e.g. a board's Controller built from the same set (on AVR a
  // second caller of check() keeps its messages in RAM: ~600 B).
  PreviewCore(const PhaseCurves<T>& curves, const Thermal<T>& thermal, const Params& p, const Effects& fx,
              const PreviewConfig& cfg, bool model_valid)
      : curves_(curves),
        thermal_(thermal),
        mech_(p),
        wire_step_(thermal_, p, cfg.dt, fx),
        grid_step_(p, cfg.grid_s, fx),
        est_(curves_, from_double<T>(fx.ambient_C(p.T_amb)), T(0)),
        sim_h_(est_),  // (start_sim() copies est_ into it before every plan)
        v_max_(from_double<T>(cfg.v_max)),
        inv_dt_(from_double<T>(1.0 / cfg.dt)),
        inv_track_(from_double<T>(1.0 / cfg.track_s)),
        d_alpha_(from_double<T>(1.0 - decay_factor(cfg.dt / cfg.offset_tau_s))),
        cool_w_(from_double<T>(cfg.cool_weight)),
        switch_margin_(from_double<T>(100.0 * cfg.switch_margin_mm * cfg.switch_margin_mm)),
        inv_n_(from_double<T>(1.0 / static_cast<int>(cfg.horizon_s / cfg.grid_s + 0.5))),
        deadband_(from_double<T>(cfg.deadband_mm)),
        n_grid_(static_cast<uint8_t>(cfg.horizon_s / cfg.grid_s + 0.5)),
        valid_(model_valid && cfg.check() == nullptr),
        plan_in_step_(cfg.plan_in_step),
        commit_switch_(cfg.commit_switch),
        steps_per_tick_(cfg.steps_per_tick),
        pwm_top_(cfg.pwm_top),
        track_(from_double<T>(cfg.track_s)),
        track_next_(from_double<T>(cfg.track_s + cfg.dt)),
        dt_(cfg.dt),
        grid_s_(cfg.grid_s),
        v_supply_(cfg.v_supply),
        grid_ticks_(from_double<T>(cfg.grid_s / cfg.dt)),
        heat_(p, cfg.dt, kObserveTicks * cfg.dt, cfg.heat_gain_memory_s > 0.0 ? cfg.heat_gain_memory_s : 1.0,
              cfg.heat_gain_adapt_s, cfg.heat_gain_dead_zone, cfg.heat_gain_latent_spread, fx.latent_heat_J),
        observe_heat_(cfg.heat_gain_memory_s > 0.0),
        lag_ticks_(from_double<T>(cfg.heat_gain_lag_ticks)),
        far_step_s_(cfg.lookahead_s / kFar),
        rise_margin_(from_double<T>(cfg.rise_margin_mm)),
        ride_margin_(from_double<T>(cfg.ride_margin_mm / p.g)),
        min_hold_(static_cast<uint8_t>(2.0 / cfg.grid_s + 0.999)),
        look_far_(cfg.lookahead_s > 0.0),
        lag_guard_(from_double<T>(cfg.lag_guard_mm)),
        a_fast_(from_double<T>(cfg.dt / 0.2)),
        a_slow_(from_double<T>(cfg.dt / 0.6)),
        shift_gain_(from_double<T>(cfg.curve_shift_tau_s > 0.0 ? cfg.dt / cfg.curve_shift_tau_s : 0.0)),
        shift_after_(static_cast<uint16_t>(1.0 / cfg.dt + 0.5)),
        reapproach_(from_double<T>(cfg.reapproach_mm)),
        stale_offset_(from_double<T>(cfg.stale_offset_mm)),
        reapproach_after_(static_cast<uint16_t>(3.5 / cfg.dt + 0.5)) {
    // Candidates: "when the reference turns" first, "now" last; "now" must win outright.
    const double sw[kCandidates] = {-1.0, 7.0, 4.0, 2.0, 1.0, 0.5, 0.0};
    for (uint8_t k = 0; k < kCandidates; ++k) {
      const double n = sw[k] / cfg.grid_s + 0.5;
      switch_at_[k] = sw[k] < 0.0 || n >= 254.0 ? kNever : static_cast<uint8_t>(n);
    }
    reset(from_double<T>(fx.ambient_C(p.T_amb)), T(0));
  }
  PreviewCore(const PreviewCore&) = delete;  // the hysteresis points into curves_
  PreviewCore& operator=(const PreviewCore&) = delete;

  bool valid() const { return valid_; }

  // Restart at rest: wire at T0 with fraction eps0 (e.g. from a measurement), heating branch.
  SMA_PREVIEW_NOINLINE void reset(T T0, T eps0) {
    wire_pending_ = false;
    sample_due_ = false;
    est_.reset(T0, eps0);
    T_est_ = T0;
    T_prev_ = T0;
    eps_est_ = est_.eps();
    deps_ = T(0);
    d_ = T(0);
    // The learned heating-curve shift is kept: it belongs to the wire, not to this start.
    x_init_ = false;
    held_ticks_ = 0;
    d_step_ = T(0);
    shift_due_ = false;
    above_ticks_ = 0;
    reapproach_due_ = false;
    reheat_ = kReheatNone;
    switch_due_ = 0;
    heating_ = true;
    moved_with_ = true;
    ref_extreme_ = mech_.displacement(eps_est_);
    have_ref_ = false;
    v_ = T(0);
    lead_ready_ = false;
    voltages_ready_ = false;
    down_next_ = false;
    restart_plan();
  }

  // Restart at the measured displacement (mm): the model wire at T0 with the fraction the
  // measurement implies (eq 14) - a board entering this controller from another one.
  void start(T T0, T measured) {
    reset(T0, is_finite(measured) ? fraction(measured) : T(0));
  }
  // A new reference (its clock restarted): the plan in progress sampled the old one.
  void new_reference() {
    have_ref_ = false;
    lead_ready_ = false;
    voltages_ready_ = false;
    switch_due_ = 0;
    down_next_ = false;
    restart_plan();
  }
  // The trade-off setting (PreviewConfig::cool_weight, 0..100); out of range: unchanged.
  bool set_cool_weight(double w) {
    if (!(w >= 0.0 && w <= 100.0)) return false;
    cool_w_ = from_double<T>(w);
    return true;
  }

  // One tick: reference now, its future (future(tau_s) = reference tau_s ahead) and the
  // measured displacement -> voltage across the wire, 0..V_max. NaN in gives 0 V.
  template <class Future>
  T step(T ref, const Future& future, T measured) {
    prepare_next_tick();  // a caller that did not call it between ticks
    if (!valid_ || !is_finite(ref) || !is_finite(measured)) return hold_off();
    ref = on_stroke(ref);
    ref_now_ = ref;
    update_offset(ref, measured);
    if (observing() && ++observe_tick_ >= kObserveTicks) {
      // A heat-loss sample: the tick keeps what it saw, prepare_next_tick() judges it.
      observe_tick_ = 0;
      sample_due_ = true;
      due_x_ = measured;
      due_T_ = T_est_;
      due_T_prev_ = T_prev_;
    }
    follow_reference(ref);
    if (switch_due_ > 0 && --switch_due_ == 0) switch_branch();
    ++elapsed_ticks_;
    if (plans_in_step())
      for (uint8_t k = 0; k < steps_per_tick_; ++k)
        if (plan_step(future)) break;
    // The voltage: this branch's inverse of the reference track_s ahead. Planning between
    // ticks, plan_step() has computed it for both branches already (prepare_voltages: no
    // reference and no inverse left in the tick), unless the hold's verdict changed since.
    T v;
    if (voltages_ready_ && !plans_in_step() && cap_on_ == pre_cap_on_ && cap_ref_ == pre_cap_ref_ &&
        cap_T_ == pre_cap_T_) {
      v = v_branch_[heating_ ? 1 : 0];
    } else {
      T r_lead = lead_ready_ && !plans_in_step() ? lead_ : ahead(future, track_);
      if (!is_finite(r_lead)) r_lead = ref;
      v = branch_voltage(heating_, on_stroke(r_lead));
    }
    lead_ready_ = false;
    voltages_ready_ = false;
    v_ = v;
    // The model wire's temperature follows the commanded voltage now (the latch watches it);
    // its hysteresis after the output is written (prepare_next_tick).
    model_wire_heat(v, deps_);
    wire_pending_ = true;
    return v_;
  }

  // Between ticks, after the output is written: the model wire's hysteresis on the tick's
  // temperature, and the cooling loop the next tick would build (a reversal of the reference
  // on the heating branch; the loop in use on the cooling branch): work the next tick would
  // otherwise do inside the control section. Changes no number; step() and plan_step() call it
  // first if the caller did not.
  SMA_PREVIEW_NOINLINE void prepare_next_tick() {
    if (SMA_PREVIEW_HEAT_LOSS && sample_due_) take_heat_sample();  // before the hysteresis moves on
    if (!wire_pending_) return;
    wire_pending_ = false;
    sensitivity_tick();
    const T eps_new = est_.update(T_est_);
    deps_ = (eps_new - eps_est_) * inv_dt_;
    eps_est_ = eps_new;
    est_.prepare_cooling();
  }

  // One grid step of the plan in progress (bounded work: one thermal step, one hysteresis
  // update, at most one future() call); true when it completed a plan (and decided). The
  // first call after a tick samples the next tick's lead reference instead (so the tick itself
  // evaluates no future reference), and runs the heat-loss sample the tick took if any. With
  // plan_in_step = false the board calls it between ticks, as often as its idle time allows;
  // future(tau) is then the reference tau seconds after the last step()'s tick. Not from an
  // interrupt that can preempt step().
  template <class Future>
  bool plan_step(const Future& future) {
    if (!valid_) return false;
    prepare_next_tick();
    if (!plans_in_step() && !lead_ready_) {  // first call after a tick: the next tick's lead sample (track_s ahead)
      lead_ = ahead(future, track_next_);
      lead_ready_ = true;
      // A heat-loss sample of the last tick with it (a lead sample is cheap; the grid steps of
      // the other calls keep their pace).
      if (SMA_PREVIEW_HEAT_LOSS && obs_pending_) observe_heat();
      if (shift_due_) learn_shift();
      if (reapproach_due_) reapproach();
      prepare_voltages();
      return false;
    }
    if (SMA_PREVIEW_HEAT_LOSS && obs_pending_) observe_heat();  // in-step planning
    if (shift_due_) learn_shift();
    if (reapproach_due_) {
      reapproach();
      if (lead_ready_) prepare_voltages();
      return false;
    }
    if (reheat_ == kReheatDue && reheat_now()) {
      switch_branch();
      if (lead_ready_) prepare_voltages();
      return false;
    }
    // The heating reached the peak of a hold approached on the rise: cool (here, not in the
    // tick: the switch builds the loop).
    if (heating_ && capped(ref_now_) && at_cap(T_est_)) {
      switch_branch();
      if (lead_ready_) prepare_voltages();
      return false;
    }
    if (j_ >= n_grid_ && next_candidate()) {
      if (lead_ready_) prepare_voltages();  // the new plan's verdict on the hold
      return true;
    }
    sim_step(future);
    return false;
  }

  T voltage() const { return v_; }
  T wire_temperature() const { return T_est_; }
  T offset() const { return d_; }                 // measured - model position, mm
  bool heating() const { return heating_; }       // the branch the controller drives
  uint16_t plans() const { return plans_; }       // completed plans (tests, telemetry)
  T heat_loss_gain() const { return heat_.gain(); }  // the wire's heat loss against the model's
  T heating_shift() const { return shift_; }  // K: the wire at T is where the model's curve has T + shift

 private:
  T hold_off() {
    v_ = T(0);
    model_wire_heat(T(0), T(0));
    sensitivity_tick();
    eps_est_ = est_.update(T_est_);
    return v_;
  }

  bool observing() const { return SMA_PREVIEW_HEAT_LOSS && observe_heat_; }
  bool plans_in_step() const { return SMA_PREVIEW_HOST_OPTIONS && plan_in_step_; }

  // Integral action: the offset d between the wire and the model wire (a low-pass, offset_tau_s),
  // except for a lag (lag_guard_mm). And whether this tick may move d into the heating curve's
  // shift (learn_shift, between ticks): in a hold of >= 1 s, the wire and the model wire at rest.
  void update_offset(T ref, T measured) {
    if (!x_init_) {
      x_fast_ = x_slow_ = measured;
      x_init_ = true;
    }
    x_fast_ = low_pass(x_fast_, a_fast_, measured);
    x_slow_ = low_pass(x_slow_, a_slow_, measured);
    if (apart(ref, held_ref_)) {
      held_ref_ = ref;
      held_ticks_ = 0;
      d_step_ = d_;
    } else if (held_ticks_ < 60000) {
      ++held_ticks_;
    }
    const T moving = x_fast_ - x_slow_;  // ~ the position's rate x 0.4 s
    const T innovation = (measured - mech_.displacement(eps_est_)) - d_;
    // A lag: in a hold, the wire moves and the innovation points behind its move (it is still
    // on its way to where the model wire already is).
    const bool lag = lag_guard_ > T(0) && held_ticks_ > 0 && abs(moving) > lag_guard_ && innovation * moving < T(0);
    if (!lag) d_ = d_ + d_alpha_ * innovation;
    // Above the hold, at rest, on the heating branch (which never lowers the wire): count.
    const bool resting = !(abs(moving) > T(0.002));
    const bool over = reapproach_ > T(0) && heating_ && held_ticks_ > 0 && x_fast_ - ref > reapproach_ && resting;
    above_ticks_ = over ? static_cast<uint16_t>(above_ticks_ + 1) : uint16_t(0);
    // A re-approached hold: the wire back at it (within the re-approach's threshold, at rest) on
    // the cooling branch; a heating or a new reference ends it.
    if (reheat_ != kReheatNone && (heating_ || held_ticks_ == 0)) reheat_ = kReheatNone;
    if (reheat_ == kReheatCooling && resting && !(x_fast_ - ref > reapproach_)) reheat_ = kReheatDue;
    if (above_ticks_ > reapproach_after_) {
      above_ticks_ = 0;
      reapproach_due_ = true;
    }
    // At rest: the wire moves < 2 um in 0.4 s, the model wire < 2 um/s.
    shift_due_ = shift_gain_ > T(0) && held_ticks_ > shift_after_ && resting && est_.heating() &&
                 abs(deps_ * mech_.g) < T(0.002);
  }

  // d into the heating curve's shift (eq 15 of the position the model wire would need, against
  // the model wire's temperature, to first order: d over the curve's slope), at the pace
  // curve_shift_tau_s, while the model wire rests on the major heating curve. The model wire is
  // re-anchored there (its temperature kept) and d keeps the measured position.
  SMA_PREVIEW_NOINLINE void learn_shift() {
    shift_due_ = false;
    const T slope = heating_slope();
    if (!(slope > T(0.005))) return;  // < 5 um/K: the position does not see the temperature
    const T dshift = shift_gain_ * d_ / slope;
    shift_ = shift_ + dshift;
    curves_.shift_heating(dshift);
    reanchor_heating(T_est_);
  }

  // The model wire re-anchored on the (major) heating curve at Tn, its loop memory reset there;
  // the offset d keeps the measured position.
  SMA_PREVIEW_NOINLINE void reanchor_heating(T Tn) {
    const T x_old = mech_.displacement(eps_est_);
    const T T_below = Tn - T(0.01);
    est_.reset(T_below, curves_.eps_heat(T_below));
    eps_est_ = est_.update(Tn);
    d_ = d_ + (x_old - mech_.displacement(eps_est_));
  }

  // The future reference tau seconds ahead. (Out of line: one copy of the board's reference for
  // the tick's lead, the plan's samples and the look beyond the horizon.)
  template <class Future>
  SMA_PREVIEW_NOINLINE static T ahead(const Future& future, T tau) {
    return future(tau);
  }

  // (c) The wire overshot the hold on the heating branch and rode the rise of the loop it opened
  // (eqs 5-6): only a cooling down that loop brings it back. The wire's fraction (the
  // measurement low-passed, eq 14) is the top of its rise; the model's rise j at the model wire's
  // peak (eqs 5-6) puts the wire's peak, on its heating curve, at eps_w - j. The model's heating
  // curve has that fraction at heat_temperature(eps_w - j), the model wire was at T_est_: the
  // difference is the heating curve's shift (eq 15; clamped to 5 K). The model wire is
  // re-anchored at the wire's peak (its loop's rise then ends at eps_w) and the branch turns to
  // cooling, down the loop to the hold (eq 16).
  SMA_PREVIEW_NOINLINE void reapproach() {
    reapproach_due_ = false;
    const T eps_w = fraction(x_fast_);
    const T eps_peak = max(eps_w - (curves_.start_loop(T_est_, eps_w, true).top - eps_w), T(0));
    if (shift_gain_ > T(0)) {
      const T dshift = clamp(curves_.heat_temperature(eps_peak) - T_est_, T(-5), T(5));
      shift_ = shift_ + dshift;
      curves_.shift_heating(dshift);
    }
    est_.reset(T_est_, eps_peak);
    eps_est_ = est_.eps();
    d_ = x_fast_ - mech_.displacement(eps_est_);
    heating_ = false;
    moved_with_ = false;
    ref_extreme_ = ref_now_;
    switch_due_ = 0;
    reheat_ = kReheatCooling;
    est_.prepare_cooling();
    restart_plan();
  }

  // The re-approach's re-heat. Back at the hold on its loop's cooling curve (eq 11), the wire
  // is below the peak of the loop it cooled down; a heating up to that peak moves nothing (the
  // heating branch follows eq 15 only from where it meets the heating curve: return-point
  // memory), so heating now costs no position and puts the wire on its heating curve before
  // the next move up starts. Left to the plan, that heating is a tie between candidates (each
  // leaves the position where it is), which the plan breaks for the latest switch: the move up
  // then starts inside a heating from the cooled wire, and which candidate is the latest flips
  // on a hundredth of a kelvin of the model (docs/control.md section 26). Here it starts when
  // the wire is back at the hold, a time that moves with the model continuously. The next move
  // is read from the last plan's reference samples (r_, within ~a plan's age); none within the
  // horizon: wait; down: the cooling branch stays (it is the move's own branch).
  bool reheat_now() {
    if (plans_ == 0) return false;  // r_ not sampled yet
    for (uint8_t e = 0; e < n_grid_; ++e)
      if (apart(r_[e], ref_now_)) {
        reheat_ = kReheatNone;
        return r_[e] > ref_now_;
      }
    return false;
  }

  // (d) A position offset is right where it was measured: between two points of cooling curves
  // that are not the model's (a fit's eq 11 top, T_MSi, T_MF, and a heat loss that is not linear
  // in the temperature rise, which the observer's gain learned on the heating curve does not
  // follow) it changes, and a large one taken along a move down drives the model wire past the
  // hold; the wire follows onto its cooling curve (eq 11), where the cooling branch cannot raise
  // it. So after a move down that started with a large offset, on the cooling curve past the
  // rise (eqs 5-6, where cooling would lift the wire), the model wire stops cooling once the wire
  // is at the hold (the measurement's two low-passes: x_fast + 4 (x_fast - x_slow) is ~1.6 s
  // ahead at its rate, the wire's lag behind its command); d then settles at the hold's own value
  // and the cooling resumes if the wire rests above.
  bool stale_cooling() const {
    return stale_offset_ > T(0) && falling_ && held_ticks_ > 0 && abs(d_step_) > stale_offset_ &&
           T_est_ < est_.loop().T_ii && !(x_fast_ + T(4) * (x_fast_ - x_slow_) > ref_now_);
  }

  // The voltage that drives the model wire onto branch heat's temperature for lead reference r
  // (mm): eq 15 or 16 (branch_temperature), then eq 17 with the first-order pull track_s.
  SMA_PREVIEW_NOINLINE T branch_voltage(bool heat, T r) {
    // (Climbing: a plain compare, not above()'s deadband: this runs between the Mega's ticks,
    // where the plan passes have ~1.3 k cycles to spare at their worst.)
    T T_cmd = branch_temperature(heat, est_, T_est_, r, !heat && r > ref_now_);
    if (!heat && stale_cooling()) T_cmd = max(T_cmd, T_est_);
    const T slope = (T_cmd - T_est_) * inv_track_;
    // Eq 17, with the observed heat loss: k^ G (T - T_a) = G (T - T_a) + C (extra slope).
    const T extra = observing() ? loss_rate_ * (T_est_ - thermal_.T_a) : T(0);
    T v = min(thermal_.voltage_for(T_est_, slope + extra, eps_est_, deps_), v_max_);
    if (!is_finite(v)) v = T(0);
    if (!heat && pwm_top_ > 0 && T_est_ > est_.loop().T_MSi) v = pwm_level_below(v);  // loop(): prepared above
    return v;
  }

  // Between ticks, after the lead sample: the next tick's voltage on either branch (it may
  // switch when the reference turns), on the model wire the tick will start from and the offset
  // of the last tick (a tick older than in the tick itself: 10 ms against its offset_tau_s).
  void prepare_voltages() {
    voltages_ready_ = false;
    if (!is_finite(lead_)) return;  // the tick falls back on its reference now
    const T r = on_stroke(lead_);
    v_branch_[0] = branch_voltage(false, r);
    v_branch_[1] = branch_voltage(true, r);
    pre_cap_on_ = cap_on_;
    pre_cap_ref_ = cap_ref_;
    pre_cap_T_ = cap_T_;
    voltages_ready_ = true;
  }

  // One tick of the model wire's temperature under voltage v (eq 1, with the observed heat loss
  // k^ G).
  void model_wire_heat(T v, T deps) {
    T_prev_ = T_est_;
    T next = wire_step_(T_est_, v, eps_est_, deps * wire_step_.dt);
    if (observing()) next = next - heat_.loss_correction() * (T_est_ - thermal_.T_a);
    T_est_ = next;
  }
  // The observer's sensitivity along that tick, between ticks (prepare_next_tick(); hold_off()
  // at once): only the samples and the re-anchoring read it, both in plan_step() after
  // prepare_next_tick(). Two multiplies less in the control section. (A reset() between the
  // tick and prepare_next_tick() drops that tick's step of S: the model wire restarts anyway.)
  SMA_PREVIEW_NOINLINE void sensitivity_tick() {
    if (observing()) heat_.tick(T_est_ - thermal_.T_a, deps_);
  }

  // The highest PWM level at or below v (the heater's duty = (V / v_supply)^2). A hundredth of
  // a level of slack: a wire held at a level's own steady state stays on that level instead of
  // stepping down a level whenever the scalar's rounding lands just below it.
  T pwm_level_below(T v) const {
    const double x = to_double(v) / v_supply_, top = pwm_top_;
    // (x >= 0 and finite: branch_voltage clamps v to 0..v_max; the truncation is floor's value.)
    const double n = static_cast<double>(static_cast<long>(x * x * top + 0.01));
    return from_double<T>(v_supply_ * ::sqrt(n / top));
  }

  // The position's slope (mm/K) on the heating curve (eq 4) at the model wire; 0 where the model
  // wire is off that curve (a flat stage) or the curve is flat.
  T heating_slope() const {
    const T Tw = T_est_;
    if (abs(curves_.eps_heat(Tw) - eps_est_) > T(0.002)) return T(0);
    return mech_.g * (curves_.eps_heat(Tw + T(0.5)) - curves_.eps_heat(Tw - T(0.5)));
  }

  // The first part of a heat-loss sample the tick took (due_x_, due_T_then_; cheap, between
  // ticks on a board, on the tick's model wire fraction): is it a sample. The rest (curves,
  // regression, re-anchoring) runs in plan_step().
  void take_heat_sample() {
    sample_due_ = false;
    const T x_model = mech_.displacement(eps_est_);
    const T x_wire = x_model + d_;  // the measurement low-passed (the offset estimate's filter)
    const bool rising = x_wire - obs_meas_ > T(0.001) && x_model - obs_model_ > T(0.001);
    obs_meas_ = x_wire;
    obs_model_ = x_model;
    // Only while both wires transform on the heating curve: the position then says the wire's
    // temperature now. (After a peak it keeps the peak's; on a cooling loop it depends on where
    // each wire reversed.)
    if (!rising || !est_.heating()) return;
    obs_pending_ = true;
    obs_x_ = due_x_;
    // The measurement sees the commands of heat_gain_lag_ticks ago: the model wire as it was
    // then (first order in its last step), else a heating transient reads as a gap.
    obs_T_then_ = due_T_ - lag_ticks_ * (due_T_ - due_T_prev_);
  }

  // One sample of the heat-loss observer: the wire's temperature the measured position gives on
  // the heating curve (eq 15 of the fraction, eq 14), minus the model wire's (at most 10 K apart).
  SMA_PREVIEW_NOINLINE void observe_heat() {
    obs_pending_ = false;
    const T slope = heating_slope();
    if (!(abs(slope) > T(0.005))) return;  // < 5 um/K: the position does not see the temperature
    // (On the model's own heating curve: the shift learned below would otherwise move the
    // regression's intercept under it.)
    const T gap = clamp(curves_.heat_temperature(fraction(obs_x_)) + shift_ - obs_T_then_, T(-10), T(10));
    const T k_before = heat_.gain();
    heat_.add(gap, slope);
    loss_rate_ = heat_.loss_correction() * inv_dt_;
    // A new gain changes the model wire's past: its temperature now is the one the new gain
    // gives, to first order T + dk S. Both wires are on the heating curve (eq 4, no loop memory),
    // so the model wire is re-anchored there, and the offset keeps the measured position.
    const T T_new = T_est_ + (heat_.gain() - k_before) * heat_.sensitivity();
    if (T_new != T_est_) {
      reanchor_heating(T_new);
      T_prev_ = T_prev_ + (T_new - T_est_);
      T_est_ = T_new;
      obs_model_ = mech_.displacement(eps_est_);
    }
  }

  // The branch follows the reference once it has moved with it: a turn against the branch
  // (beyond the deadband, from the last extreme) switches it.
  void follow_reference(T ref) {
    if (!have_ref_) {
      ref_extreme_ = ref;
      ref_prev_ = ref;
      have_ref_ = true;
    }
    if (below(ref, ref_prev_)) falling_ = true;
    if (above(ref, ref_prev_)) falling_ = false;
    ref_prev_ = ref;
    if (heating_ ? ref > ref_extreme_ : ref < ref_extreme_) {
      if (apart(ref, ref_extreme_)) moved_with_ = true;
      ref_extreme_ = ref;
    }
    if (moved_with_ && (heating_ ? below(ref, ref_extreme_) : above(ref, ref_extreme_))) {
      heating_ = !heating_;
      ref_extreme_ = ref;
      moved_with_ = true;  // the reference already moves with the new branch
      switch_due_ = 0;
      restart_plan();
    }
  }

  // The temperature the policy drives the wire to on a branch (eq 15 heating, eq 16 cooling on
  // the loop the hysteresis h would follow), never against the branch, for reference r (mm).
  // The cooling loop is built once (prepare_cooling): the reversal's update() and the PWM
  // rounding reuse it (three builds of eqs 5-11 on one tick otherwise).
  // `rising`: the reference climbs (r above the reference before it).
  T branch_temperature(bool heat, Hysteresis<T>& h, T Tw, T r, bool rising) const {
    const T eps_t = fraction(r - d_);  // eq 14, with the offset
    if (heat) return max(Tw, capped(r) ? cap_T_ + T(0.1) : curves_.heat_temperature(eps_t));
    const CoolingLoop<T>& L = h.prepare_cooling();
    // Still above the end of the rise and asked to stay or go up, to where the rise reaches:
    // ride the rise (eqs 5-6). At or past its top (eq 5) the wire can go no higher on this
    // loop: it is cooled on through the flat stage (eqs 7-10, the fraction held at the top) to
    // T_MSi (eq 16), so that it follows the reference down at once instead of waiting there for
    // the flat stage. Not before a move down (take the rise now, and hold on the cooling curve).
    // (Both to within PreviewConfig::ride_margin_mm.)
    if (Tw > L.T_ii && !capped(r)) {
      const T e_m = eps_t + ride_margin_;
      if (!((rising ? e_m : eps_t) < h.eps()) && e_m < L.top) return min(Tw, curves_.rise_temperature(L, eps_t));
    }
    return min(Tw, curves_.cool_temperature(L, eps_t));
  }

  // (A plan's switch runs between ticks: the cooling loop it leads to is built there, not in
  // the next tick.)
  void switch_branch() {
    heating_ = !heating_;
    if (!heating_) est_.prepare_cooling();
    moved_with_ = false;
    ref_extreme_ = ref_now_;
    switch_due_ = 0;
    restart_plan();
  }

  SMA_PREVIEW_NOINLINE void restart_plan() {
    // The last plan's verdict on the hold, for the tick and every candidate of this plan.
    cap_on_ = down_next_;
    cap_ref_ = hold_ref_;
    cap_T_ = peak_T_;
    cand_ = 0;
    j_ = 0;
    elapsed_ticks_ = 0;
    best_cost_ = T(-1);
    best_ = 0;
    start_sim();
  }
  SMA_PREVIEW_NOINLINE void start_sim() {
    sim_T_ = T_est_;
    sim_h_ = est_;
    sim_heat_ = heating_;
    sim_moved_ = moved_with_;
    sim_ext_ = ref_extreme_;
    sim_fall_ = falling_;
    cost_ = T(0);
  }

  // The simulation of candidate cand_ is complete: score it; after the last candidate decide
  // and start the next plan (true), else start the next candidate (false).
  bool next_candidate() {
    // Ties keep the later switch; and switching at all (any timed candidate) must beat
    // following the reference by the margin: a switch that buys little is not made
    // (e.g. heating a wire on a flat stage, which moves nothing yet).
    if (switch_at_[cand_] == kNever) natural_cost_ = cost_;
    cost_at_[cand_] = cost_;
    if (best_cost_ < T(0) || cost_ < best_cost_) {
      best_cost_ = cost_;
      best_ = cand_;
    }
    if (++cand_ >= kCandidates) {
      ++plans_;
      // commit_switch: a timed switch that wins is kept as a commitment (due when its time
      // comes, unless a later plan prefers otherwise). Without it the heating stops once its
      // best time (switch_ticks, between the candidates) has come while the plan ran; a later
      // one is left to the next plan. The heating restarts only when "now" wins outright: a
      // re-heat of a wire on its rise opens a new loop with a rise of its own under model.md's
      // literal reading (plant B), which the model's return-point memory does not predict.
      switch_due_ = 0;
      const bool wins = switch_at_[best_] != kNever && best_cost_ < natural_cost_ - switch_margin_ && !idle_heat();
      if (SMA_PREVIEW_HOST_OPTIONS && commit_switch_ && wins) {
        const long due = static_cast<long>(switch_at_[best_] * grid_s_ / dt_ + 0.5) - elapsed_ticks_;
        if (due <= 0) switch_branch();
        else switch_due_ = static_cast<uint16_t>(due);
      } else if (wins && (heating_ ? switch_ticks() <= elapsed_ticks_ : switch_at_[best_] == 0)) {
        switch_branch();
      }
      restart_plan();
      return true;
    }
    j_ = 0;
    start_sim();
    return false;
  }

  // A heating that cannot serve the reference: on a hold approached on the rise whose next move
  // is down, the wire at it or above (not below it by more than reapproach_mm, the band in which
  // a re-approached wire is back at its hold). Heating only raises the fraction (eq 4), so it
  // moves the wire neither to the hold nor towards the move; what the plan sees in it is a new
  // loop from the peak (eqs 5-11), which the model predicts where its cooling curve is not the
  // wire's. Left to the switch margin, that verdict flips on a model change far below what a fit
  // resolves, and the re-heat it buys holds the wire at its peak when the move comes.
  bool idle_heat() const { return !heating_ && capped(ref_now_) && !(x_fast_ < ref_now_ - reapproach_); }

  // The best switch time between the candidates, in ticks from the plan's start: the vertex of
  // the parabola through the cheapest candidate's cost and its two neighbours' in time,
  // clamped between the neighbours. Near its minimum the cost is smooth in the time the
  // heating stops: earlier stops it at a lower peak T_i, whose minor-loop rise j_i (eqs 5-6)
  // ends short of the top; later at a higher one, whose rise ends past it. So the switch
  // moves with the model instead of waiting for "now" to win outright, and a candidate that
  // wins while its time passes ("0.5 s" in plan after plan: a plan is ~0.56 s old when it
  // decides) switches once its time has come. (In double: cost differences times squared
  // grid steps of up to 7 s overflow Q16.16.)
  long switch_ticks() const {
    const uint8_t b = best_;
    double t = switch_at_[b];
    // Neighbours in time: the next candidate is the earlier one; the first is "never".
    if (b >= 2 && b + 1 < kCandidates) {
      const double t0 = switch_at_[b + 1], t2 = switch_at_[b - 1];
      const double c0 = to_double(cost_at_[b + 1]), c1 = to_double(cost_at_[b]), c2 = to_double(cost_at_[b - 1]);
      const double p = (t - t0) * (c1 - c2), q = (t - t2) * (c1 - c0);
      const double den = p - q;
      if (den < 0.0) {  // convex (b is the cheapest of the three); flat: stay at b
        const double v = t - 0.5 * ((t - t0) * p - (t - t2) * q) / den;
        t = v < t0 ? t0 : v > t2 ? t2 : v;
      }
    }
    return static_cast<long>(t * grid_s_ / dt_ + 0.5);
  }

  // A position (mm) clamped to the stroke; its fraction (eq 14, clamped to 0..1). (Out of line:
  // one copy each for the tick, the plan and the observer.)
  SMA_PREVIEW_NOINLINE T on_stroke(T x) const { return clamp(x, T(0), mech_.g); }
  SMA_PREVIEW_NOINLINE T fraction(T x) const { return mech_.fraction(x); }

  // References (mm) against the deadband: a move (apart; none: !apart, every reference here is
  // finite), one down (below) or up (above) from b. (Out of line: the tick, the plan and the look
  // share one copy each.)
  SMA_PREVIEW_NOINLINE bool apart(T a, T b) const { return abs(a - b) > deadband_; }
  SMA_PREVIEW_NOINLINE bool below(T a, T b) const { return a < b - deadband_; }
  SMA_PREVIEW_NOINLINE bool above(T a, T b) const { return a > b + deadband_; }

  // Is reference r a hold approached on the rise (its next move is down)?
  bool capped(T r) const { return cap_on_ && !apart(r, cap_ref_); }
  // Heading up to (or at) a hold approached on the rise, below its peak: a cooling that starts
  // here would rise short of the hold (the planned switch waits for the peak).
  bool climbs_to_cap(T r) const { return cap_on_ && !above(r, cap_ref_) && sim_T_ < cap_T_; }
  // The heating has reached the peak whose rise ends at the hold. (It is driven 0.1 K past it:
  // it crosses T_i* at speed instead of creeping up to it.)
  bool at_cap(T Tw) const { return !(Tw < cap_T_); }

  // The first hold (>= 2 s) in the plan's reference whose next move is down (in the plan's
  // samples, else at a knot beyond the horizon), and its peak T_i*: the fixed point
  // T = eq 15 (eps_t - j(T)) whose rise (eqs 5-6) ends at the hold (step_peak).
  // The second candidate, which samples nothing else, does one part per grid step (j_ <= kFar).
  template <class Future>
  void look_far(const Future& future) {
    if (j_ == 0) {
      far_open_ = false;
      down_next_ = false;
      for (uint8_t i = 0, e; i < n_grid_; i = e) {
        for (e = static_cast<uint8_t>(i + 1); e < n_grid_ && !apart(r_[e], r_[i]);) ++e;
        if (e - i < min_hold_) continue;  // not held 2 s
        if (e < n_grid_ && !(r_[e] < r_[i])) continue;
        if (apart(r_[i], hold_ref_)) peak_T_ = T(-1);  // a new hold: start the fixed point again
        hold_ref_ = r_[i];
        down_next_ = e < n_grid_;
        far_open_ = e >= n_grid_;
        break;
      }
    } else if (far_open_) {
      const double tau = n_grid_ * grid_s_ + j_ * far_step_s_ - elapsed_ticks_ * dt_;
      const T r = ahead(future, from_double<T>(tau));
      if (is_finite(r) && apart(r, hold_ref_)) {
        down_next_ = r < hold_ref_;
        far_open_ = false;
      }
    }
    if (j_ == kFar) step_peak();
  }
  // One damped step of that fixed point, kFar + 1 a plan: the second candidate's last look
  // (its verdict known), then the first grid step of each of the next kFar candidates. A step
  // (~15-20 k AVR cycles) is as heavy as a grid step or more: steps on consecutive grid steps
  // made a board's tick (its lead sample and four grid steps) longer than the tick.
  SMA_PREVIEW_NOINLINE void step_peak() {
    if (!(down_next_ || far_open_)) return;
    const T eps_t = fraction(hold_ref_ + rise_margin_ - d_);
    if (peak_T_ < T(0)) peak_T_ = curves_.heat_temperature(eps_t);
    const T eps_i = curves_.eps_heat(peak_T_);
    const T j = curves_.start_loop(peak_T_, eps_i, true).top - eps_i;  // eqs 5-6, clamped at 1
    peak_T_ = T(0.5) * (peak_T_ + curves_.heat_temperature(eps_t - j));
  }

  // One grid step of candidate cand_ (switch at grid index switch_at_[cand_]).
  template <class Future>
  void sim_step(const Future& future) {
    if (cand_ == 0) {  // the first candidate samples the future reference for all of them
      const double tau = (j_ + 1) * grid_s_ - elapsed_ticks_ * dt_;
      const T r = ahead(future, from_double<T>(tau > 0.0 ? tau : 0.0));
      r_[j_] = is_finite(r) ? on_stroke(r) : (j_ ? r_[j_ - 1] : T(0));
    } else if (cand_ == 1 && j_ <= kFar && look_far_) {
      look_far(future);
    } else if (j_ == 0 && cand_ >= 2 && cand_ <= kFar + 1 && look_far_) {
      step_peak();
    }
    const T r = r_[j_];
    if (sim_heat_ && capped(r) && at_cap(sim_T_)) {  // the peak of a hold approached on the rise
      sim_heat_ = false;
      sim_moved_ = false;
      sim_ext_ = r;
    } else if (j_ == switch_at_[cand_] && sim_heat_ == heating_ && !(sim_heat_ && climbs_to_cap(r))) {
      sim_heat_ = !sim_heat_;
      sim_moved_ = false;
      sim_ext_ = r;
    } else {
      if (sim_heat_ ? r > sim_ext_ : r < sim_ext_) {
        if (apart(r, sim_ext_)) sim_moved_ = true;
        sim_ext_ = r;
      }
      if (sim_moved_ && (sim_heat_ ? below(r, sim_ext_) : above(r, sim_ext_))) {
        sim_heat_ = !sim_heat_;
        sim_ext_ = r;
      }
    }
    const T r_before = j_ ? r_[j_ - 1] : ref_now_;
    const bool up = above(r, r_before);
    const T target = branch_temperature(sim_heat_, sim_h_, sim_T_, r, up);
    if (below(r, r_before)) sim_fall_ = true;
    if (up) sim_fall_ = false;
    // Exact limits of eq 1 over one grid step: full power, or none.
    // (the observed heat loss to first order over the grid step: (k^ - 1) G grid_s / C)
    const T loss = observing() ? heat_.loss_correction() * grid_ticks_ * (sim_T_ - thermal_.T_a) : T(0);
    // (No power: eq 1's passive part alone, the same number as grid_step_(sim_T_, 0).)
    const T passive = grid_step_.passive(sim_T_);
    const T hi = passive + grid_step_.heat(v_max_) - loss;
    const T lo = passive - loss;
    sim_T_ = clamp(target, lo, hi);
    // Error in 0.1 mm (Q16.16 keeps its square); e^2 (1 + e^2): errors past 0.1 mm weigh more,
    // so the plan trades a long small error for a short large one the way the max metric does.
    const T e = T(10) * (mech_.displacement(sim_h_.update(sim_T_)) + d_ - r);
    const T e2 = e * e;
    // The mean over the horizon, not the sum: Q16.16 (max 32767) holds it for any error of the
    // stroke (e2 (1 + e2) <= ~8600 at 0.96 mm) and any cool_weight <= 100 on a grid of up to kMaxGrid steps.
    cost_ = cost_ + (sim_fall_ ? cool_w_ : T(1)) * (e2 * (T(1) + e2) * inv_n_);
    ++j_;
  }

  // (The state without an initializer below is set by reset(), which the constructor calls:
  // initializers there would be stores the AVR image makes twice.)
  PhaseCurves<T> curves_;  // a copy: its heating curve carries the learned shift
  const Thermal<T>& thermal_;
  Mechanics<T> mech_;
  WireStep<T> wire_step_;
  ThermalStep<T> grid_step_;
  Hysteresis<T> est_;    // loop memory of the model wire
  Hysteresis<T> sim_h_;  // its copy, walked by the plan
  T v_max_, inv_dt_, inv_track_, d_alpha_, cool_w_;
  T switch_margin_;  // cost units: (0.1 mm)^2, a mean over the horizon's grid steps
  T inv_n_;          // 1 / grid steps of the horizon
  T deadband_;
  uint8_t n_grid_;
  bool valid_;
  // What the tick and the plan read of the PreviewConfig (the rest is folded into the above).
  bool plan_in_step_, commit_switch_;
  uint8_t steps_per_tick_;
  uint16_t pwm_top_;
  T track_, track_next_;  // track_s, and track_s + dt (the next tick's lead, sampled between ticks)
  double dt_, grid_s_, v_supply_;
  T grid_ticks_;  // grid_s / dt
  HeatLossObserver<T> heat_;
  bool observe_heat_;
  uint8_t observe_tick_ = 0;
  T obs_meas_ = T(0), obs_model_ = T(0);  // positions at the observer's last sample
  bool obs_pending_ = false;              // a sample waits for plan_step()
  bool sample_due_;                       // the tick took a sample: prepare_next_tick() judges it
  T due_x_ = T(0), due_T_ = T(0), due_T_prev_ = T(0);  // its measurement, the model wire then and before
  T obs_x_ = T(0), obs_T_then_ = T(0);    // its measurement and model wire temperature
  T lag_ticks_;
  T loss_rate_ = T(0);  // (k^ - 1) G / C, 1/s: eq 17's extra slope per kelvin (branch_voltage)
  double far_step_s_;  // lookahead_s / kFar
  T rise_margin_;      // rise_margin_mm
  T ride_margin_;      // ride_margin_mm as a fraction (eq 14)
  uint8_t min_hold_;   // grid steps of a hold: 2 s
  bool look_far_;
  // The lag guard and the heating curve's shift (update_offset, learn_shift).
  T lag_guard_, a_fast_, a_slow_, shift_gain_;
  uint16_t shift_after_;               // ticks of a hold before the shift is learned: 1 s
  T reapproach_;                       // reapproach_mm
  T stale_offset_;                     // stale_offset_mm
  T d_step_;                           // the offset when the reference last moved (reset() sets it)
  uint16_t reapproach_after_;          // ticks above the hold before it is re-approached: 3.5 s
  uint16_t above_ticks_;
  bool reapproach_due_;
  uint8_t reheat_;  // the re-approach's re-heat: kReheatNone, kReheatCooling, kReheatDue
  T x_fast_ = T(0), x_slow_ = T(0);    // the measurement low-passed over 0.2 s and 0.6 s
  bool x_init_;
  T held_ref_ = T(-1);
  uint16_t held_ticks_;                // ticks the reference has held (within the deadband)
  bool shift_due_;
  T shift_ = T(0);                     // K, the learned shift of the heating curve
  bool far_open_ = false;        // looking for the next move beyond the horizon
  bool down_next_;               // the hold's next move is down (the last look's verdict)
  T hold_ref_ = T(-1), peak_T_ = T(-1);  // the hold it looked at, and its peak T_i*
  bool cap_on_;                  // the verdict in use (from the last complete plan)
  T cap_ref_, cap_T_;
  T T_prev_;  // the model wire before its last step
  uint8_t switch_at_[kCandidates];
  T cost_at_[kCandidates];  // the plan's cost of each candidate (switch_ticks)
  // Model wire.
  T T_est_, eps_est_, deps_, d_, v_;
  bool heating_, moved_with_, have_ref_;
  bool falling_ = false;  // the reference's last move was down (the trade-off weight applies)
  T ref_extreme_, ref_prev_ = T(0), ref_now_ = T(0);
  // Plan in progress.
  // The plan's reference samples. (Not packed into 16 bits: ~15 nm steps were enough to move
  // the planned switches at the sine's peaks, docs/control.md section 11.)
  T r_[kMaxGrid];
  uint8_t cand_, j_, best_;
  uint16_t elapsed_ticks_, plans_ = 0;
  uint16_t switch_due_;  // ticks until a planned branch switch, 0 = none
  T best_cost_, natural_cost_ = T(0), cost_, sim_T_, sim_ext_;
  bool sim_heat_, sim_moved_, sim_fall_;
  // The reference track_s after the next tick, sampled between ticks by plan_step().
  T lead_ = T(0);
  bool lead_ready_;
  bool wire_pending_;  // the model wire's hysteresis waits for prepare_next_tick()
  // The next tick's voltage on the cooling [0] and heating [1] branch (prepare_voltages), and
  // the hold's verdict it was computed with.
  T v_branch_[2];
  bool voltages_ready_;
  bool pre_cap_on_ = false;
  T pre_cap_ref_ = T(0), pre_cap_T_ = T(0);
};

// The models a stand-alone preview controller owns (a base: built before PreviewCore).
template <class T>
struct PreviewModels {
  PreviewModels(const Params& p, const Effects& fx) : curves(p), thermal(p, fx) {}
  PhaseCurves<T> curves;
  Thermal<T> thermal;
};

// The preview controller with its own models (the host, tests, benchmarks).
template <class T>
class PreviewController : private PreviewModels<T>, public PreviewCore<T> {
 public:
  PreviewController(const Params& p, const Effects& fx, const PreviewConfig& cfg)
      : PreviewModels<T>(p, fx),
        PreviewCore<T>(this->curves, this->thermal, p, fx, cfg, p.check() == nullptr && fx.check() == nullptr) {}
};

// The preview as a part of a board that may leave it out (a compile switch, sma/board.hpp):
// PreviewSlot<T, true> holds a PreviewCore on the board's models, built in place (it is not
// copyable and a board rebuilds it with its models); PreviewSlot<T, false> is empty and does
// nothing, so the board's calls compile either way and vanish when it is off.
template <class T, bool On>
class PreviewSlot {
 public:
  void build(const PhaseCurves<T>&, const Thermal<T>&, const Params&, const Effects&, const PreviewConfig&, bool) {}
  void start(T, T) {}
  void new_reference() {}
  void set_cool_weight(double) {}
  template <class Future>
  T step(T, const Future&, T) { return T(0); }
  void prepare_next_tick() {}
  template <class Future>
  bool plan_step(const Future&) { return false; }
  T wire_temperature() const { return T(0); }
};

template <class T>
class PreviewSlot<T, true> {
 public:
  PreviewSlot() {}
  ~PreviewSlot() {}
  void build(const PhaseCurves<T>& curves, const Thermal<T>& thermal, const Params& p, const Effects& fx,
             const PreviewConfig& cfg, bool model_valid) {
    new (&u_.c) PreviewCore<T>(curves, thermal, p, fx, cfg, model_valid);
  }
  void start(T T0, T measured) { u_.c.start(T0, measured); }
  void new_reference() { u_.c.new_reference(); }
  void set_cool_weight(double w) { u_.c.set_cool_weight(w); }
  template <class Future>
  T step(T ref, const Future& future, T measured) { return u_.c.step(ref, future, measured); }
  void prepare_next_tick() { u_.c.prepare_next_tick(); }
  template <class Future>
  bool plan_step(const Future& future) { return u_.c.plan_step(future); }
  T wire_temperature() const { return u_.c.wire_temperature(); }
  const PreviewCore<T>& controller() const { return u_.c; }

 private:
  union U {
    U() {}
    ~U() {}
    PreviewCore<T> c;
  } u_;
};

}  // namespace sma

#endif  // SMA_PREVIEW_HPP
