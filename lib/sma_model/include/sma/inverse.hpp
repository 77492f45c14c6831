// The inverse model (eqs 14-17) used as the feedforward V1 of eq 18.
//
// reference u (mm) --eq 14--> eps_d --eq 15 or 16--> desired temperature T_d --eq 17--> V1
//
// The branch (heating eq 15 / cooling eq 16) follows the sign of du/dt. The inverse keeps its own
// loop memory by walking a Hysteresis along the desired temperature path T_d: the same state
// machine as the plant, so a reversal of the reference opens the same minor loop (T_i, eps_i,
// T_MSi, j_i, T_ii) in both.
// dT/dt: T_d jumps where the hysteresis is flat (e.g. from T_MSi up to T_AS when heating
// resumes), so eq 17 is applied to a low-pass filtered path T_f (time constant rate_filter_s)
// whose slope is exact: dT_f/dt = (T_d - T_f) / tau. Filtering the path, not clamping the
// difference, keeps the whole heat C_th (T_d - T) of a jump in the command.
// Model wire: eq 17 assumes the wire is on the path, but V_max clips the heating after a jump
// and the wire lags. The inverse therefore runs eq 1 on its own output (ThermalStep, exact)
// and evaluates eq 17 at that model wire temperature T_m with the slope
// dT_f/dt + (T_f - T_m) / track_s: the path's slope plus a pull back onto it. With T_m = T_f
// this is exactly eq 17. Because T_m is driven by V1 alone, V1 stays a pure function of the
// reference, a feedforward in the strict sense: it never fights the PID's heat.
// Fitted thermal effects (effects.hpp) enter both eq 17 and the model wire (issue 7): a wire
// that loses more heat when hot, changes resistance with phase or absorbs latent heat gets the
// voltage its own power balance needs.
#ifndef SMA_INVERSE_HPP
#define SMA_INVERSE_HPP

#include "derived.hpp"
#include "effects.hpp"
#include "hysteresis.hpp"
#include "mechanics.hpp"
#include "params.hpp"
#include "scalar.hpp"
#include "thermal.hpp"

// The model wire's position on the flat stage (InverseModel::heating_position, the lead's PID
// target): 0 leaves it out of an image (the Q16.16 Uno image: ~50 B of flash it does not have;
// docs/control.md section 45).
#ifndef SMA_LEAD_FLAT_STAGE
#define SMA_LEAD_FLAT_STAGE 1
#endif

namespace sma {

struct InverseConfig {
  double dt = 0.01;            // tick, s
  // Time constant of the desired-temperature low-pass, s: the path lags a moving reference by
  // it. Where the lead's ride follows a climbing reference the PID stays out (Controller), so
  // the lag is the ride's error: 0.3 s was 0.008 mm behind the paper's sine there; 0.1 s keeps
  // a jump's heat spread over 10 ticks (docs/control.md section 42 has the scan).
  double rate_filter_s = 0.1;
  double track_s = 0.5;        // time constant of the pull of the wire onto the path, s
  double v_max = 2.0;          // the heater's limit, V (eq 18): the model wire sees it too
  double deadband_mm = 1e-4;   // the reference must come back this far from its last extreme
                               // before the branch reverses: 0.1 um, ~7 LSB of Q16.16. Each
                               // tick of delay at a valley costs tracking (the wire must be
                               // reheated by ~35 K before it moves): measured best of 0.02-1 um
};

template <class T>
class InverseModel {
 public:
  InverseModel(const Params& p, const Effects& fx = Effects(), const InverseConfig& cfg = InverseConfig())
      : InverseModel(p, fx, cfg, cfg.dt, cfg.v_max) {}
  // With the tick and V_max given apart (the controller's: its config has them once). The config
  // by reference, not a modified copy: on the AVR a copy sat on the frame that builds the
  // controller while it builds the loop memory (the firmware's deepest stack, Q16.16).
  InverseModel(const Params& p, const Effects& fx, const InverseConfig& cfg, double dt, const double& v_max)
      : InverseModel(p, fx, cfg, dt, v_max, p.heat_capacity(), p.conductance()) {}
  // With C_th and G computed once for the thermal model and its wire step.
  InverseModel(const Params& p, const Effects& fx, const InverseConfig& cfg, double dt, const double& v_max,
               double C_th, double G_th)
      : deadband_(from_field<T>(cfg.deadband_mm)),
        v_max_(from_field<T>(v_max)),
        inv_dt_(reciprocal_as<T>(dt)),
        alpha_(low_pass_gain_as<T>(dt, cfg.rate_filter_s)),
        inv_tau_(reciprocal_as<T>(cfg.rate_filter_s)),
        inv_track_(reciprocal_as<T>(cfg.track_s)),
        curves_(p),
        thermal_(p, fx, C_th, G_th),
        mech_(p, fx),
        memory_(curves_, from_field<T>(p.T_amb), T(0)),
        wire_step_(thermal_, p, dt, C_th, G_th) {
    reset(from_field<T>(p.T_amb), T(0));
  }

