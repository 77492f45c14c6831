// The feedforward + feedback controller of eq 18:  V = V1 + V2,  0 <= V <= V_max.
//   V1: inverse model (inverse.hpp) of the reference,  V2: PID (pid.hpp) on r - D.
// Modes: Off (V = 0), OpenLoop (a fixed V), Pid (V2 only), Feedforward (V1 only),
// FeedforwardPid (both). A mode change is bumpless where it can be: the PID starts from the
// voltage the loop had. NaN in, or a non-finite result, gives V = 0: the heater off is the safe
// output of a heater.
#ifndef SMA_CONTROLLER_HPP
#define SMA_CONTROLLER_HPP

#include "effects.hpp"
#include "inverse.hpp"
#include "mechanics.hpp"
#include "params.hpp"
#include "pid.hpp"
#include "reference.hpp"
#include "scalar.hpp"
#include "thermal.hpp"

// The lead's restart of the inverse on a wire parked under its setpoint (Controller::
// check_parted); 0 leaves it out of an image (~170 B of the Uno's float flash: the Q16.16 image,
// at its budget, is built without it).
#ifndef SMA_LEAD_REANCHOR
#define SMA_LEAD_REANCHOR 1
#endif

namespace sma {

// Preview: the controller of preview.hpp (PreviewController), which needs the future of the
// reference; Controller itself outputs 0 V in that mode (the board dispatches to the other).
enum class Mode : uint8_t { Off = 0, OpenLoop = 1, Pid = 2, Feedforward = 3, FeedforwardPid = 4, Preview = 5 };

inline const char* mode_name(Mode m) {
  switch (m) {
    case Mode::OpenLoop: return "open";
    case Mode::Pid: return "pid";
    case Mode::Feedforward: return "ff";
    case Mode::FeedforwardPid: return "ffpid";
    case Mode::Preview: return "preview";
    default: return "off";
  }
}

struct ControllerConfig {
  double dt = 0.01;     // tick, s (100 Hz)
  double v_max = 2.0;   // eq 18
  PidGains gains;       // for both PID modes (see default_gains())
  InverseConfig inverse;

  constexpr const char* check() const {
    if (!(dt > 0.0 && dt <= 1.0)) return "dt must be in 0..1";
    if (!(v_max > 0.0 && v_max <= 5.0)) return "v_max must be in 0..5";
    return gains.check();
  }
};

// FeedforwardPid with the known future: the caller's setting (the board's `lead F` times
// lead_for, the host's RunSetup), read through ReferenceGen::lookahead into Controller::step.
struct LeadConfig {
  // s; 0: the paper's eq 18. The inverse model reads the reference lead_s ahead where it is
  // lower than now: cooling is passive and slow, the cooling branch is taken lead_s before the
  // reference falls (the heating/cooling trade-off: a longer lead leaves a setpoint earlier
  // for the fall that follows). And it stops
  // a heating where the minor-loop rise (eqs 5-6) carries the wire to the highest reference of
  // the next peak_window_s (InverseModel::step's peak rule). The PID keeps the error r - D.
  double lead_s = 0.0;
  double peak_window_s = 10.0;

  constexpr const char* check() const {
    if (!(lead_s >= 0.0 && lead_s <= 20.0)) return "lead_s must be in 0..20";
    if (!(peak_window_s > 0.0 && peak_window_s <= 20.0)) return "peak_window_s must be in 0..20";
    return nullptr;
  }
  constexpr bool on() const { return lead_s > 0.0; }
  // In ticks of dt (ReferenceGen::lookahead).
  constexpr uint32_t lead_ticks(double dt) const { return static_cast<uint32_t>(lead_s / dt + 0.5); }
  // The window's sample spacing (kLookaheadSamples).
  constexpr uint32_t sample_ticks(double dt) const {
    return static_cast<uint32_t>(peak_window_s / dt / kLookaheadSamples + 0.5);
  }
};

// The lead a reference gets (the board's, and every benchmark's that runs the lead as the board
// does): 10 s on the multi-step (tune_lead's, bench_tracking, docs/control.md section 31); 5.25 s
// on the sine and a trajectory, one lead for both (section 42: the best of a 0.25 s grid on the
// rig-like sine since the lead's path ends on the cooling stage; a user's trajectory, 3.25 s
// before, gains on the own plant and loses on plant B); none on a constant (it has no future).
constexpr LeadConfig lead_for(RefKind k) {
  return LeadConfig{k == RefKind::MultiStep ? 10.0 : k == RefKind::Constant ? 0.0 : 5.25, LeadConfig().peak_window_s};
}

// Tag of a ControllerConfig whose check() the caller has proven at compile time (the board's
// own config, a constant: its run-time check is ~300 B of AVR flash).
struct CheckedConfig {};

template <class T>
class Controller {
 public:
  Controller(const Params& p, const Effects& fx, const ControllerConfig& cfg)
      : Controller(p, fx, cfg, cfg.check() == nullptr) {}
  Controller(const Params& p, const Effects& fx, const ControllerConfig& cfg, CheckedConfig)
      : Controller(p, fx, cfg, true) {}

