// The simulated rig: the model's own boxes run forward (thermal.hpp, hysteresis.hpp,
// mechanics.hpp), plus what a real rig adds and the model may not know: the effects of
// effects.hpp, sensor noise, ADC quantisation and PWM quantisation.
//
//   V --(PWM levels)--> thermal ODE --> T --> hysteresis --> eps --> D = g eps - k (T - T_a)
//   D --> calibration --> lag --> delay --> noise --> ADC step --> measured
//
// Host side only (tests, virtual rig, tools): its sensor-delay history alone is 128 KB.
// Integration: with no thermal effect eq 1 is linear with V held over the step, so the exact
// exponential solution is used and, since T moves monotonically within a step, one
// hysteresis update per step is exact. With thermal effects the ODE is sub-stepped (Heun, at
// most kSubstep), and latent heat enters as an effective heat capacity C + L d(eps)/dT along the
// current branch.
#ifndef SMA_PLANT_HPP
#define SMA_PLANT_HPP

#if defined(__AVR__)
#error "sma_host/plant.hpp is the host-side simulated rig; the firmware includes sma_model.h only"
#endif

#include <stdint.h>
#include "sma/effects.hpp"
#include "sma/hysteresis.hpp"
#include "sma/mechanics.hpp"
#include "sma/params.hpp"
#include "sma/scalar.hpp"
#include "sma/thermal.hpp"

namespace sma {

// What the rig adds around the wire (model.md, "rig-like" conditions). Zero = ideal.
struct RigOptions {
  double noise_mm = 0.0;      // RMS of white displacement noise
  double adc_step_mm = 0.0;   // sensor quantisation (ADC count), 0 = continuous
  double v_supply = 5.0;      // PWM supply, duty = (V / v_supply)^2
  uint32_t pwm_top = 0;       // PWM levels (duty = n / pwm_top), 0 = continuous
  uint64_t seed = 1;          // noise seed: runs are repeatable