  // Restart at rest: wire at T0 with fraction eps0, reference at its displacement.
  void reset(T T0, T eps0) {
    memory_.reset(T0, eps0);
    T_f_ = T0;
    T_m_ = T0;
    model_pending_ = false;
    eps_f_ = memory_.eps();
    u_prev_ = mech_.displacement(memory_.eps(), T0);
    u_extreme_ = u_prev_;
#if SMA_LEAD_FLAT_STAGE
    u_turn_ = u_prev_;
#endif
    heating_ = true;
    riding_ = false;
  }

  // One tick: reference u (mm, a position on the stroke: >= 0) -> feedforward V1 in 0..V_max.
  T step(T u) { return step_(u, u, false, false); }
  // The same with the known future (LeadConfig): `now`, the present reference; `ahead`, the
  // reference lead_s ahead; `peak`, the highest reference of the next few seconds.
  // - The cooling lead: while the branch heats or rides the rise (the memory above its loop's
  //   T_MSi, eqs 5-7: the wire must cool before it moves), the inverse reads the lower of now and
  //   ahead, so its cooling branch starts lead_s before the reference falls (cooling is passive
  //   and slow). That turn takes the path to the point ahead's temperature on the cooling stage
  //   (eq 16, below T_MSi). From there the wire moves with its temperature (eq 11), and a path
  //   lead_s ahead would carry it below the present reference (0.02 mm after the paper's sine's
  //   top): on the cooling stage the inverse reads the present reference, and the memory holds
  //   where the turn took it until the present reference comes down to it (eq 16 does not raise
  //   T on a cooling branch). (A jump up held for less than the lead is therefore not climbed:
  //   the branch turns to cooling with the wire still on the flat stage; waiting for the
  //   heating to arrive climbs it, but then a jump of ~1 s locks its loop's rise above the next
  //   hold: docs/control.md section 45.)
  // - No turn against the future: while ahead lies below now the branch does not turn to
  //   heating, while it lies above, not to cooling. At a valley the wire is on the present
  //   reference's path and turns to heating once, when the present reference comes back up past
  //   its lowest point (the deadband). (A turn on the point ahead, half the lead early, held the
  //   wire on the flat stage above the falling reference, then past the rise.)
  // - The peak rule: a heating stops where the minor-loop rise (eqs 5-6) of a reversal at the
  //   present point would carry the wire to the peak: the branch turns to cooling and the wire
  //   rides the rise up (lower temperature, higher fraction) while the reference still climbs,
  //   instead of being heated to the peak and rising past it when the cooling starts (Fig. 12).
  // (`peak_rule` false: step(now). The references are positions on the stroke, >= 0.)
  T step(T now, T ahead, T peak, bool peak_rule) {
    const bool lower = peak_rule && above(now, ahead);
    const bool early = lower && (heating_ | riding_);  // (`|`: one instruction, flash on the Uno)
    return step_(early ? ahead : now, peak, peak_rule, lower);
  }