  // False when built from a non-physical set (Params/Effects/ControllerConfig::check()): the
  // controller then stays Off and outputs 0 V whatever it is asked.
  bool valid() const { return valid_; }

  // Switch mode. The measurement lets the new mode start smoothly: the inverse's loop memory
  // restarts from the measured fraction at the estimated wire temperature, the PID from the
  // last V.
  void set_mode(Mode m, T measurement) {
    if (m == mode_ || !valid_) return;
    const bool ff = m == Mode::Feedforward || m == Mode::FeedforwardPid;
    const bool had_ff = mode_ == Mode::Feedforward || mode_ == Mode::FeedforwardPid;
    if (ff && !had_ff) inverse_.reset(T_wire_, inverse_.mechanics().fraction(measurement, T_wire_));
    if (m == Mode::Pid || m == Mode::FeedforwardPid) {
      const T v1 = (m == Mode::FeedforwardPid) ? v1_ : T(0);
      pid_.start(measurement, T(0), v_ - v1);
    }
    mode_ = m;
    prepare_hold();  // the mode's first tick, too, finds V_hold computed
  }
  Mode mode() const { return mode_; }

  // Voltage of the open-loop mode, clamped to 0..V_max.
  void set_voltage(T v) { v_open_ = clamp(v, T(0), v_max_); }
  void set_gains(const PidGains& g) { pid_.set_gains(g, dt_); }

  // One tick: reference and measured displacement (mm) -> voltage across the wire, 0..V_max.
  // The wire temperature estimate advances with the voltage actually commanded (eq 1 with the
  // model's effects, WireStep): what the safety limit and the PID's branch limits watch.
  T step(T ref, T measured) { return step_<false>(ref, measured, nullptr, false); }
  // The same with the known future (LeadConfig; ReferenceGen::lookahead) where `lead`.
  // (Out of line: inside it the controller's and the inverse's scalars are within the AVR's
  // 63-byte load reach of the controller's address, not hundreds of bytes into a board's.)
  __attribute__((noinline)) T step(T ref, T measured, const Lookahead<T>& future, bool lead) { return step_<true>(ref, measured, &future, lead); }

  // Between ticks, after the output is written: the feedforward's model wire and the loop of a
  // possible reversal (InverseModel::advance_model, prepare_reversal), work that the next tick
  // would otherwise do inside the control section; that part changes no number. With the known
  // future (`lead`, as the tick's step had it) also the check of a wire parked under its
  // setpoint (check_parted), which may restart the inverse: a loop with the lead calls this after
  // every step.
  void prepare_next_tick(bool lead = false) {
#if SMA_LEAD_REANCHOR
    if (lead) check_parted();
#else
    (void)lead;
#endif
    if (mode_ == Mode::Feedforward || mode_ == Mode::FeedforwardPid) {
      inverse_.advance_model();
      inverse_.prepare_reversal();
    }
    prepare_hold();
  }

  // Estimated wire temperature (eq 1 on the commanded voltage), deg C.
  T wire_temperature() const { return T_wire_; }
  // Takes over the estimate of a controller that drove the wire meanwhile (the preview): the
  // estimate is what the latch watches and where the inverse model restarts.
  void set_wire_temperature(T Tw) {
    if (is_finite(Tw)) T_wire_ = Tw;
    hold_ready_ = false;
  }

  T v1() const { return v1_; }
  T v2() const { return v2_; }
  T voltage() const { return v_; }
  const InverseModel<T>& inverse() const { return inverse_; }

 private:
  // The next tick's V_hold at the estimate it will start from (eq 1's R: with a phase-dependent
  // resistance it needs the next measurement's fraction, and stays in the tick).
  void prepare_hold() {
    if (mode_ == Mode::FeedforwardPid && inverse_.thermal().plain) {
      hold_ = thermal_hold();
      hold_ready_ = true;
    }
  }
  // `cfg_ok`: the config's check(), done by the caller (at compile time for CheckedConfig).
  Controller(const Params& p, const Effects& fx, const ControllerConfig& cfg, bool cfg_ok)
      : valid_(cfg_ok && p.check() == nullptr && fx.check() == nullptr),
        inverse_(p, fx, cfg.inverse, cfg.dt, cfg.v_max),  // the controller's tick and V_max
        pid_(cfg.gains, cfg.dt),
#if SMA_LEAD_REANCHOR
        parted_limit_(parted_ticks(cfg.dt)),
#endif
        dt_(cfg.dt) {
    T_wire_ = inverse_.thermal().T_a;  // the true ambient, converted once
    v_max_ = inverse_.v_max();         // cfg.v_max, converted once
  }