  static RigOptions rig_like() {  // model.md: 2 um noise, 2 um ADC step, 14-bit PWM at 1 kHz
    RigOptions o;
    o.noise_mm = 0.002;
    o.adc_step_mm = 0.002;
    o.pwm_top = 15999;
    return o;
  }
};

// Small deterministic Gaussian generator (xorshift64* + Box-Muller): no STL, same numbers
// on every platform for a seed.
class Noise {
 public:
  explicit Noise(uint64_t seed = 1) : s_(seed ? seed : 1) {}
  double uniform() {  // (0, 1)
    s_ ^= s_ >> 12;
    s_ ^= s_ << 25;
    s_ ^= s_ >> 27;
    return (static_cast<double>((s_ * 2685821657736338717ULL) >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  }
  double gauss() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u = uniform(), v = uniform();
    const double r = ::sqrt(-2.0 * ::log(u));
    spare_ = r * ::sin(2.0 * kPi * v);
    has_spare_ = true;
    return r * ::cos(2.0 * kPi * v);
  }

 private:
  uint64_t s_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

class Plant {
 public:
  static constexpr int kHistory = 8192;  // sensor-delay history (samples)
  // Sub-step of the non-linear thermal ODE: 5 ms keeps the displacement within 0.5 um of a
  // 0.1 ms integration (tau = 4 s; measured in test_plant.cpp).
  static constexpr double kSubstep = 5e-3;

  Plant(const Params& p, const Effects& fx = Effects(), const RigOptions& rig = RigOptions())
      : fx_(fx),
        rig_(rig),
        thermal_(p, fx),
        curves_(p),
        hyst_(curves_, fx.ambient_C(p.T_amb), 0.0),
        mech_(p, fx),
        noise_(rig.seed) {
    reset(fx.ambient_C(p.T_amb), 0.0);
  }
  Plant(const Plant&) = delete;  // hyst_ points into curves_
  Plant& operator=(const Plant&) = delete;

  // At rest at Tw with fraction eps (a log may start mid-transformation).
  void reset(double Tw, double eps) {
    T_ = Tw;
    hyst_.reset(Tw, eps);
    t_ = 0.0;
    lag_ = sensed_true();
    head_ = 0;
    count_ = 0;
    push_history(lag_);
  }

  // The voltage the PWM really applies for a commanded V (duty quantised to pwm_top levels).
  double applied_voltage(double V) const {
    V = clamp(V, 0.0, rig_.v_supply);
    if (!(V > 0.0)) return 0.0;
    if (rig_.pwm_top == 0) return V;
    const double duty = (V / rig_.v_supply) * (V / rig_.v_supply);
    const double n = ::floor(duty * rig_.pwm_top + 0.5);
    return rig_.v_supply * ::sqrt(n / rig_.pwm_top);
  }

  // Advance dt seconds with V (commanded, effective volts) held.
  void step(double V, double dt) {
    if (!(dt > 0.0)) return;
    const double v = applied_voltage(is_finite(V) ? V : 0.0);
    if (thermal_.plain) {
      // Exact solution of the linear eq 1 over dt.
      const double Tss = thermal_.steady_state(v);
      T_ = Tss + (T_ - Tss) * ::exp(-dt / thermal_.time_constant());
      hyst_.update(T_);
    } else {
      const int n = static_cast<int>(::ceil(dt / kSubstep));
      const double h = dt / n;
      for (int k = 0; k < n; ++k) substep(v, h);
    }
    t_ += dt;
    update_sensor(dt);
  }

  // Ground truth.
  double temperature() const { return T_; }
  double fraction() const { return hyst_.eps(); }
  double displacement() const { return mech_.displacement(hyst_.eps(), T_); }  // eq 12 + expansion
  double time() const { return t_; }
  const Hysteresis<double>& hysteresis() const { return hyst_; }

  // What the sensor reports now: calibration, lag, delay, then noise and ADC step.
  double measure() {
    double y = delayed();
    if (rig_.noise_mm > 0.0) y += rig_.noise_mm * noise_.gauss();
    if (rig_.adc_step_mm > 0.0) y = rig_.adc_step_mm * ::floor(y / rig_.adc_step_mm + 0.5);
    return y;
  }
  // The sensor without noise or quantisation (for tests of the effects themselves).
  double measure_clean() const { return delayed(); }

 private:
  double sensed_true() const { return fx_.sensor_gain * displacement() + fx_.sensor_offset_mm; }

  void substep(double v, double h) {
    const double eps = hyst_.eps();
    // Heun's method on the non-latent part of the power balance.
    const double r1 = thermal_.rate(T_, v, eps);
    const double r2 = thermal_.rate(T_ + h * r1, v, eps);
    double dT = 0.5 * h * (r1 + r2);
    if (thermal_.L > 0.0 && dT != 0.0) {
      // Latent heat: the slope d(eps)/dT of the branch this move follows, probed on a copy.
      Hysteresis<double> probe = hyst_;
      const double slope = (probe.update(T_ + dT) - eps) / dT;
      const double c_eff = max(thermal_.C + thermal_.L * slope, 0.2 * thermal_.C);
      dT *= thermal_.C / c_eff;
    }
    T_ += dT;
    hyst_.update(T_);
  }

  void update_sensor(double dt) {
    const double target = sensed_true();
    if (fx_.sensor_lag_s > 0.0)
      lag_ += (target - lag_) * (1.0 - ::exp(-dt / fx_.sensor_lag_s));
    else
      lag_ = target;
    push_history(lag_);
  }

  void push_history(double y) {
    hist_t_[head_] = t_;
    hist_y_[head_] = y;
    head_ = (head_ + 1) % kHistory;
    if (count_ < kHistory) ++count_;
  }

  // The lagged signal at t - delay, linear between stored samples.
  double delayed() const {
    const int newest = (head_ + kHistory - 1) % kHistory;
    if (!(fx_.sensor_delay_s > 0.0)) return hist_y_[newest];
    const double tq = t_ - fx_.sensor_delay_s;
    int i = newest;
    for (int k = 1; k < count_; ++k) {
      const int older = (i + kHistory - 1) % kHistory;
      if (hist_t_[older] <= tq) {
        const double span = hist_t_[i] - hist_t_[older];
        const double w = span > 0.0 ? (tq - hist_t_[older]) / span : 1.0;
        return hist_y_[older] + w * (hist_y_[i] - hist_y_[older]);
      }
      i = older;
    }
    return hist_y_[i];  // before the start of the run: the oldest value
  }

  Effects fx_;
  RigOptions rig_;
  Thermal<double> thermal_;
  PhaseCurves<double> curves_;
  Hysteresis<double> hyst_;
  Mechanics<double> mech_;
  Noise noise_;
  double T_ = 22.0, t_ = 0.0, lag_ = 0.0;
  double hist_t_[kHistory];
  double hist_y_[kHistory];
  int head_ = 0, count_ = 0;
};

}  // namespace sma

#endif  // SMA_PLANT_HPP