  // (The two inline into one body each: the paper's step(u) compiles to the code it had, the
  // rule folded away, flash on the Uno; a board with the lead carries only the second.)
  // `lower`: the future lies lower (u is the point ahead, or on the cooling stage the present
  // reference).
  __attribute__((always_inline)) inline T step_(T u, T peak, bool peak_rule, bool lower) {
    advance_model();  // the last tick's, where the caller did not run it between ticks
    if (!is_finite(u)) u = u_prev_;  // hold the last reference on NaN
    u_prev_ = u;
    // Eq 14 at ambient, once: the branch decision (on_rise) and eq 15 or 16 read the same
    // fraction (one multiplication call fewer, flash on the Uno).
    const T e_u = mech_.fraction(u);
    // Branch = sign of du/dt (eq 14), decided against the last extreme of the reference rather
    // than tick to tick: a per-tick difference near a turning point is below the resolution
    // of a fixed-point scalar and would flip on rounding. With the known future the branch does
    // not turn against it (`lower`, step(now, ahead, peak, rule)). (Positions >= 0: above().)
    if (heating_ ? above(u, u_extreme_) : above(u_extreme_, u)) u_extreme_ = u;
    if ((heating_ ? u < u_extreme_ - deadband_ : u > u_extreme_ + deadband_) && !(peak_rule && heating_ != lower)) {
      // A rising reference that the rise still reaches (above its end, below its top) stays
      // on the cooling branch: it is followed up the rise.
#if SMA_LEAD_FLAT_STAGE
      if (!heating_) u_turn_ = u_extreme_;
#endif
      u_extreme_ = u;
      if (!(peak_rule && !heating_ && on_rise(e_u))) heating_ = !heating_;
    }
    // The peak rule: only while the reference still climbs towards the peak (a hold is not a
    // peak), and once the heating it stops has been applied: the model wire (eq 1 under V1) is
    // on the path, within kApplied_K. A reversal opens a loop with its rise (eqs 5-6) only after
    // a heating that transformed, and the rise's height is then the loop's (j_i at T_i) however
    // little it transformed. At a valley the path jumps onto the heating curve at the present
    // fraction (eq 15) while the wire still crosses the flat stage (eq 4, ~2 s at V_max); a rule
    // applied to the path alone stopped that heating where the wire, a hair behind the model,
    // had transformed nothing: it never rose (a 0.45-0.55 mm sine: parked 0.1 mm below it on
    // half the noise seeds; the paper's wire on a 100 s sine: 0.07 mm RMS). On a steady rise
    // the model wire trails the path by rate_filter_s: ~0.03 K on the paper's sine.
    if (peak_rule && heating_ && memory_.heating() && !(T_m_ < T_f_ - T(kApplied_K)) &&
        above(peak, u + deadband_)) {
      // (top: the loop a reversal at the present point opens. The test that it lies above eps, a
      // heating that transformed, went with the gate: on the tracking benches no run reaches
      // the rule after a heating that did not, docs/control.md section 42; flash on the Uno.)
      if (!(mech_.fraction(peak) > memory_.prepare_cooling_shape().top)) heating_ = false;  // (top needs no rates)
    }

    // Eq 14 then eq 15 or 16. With thermal expansion eq 14 needs the temperature it leads to,
    // eps_d = (u + k (T(eps_d) - T_a)) / g: a fixed number of fixed-point steps (a contraction:
    // k dT/deps / g ~ 0.01 inside the band; T stays within the branch's range), no loop
    // whose length depends on the data.
    const bool expands = kThermalExpansion && mech_.expands;
    // The desired temperature T_d so far: where the memory walked to.
    const T T_d = memory_.temperature();
    T e = e_u;  // eq 14 at ambient
    T T_new;
    // The memory walks the same branch from the same fraction e, so where T_new is the branch
    // at e (not held), e is its fraction there: it gets it instead of evaluating the curve again.
    bool on_curve;
    if (heating_) {
      T_new = curves_.heat_temperature(e);  // eq 15
      if (expands)
        for (int i = 0; i < kExpansionSteps; ++i) {
          e = mech_.fraction(u, T_new);
          T_new = curves_.heat_temperature(e);
        }
      // Heating can only raise eps: below the current fraction, hold the temperature.
      on_curve = T_new > T_d;
      T_new = max(T_new, T_d);
      riding_ = false;
    } else {
      // Eq 16 needs only the loop's shape: its rates wait (prepare_cooling_shape).
      const CoolingLoop<T>& loop = memory_.prepare_cooling_shape();
      const bool riding = peak_rule && !(e < memory_.eps()) && on_rise(e);  // (on_rise finishes the loop)
      // (On the ride e lies on the rise: eps_i <= eps <= e < top, the memory above T_ii.)
      T_new = riding ? curves_.rise_temperature_inside(loop, e) : curves_.cool_temperature(loop, e);  // eq 16, this loop's T_MSi
      if (expands && !riding)
        for (int i = 0; i < kExpansionSteps; ++i) {
          e = mech_.fraction(u, T_new);
          T_new = curves_.cool_temperature(loop, e);
        }
      // Eq 16 inverts eq 11 only strictly inside the cooling stage. The ride's T_new inverts
      // eqs 5-6 at e (eps_i < e < top: on_rise and the test above), so the memory takes e itself:
      // a reference held on the ride then finds the memory at exactly its fraction and rides on,
      // where the fraction walked back from T_new differed by a rounding whose sign decided,
      // scalar by scalar, between riding on and the cooling stage.
      // (Fractions >= 0: positive(), above().)
      on_curve = T_new < T_d && (riding || (positive(e) && above(loop.top, e) && curves_.has_cooling_stage(loop)));
      T_new = min(T_new, T_d);
      riding_ = riding;  // (T_new then lies in T_ii..T_i: the memory is on the rise, riding())
    }
    if (on_curve) memory_.update(T_new, e);
    else memory_.update(T_new);
    // The filtered path T_f and its exact slope.
    const T rate = (T_new - T_f_) * inv_tau_;
    T_f_ = T_f_ + alpha_ * (T_new - T_f_);
    // With non-linear thermal effects: the fraction along the filtered path, on the branch the
    // memory is on, i.e. what the wire transforms as it follows T_f (latent heat,
    // phase-dependent resistance). The paper's eq 1 does not need it: skip the work.
    T deps_dt = T(0);
    if (!thermal_.plain) {
      const T eps_f = heating_ ? max(curves_.eps_heat(T_f_), eps_f_)
                               : min(curves_.eps_cool(memory_.loop(), T_f_), eps_f_);
      d_eps_ = eps_f - eps_f_;
      deps_dt = d_eps_ * inv_dt_;
      eps_f_ = eps_f;
    }
    const T slope = rate + (T_f_ - T_m_) * inv_track_;
    T v1 = min(thermal_.voltage_for(T_m_, slope, eps_f_, deps_dt), v_max_);  // eq 17
    if (!is_finite(v1)) v1 = T(0);
    v1_ = v1;
    model_pending_ = true;
    return v1;
  }