  // The voltage that holds the estimated wire temperature (eq 17, dT/dt = 0), at the measured
  // fraction: the same resistance R(eps) the estimate uses (phase-dependent resistance).
  // (Out of line: one copy for the tick and prepare_next_tick, flash on the Uno.)
  __attribute__((noinline)) T thermal_hold() const { return inverse_.thermal().hold_voltage(T_wire_, eps_meas_); }

  // (One template for the two: the paper's compiles to the code it had, the known future folded
  // away, flash on the Uno; a board with the lead carries only the second, `lead` at run time.)
  template <bool kLead>
  T step_(T ref, T measured, const Lookahead<T>* future, bool lead) {
    // The fraction comes from the measurement: a phase-dependent resistance (V_hold and the
    // estimate) and the latent heat of what the wire transformed this tick (its change, not its
    // rate: the measurement's noise telescopes away). Without it the estimate runs ahead of a
    // wire that absorbs latent heat while it transforms, and V_hold, the PID's floor while
    // heating, holds the wire past its first setpoint. A sample lost (NaN) keeps the last
    // fraction. (Eq 1 of the paper needs neither, and WireStep ignores both there; the fraction
    // is read on every model all the same: the test of the model's kind cost 14 B of the Uno's
    // flash, more than its ~0.6 k cycles of the tick are worth.)
    T d_eps = T(0);
    if (is_finite(measured)) {
      d_eps = (inverse_.mechanics().fraction(measured, T_wire_) - eps_meas_) * T(kFractionFilter);  // (T(x): folded at compile time)
      eps_meas_ = eps_meas_ + d_eps;
    }
    v_ = compute<kLead>(ref, measured, future, kLead && lead);
    T_wire_ = inverse_.wire_step()(T_wire_, v_, eps_meas_, d_eps);
    hold_ready_ = false;  // V_hold was the old estimate's
    return v_;
  }

  template <bool kLead>
  T compute(T ref, T measured, const Lookahead<T>* future, bool lead) {
    v1_ = T(0);
    v2_ = T(0);
    if (!is_finite(ref) || !is_finite(measured)) return T(0);
    ref = clamp(ref, T(0), inverse_.mechanics().g);  // a reference past the stroke cannot be reached
    switch (mode_) {
      case Mode::OpenLoop: return v_open_;
      case Mode::Pid:
        v2_ = pid_.step(ref - measured, measured, T(0), v_max_);
        break;
      case Mode::Feedforward:
      case Mode::FeedforwardPid: {
        // (One call for the two modes: it inlines once, flash on the Uno.)
        v1_ = feedforward<kLead>(ref, future, lead);  // 0..V_max: the inverse has the same V_max
        if (mode_ == Mode::Feedforward) break;
        // PID limits: V1 + V2 inside 0..V_max (eq 18; the anti-windup sees the clamp), and
        // never against the branch the reference is on. While it heats, the PID may slow the
        // heating but not cool the wire: cooling opens a minor loop whose rise (eqs 5-6) moves
        // the wire up, which the PID would answer by cooling more, a runaway to T_MSi. While
        // it cools, the PID may not heat: heating from a cooling branch only moves along a
        // flat stage (eq 4). V_hold (eq 17 with dT/dt = 0) keeps the estimated wire
        // temperature where it is. The cooling cap is never below V1 itself: after a down-step
        // the estimate can sit below the inverse's model wire (the PID first cancels part of
        // V1), and a cap at its V_hold would hold the command under the cooling curve's own
        // voltage (eq 16, 17) while the wire creeps below the hold, for good.
        const T v_hold = min(hold_ready_ ? hold_ : thermal_hold(), v_max_);
        T lo = -v1_, hi = v_max_ - v1_;
        if (inverse_.heating()) lo = max(lo, v_hold - v1_);
        else hi = min(hi, max(v_hold - v1_, T(0)));
        // On the rise of the peak rule cooling moves the wire up, heating stalls it on a flat
        // stage: the error's sign says nothing of the voltage's, the feedforward rides alone.
        // (Only the peak rule rides: no ride without the lead.)
        if (kLead && inverse_.riding()) lo = hi = T(0);
        // A hold approached on the heating branch (the future: nothing higher ahead): the PID
        // acts on the gap to where the model wire is, not to the reference. The wire's lag
        // behind a step is the feedforward's to close (eq 17 plans that path); a PID pushing
        // on it heats the wire ahead of the model, past the setpoint, and on this branch the
        // overshoot stays (it may not cool). With an exact model the gap is nil; with a wrong
        // one the PID closes, from below, what the model leaves.
        v2_ = pid_.step((kLead ? hold_target(ref, future->peak, lead) : ref) - measured, measured, lo, hi);
        break;
      }
      default: return T(0);
    }
    return clamp(v1_ + v2_, T(0), v_max_);  // NaN -> 0 V (clamp maps it to lo)
  }

#if SMA_LEAD_REANCHOR
  // A wire parked under its setpoint on a cooling branch: the inverse's path (its memory, eqs
  // 4-10) cooled to the reference along its loop, the wire did not follow (a heating cut short, as
  // a jump up held about as long as the lead: it never left the flat stage, eq 4). Cooling cannot
  // raise the wire and the PID may not heat past V_hold there, so nothing brings the two
  // together: the inverse restarts at the wire (as a mode change does) once the wire has stayed
  // kPartedMm under the path for kPartedS; a reference above it then lies on a heating branch.
  // Not while the peak rule rides the rise (eqs 5-6): there the wire is meant to rise by cooling.
  // (Between ticks, prepare_next_tick(): a restart stays out of the control section. The wire's
  // fraction is the measurement's, low-passed: eps_meas_.)
  __attribute__((noinline)) void check_parted() {
    if (!(mode_ == Mode::Feedforward || mode_ == Mode::FeedforwardPid) || inverse_.heating() || inverse_.riding() ||
        !(inverse_.mechanics().g * (inverse_.memory().eps() - eps_meas_) > T(kPartedMm))) {
      parted_ = 0;
    } else if (++parted_ >= parted_limit_) {
      inverse_.reset(T_wire_, eps_meas_);
      parted_ = 0;
    }
  }
#endif

