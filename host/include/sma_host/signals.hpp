// Open-loop voltage signals for identification and for testing the discrepancy workflow.
//  - training_ramp: the paper's training signal (section III.B, Fig. 4): slow voltage ramps up
//    to decaying peaks, each followed by a ramp back down, so that the wire passes through the
//    major loop and then minor loops of decreasing peak temperature, quasi-statically
//    (the paper's slope is 5.88e-3 V/s; tests use a faster one to keep logs short);
//  - voltage_steps: a staircase up through the transformation and back, with holds long
//    enough (several tau) for steady states: excites the dynamics that the ramp hides.
#ifndef SMA_HOST_SIGNALS_HPP
#define SMA_HOST_SIGNALS_HPP

#include <math.h>
#include <vector>

namespace sma_host {

struct VoltageSignal {
  std::vector<double> t, v;  // V(t) held from t[k] to t[k + 1]
};

struct TrainingRamp {
  double slope_V_per_s = 5.88e-3;                       // the paper's
  std::vector<double> peaks_V = {1.60, 1.42, 1.36, 1.31, 1.26};  // decaying peaks
  double floor_V = 0.0;                                 // where each ramp down ends
  double hold_s = 5.0;                                  // rest at the floor before the next ramp
};

inline VoltageSignal training_ramp(const TrainingRamp& r, double dt = 0.01) {
  VoltageSignal s;
  double t = 0, v = r.floor_V;
  auto emit = [&](double target) {
    const double sign = target > v ? 1.0 : -1.0;
    while ((target - v) * sign > 1e-12) {
      s.t.push_back(t);
      s.v.push_back(v);
      t += dt;
      v += sign * r.slope_V_per_s * dt;
      if ((target - v) * sign < 0) v = target;
    }
  };
  auto hold = [&](double seconds) {
    for (double h = 0; h < seconds - 1e-9; h += dt) {
      s.t.push_back(t);
      s.v.push_back(v);
      t += dt;
    }
  };
  hold(r.hold_s);
  for (double peak : r.peaks_V) {
    emit(peak);
    emit(r.floor_V);
    hold(r.hold_s);
  }
  return s;
}

inline VoltageSignal voltage_steps(const std::vector<double>& levels_V, double hold_s, double dt = 0.01) {
  VoltageSignal s;
  double t = 0;
  for (double level : levels_V)
    for (double h = 0; h < hold_s - 1e-9; h += dt) {
      s.t.push_back(t);
      s.v.push_back(level);
      t += dt;
    }
  return s;
}

// Default staircase: through the transformation, a minor loop, and back to cold.
inline VoltageSignal default_steps(double dt = 0.01) {
  return voltage_steps({0.0, 1.2, 1.35, 1.5, 1.3, 1.7, 1.0, 0.6, 1.4, 0.0}, 20.0, dt);
}

}  // namespace sma_host

#endif  // SMA_HOST_SIGNALS_HPP