  // The model wire's tick under this tick's V1 (eq 1: the power balance eq 17 inverted). The
  // V1 of step() does not depend on it, so the board runs it between ticks, after the output is
  // written; otherwise the next step() runs it first. The same numbers either way.
  void advance_model() {
    if (model_pending_) advance_model_now();
  }

  // Between ticks (after the output is written): the loop a reversal at the memory's present
  // point would open, built now with its rates (Hysteresis::prepare_cooling), so that the tick
  // whose reference reverses, or whose peak rule switches, neither builds it nor divides inside
  // the control section. Changes no number: the reversal uses the same loop it would have built;
  // a heating that goes on discards it.
  void prepare_reversal() { memory_.prepare_cooling(); }

  T desired_temperature() const { return memory_.temperature(); }
  T filtered_temperature() const { return T_f_; }
  // The reference's last extreme on this branch (the highest while heating): where a heating
  // kept against a falling reference turned.
  T extreme() const { return u_extreme_; }
  // Where the model wire is while it heats (eq 12): on the major heating curve at its
  // temperature (eq 2), or still at the fraction of the valley the heating turned at while it
  // crosses the flat stage (eq 4). The position the feedforward has brought a wire like the
  // model's to so far. (The curve alone read ~0 mm there: the PID, acting on that gap, cut the
  // heating of a wire resting at 0.21 mm after a jump up to 0.51 mm to V_hold for 1.2 s.)
  T heating_position() const {
#if SMA_LEAD_FLAT_STAGE
    return max(mech_.displacement(curves_.eps_heat(T_m_)), u_turn_);
#else
    return mech_.displacement(curves_.eps_heat(T_m_));
#endif
  }
  // (After step(): the model wire at the end of its tick, advanced or not.)
  T model_temperature() const { return model_pending_ ? wire_step_(T_m_, v1_, eps_f_, d_eps_) : T_m_; }
  bool heating() const { return heating_; }
  // The last step rode a loop's rise (the peak rule's, eqs 5-6): on a cooling branch above the
  // rise's end, where cooling moves the wire up.
  bool riding() const { return riding_; }
  const Hysteresis<T>& memory() const { return memory_; }
  const Thermal<T>& thermal() const { return thermal_; }
  const Mechanics<T>& mechanics() const { return mech_; }
  // Eq 1 over one tick (the controller's temperature estimate uses the same).
  const WireStep<T>& wire_step() const { return wire_step_; }
  T v_max() const { return v_max_; }
  const PhaseCurves<T>& curves() const { return curves_; }

