// PID on the position error, in the style of the Arduino PID library write-ups:
//  - derivative on measurement: a setpoint step gives no derivative kick;
//  - the derivative is low-pass filtered: the sensor's noise is not amplified by kd/dt;
//  - anti-windup: the integrator stops when the output saturates in the error's direction,
//    and is clamped to the output range, so it never winds up past what the heater can do;
//  - integral zone: it integrates only within i_zone of the setpoint, so that it removes the
//    steady-state error without storing the error of a whole transient (on a hysteretic
//    plant an overshoot cannot be undone by backing off: see controller.hpp);
//  - output limits are set per tick (the controller passes [-V1, V_max - V1] so that
//    V1 + V2 stays in 0..V_max, eq 18);
//  - bumpless mode change: start() sets the integrator so the first output equals the
//    output the loop had before.
#ifndef SMA_PID_HPP
#define SMA_PID_HPP

#include "derived.hpp"
#include "scalar.hpp"
#include "codegen.hpp"

namespace sma {

struct PidGains {
  double kp = 0.0;        // V/mm
  double ki = 0.0;        // V/(mm s)
  double kd = 0.0;        // V s/mm
  double d_filter_s = 0.05;  // derivative low-pass time constant, s
  double i_zone_mm = 0.05;   // integrate only while |error| < i_zone_mm (0: always)

  // nullptr if usable, else a message naming the gain.
  constexpr const char* check() const {
    if (!(kp >= 0.0 && kp < 1000.0)) return "kp must be in 0..1000";
    if (!(ki >= 0.0 && ki < 1000.0)) return "ki must be in 0..1000";
    if (!(kd >= 0.0 && kd < 1000.0)) return "kd must be in 0..1000";
    if (!(d_filter_s >= 0.0 && d_filter_s < 10.0)) return "d_filter_s must be in 0..10";
    if (!(i_zone_mm >= 0.0 && i_zone_mm < 100.0)) return "i_zone_mm must be in 0..100";
    return nullptr;
  }
};

template <class T>
class Pid {
 public:
  Pid(const PidGains& gains, double dt) { set_gains(gains, dt); }

  // New gains keep the current output (bumpless): the integrator absorbs the change of P.
  void set_gains(const PidGains& gains, double dt) {
    const T kp_new = from_field<T>(gains.kp);
    integral_ = integral_ + (kp_ - kp_new) * e_prev_;
    kp_ = kp_new;
    ki_dt_ = from_double<T>(gains.ki * dt);
    // The filtered derivative d += alpha (d_raw - d) with d_raw = -kd/dt dMeas, folded into
    // d = keep d - gain dMeas: one subtraction a tick less.
    const double alpha = dt / (gains.d_filter_s + dt);
    d_keep_ = from_double<T>(1.0 - alpha);
    d_gain_ = from_double<T>(alpha * gains.kd / dt);
    i_zone_ = from_double<T>(gains.i_zone_mm > 0.0 ? gains.i_zone_mm : 1e4);
  }

  // Bumpless start: the next output equals `output` for an unchanged error.
  void start(T measurement, T error, T output) {
    meas_prev_ = measurement;
    e_prev_ = error;
    d_ = T(0);
    integral_ = output - kp_ * error;
  }

  // One tick. error = setpoint - measurement; output in [lo, hi].
  SMA_OWN_OPTIONS T step(T error, T measurement, T lo, T hi) {
    if (!is_finite(error) || !is_finite(measurement)) return clamp(T(0), lo, hi);
    e_prev_ = error;
    // Derivative on measurement, low-pass filtered; P and D summed once for both uses below.
    d_ = d_keep_ * d_ - d_gain_ * (measurement - meas_prev_);
    meas_prev_ = measurement;
    const T pd = kp_ * error + d_;
    const T unsat = pd + integral_;
    // Conditional integration: no integration that pushes further into saturation.
    // (error is finite here: sign and magnitude tests without a compare of floats.)
    const bool pushing_up = positive(error) && unsat >= hi;
    const bool pushing_down = negative(error) && unsat <= lo;
    if (!pushing_up && !pushing_down && abs_below(error, i_zone_))
      integral_ = integral_ + ki_dt_ * error;
    integral_ = clamp(integral_, lo, hi);
    return clamp(pd + integral_, lo, hi);
  }

  T integral() const { return integral_; }

 private:
  // The coefficients set_gains() sets (it reads only kp_ before: 0 at construction).
  T kp_ = T(0), ki_dt_, d_keep_, d_gain_, i_zone_;
  T integral_ = T(0), meas_prev_ = T(0), d_ = T(0), e_prev_ = T(0);
};

}  // namespace sma

#endif  // SMA_PID_HPP