  // The PID's target while the inverse heats with the known future: a heating kept for the rise
  // ahead of a valley (the future above, the present reference still falling: InverseModel's
  // step) acts on the reference the heating turned at, its extreme: the wire stalls there on the
  // flat stage (eq 4) while it heats, and a PID on the falling reference would hold its
  // temperature at V_hold, the floor of its heating, until the reference came back up. On a
  // rising reference the extreme is the reference itself.
  // (Inline: the step with the known future, its only caller, is out of line itself.)
  T hold_target(T ref, T peak, bool lead) const {
    if (!lead || !inverse_.heating()) return ref;
    if (above(peak, ref)) return inverse_.extreme();
    return min(inverse_.heating_position(), ref);  // (g eps >= 0: eq 12 at ambient, eps in 0..1)
  }

  // V1: the inverse model of the reference, with the known future where `lead`: the future's
  // `ahead` (the present reference where it is not below it; NaN: not below) and its peak.
  template <bool kLead>
  T feedforward(T ref, const Lookahead<T>* future, bool lead) {
    if (!kLead) return inverse_.step(ref);
    return inverse_.step(ref, future->ahead, future->peak, lead);
  }

  // (The tick's scalars before the models: the AVR's loads reach 63 bytes past an object's
  // address.)
  Mode mode_ = Mode::Off;
  bool hold_ready_ = false;
  bool valid_;
  T T_wire_;
  T eps_meas_ = T(0);  // austenite fraction of the measurements, low-passed (kFractionFilter)
  // Its low-pass gain per tick: 1/16, a time constant of 0.16 s at the board's 100 Hz (against
  // the wire's 4 s). The raw fraction's noise (2 um: 0.002) would move the estimate's latent term
  // by ~0.01 K a tick, up and down: a sensor predictor walking the estimate through its loop
  // memory (sensor.hpp) would open a minor loop at every tick.
  static constexpr double kFractionFilter = 1.0 / 16.0;
  T hold_ = T(0);      // thermal_hold() computed between ticks (prepare_next_tick)
  T v_max_;
  T v_open_ = T(0), v_ = T(0), v1_ = T(0), v2_ = T(0);
  // Eq 12 and the wire's tick are the inverse model's (the same parameters, effects and dt):
  // one copy in RAM.
  InverseModel<T> inverse_;
  Pid<T> pid_;
#if SMA_LEAD_REANCHOR
  // The wire parked under a cooling branch's path (check_parted): by more than 25 x the
  // sensor's 2 um noise, for half a second (in ticks, 1..255).
  static constexpr double kPartedMm = 0.05, kPartedS = 0.5;
  static constexpr uint8_t parted_ticks(double dt) {
    return kPartedS / dt > 254.5 ? 255 : kPartedS / dt < 1.5 ? 1 : static_cast<uint8_t>(kPartedS / dt + 0.5);
  }
  uint8_t parted_ = 0, parted_limit_;  // ticks the wire has stayed parted (check_parted), limit
#endif
  // The tick, s (the PID's gains per tick; the rest of the config lives in what it built, not
  // twice in RAM).
  double dt_;
};

}  // namespace sma

#endif  // SMA_CONTROLLER_HPP