  InverseModel(const InverseModel&) = delete;  // memory_ points into curves_
  InverseModel& operator=(const InverseModel&) = delete;

 private:
  static constexpr int kExpansionSteps = 3;
  static constexpr double kApplied_K = 0.1;  // the peak rule's model wire on its path (step())

  // Fraction e is on the rise of the memory's loop from where the memory is: between the
  // rise's end and its top, the memory still above the rise's end temperature T_ii.
  // (Out of line: the branch decision and the cooling branch share one copy, flash on the Uno.)
  __attribute__((noinline)) bool on_rise(T e) const {
    const CoolingLoop<T>& L = memory_.loop();
    return e < L.top && memory_.temperature() > L.T_ii;
  }

  // (Out of line: one copy for advance_model's two callers, flash on the Uno.)
  __attribute__((noinline)) void advance_model_now() {
    T_m_ = wire_step_(T_m_, v1_, eps_f_, d_eps_);
    model_pending_ = false;
  }

  // (The tick's scalars first, the models after them: the AVR's loads reach 63 bytes past an
  // object's address, flash on the Uno.)
  bool heating_;
  bool model_pending_;  // T_m_ has not had the last step's tick yet (advance_model)
  bool riding_;         // the last step's cooling rode the rise (riding())
  T u_extreme_, u_prev_, deadband_;
  T T_f_, T_m_, eps_f_;
  T v1_, d_eps_;  // the last step's V1 and change of eps_f: the model wire's pending tick
  T v_max_;
  T inv_dt_, alpha_, inv_tau_, inv_track_;
  PhaseCurves<T> curves_;
  Thermal<T> thermal_;
  Mechanics<T> mech_;
  Hysteresis<T> memory_;
  WireStep<T> wire_step_;
#if SMA_LEAD_FLAT_STAGE
  T u_turn_;  // the reference's valley where the branch last turned to heating (heating_position)
#endif
};

}  // namespace sma

#endif  // SMA_INVERSE_HPP
