// Open-loop voltage signals for identification and for testing the discrepancy workflow.
//  - TrainingSignal: the paper's training signal (section III.B, Fig. 4), below;
//  - voltage_steps: a staircase up through the transformation and back, with holds long
//    enough (several tau) for steady states: excites the dynamics that the ramp hides.
#ifndef SMA_HOST_SIGNALS_HPP
#define SMA_HOST_SIGNALS_HPP

#include <math.h>
#include <utility>
#include <vector>

namespace sma_host {

struct VoltageSignal {
  std::vector<double> t, v;  // V(t) held from t[k] to t[k + 1]
};

// The paper's training signal (section III.B, Fig. 4): a slow voltage ramp up and down at
// +-slope whose peaks decay from cycle to cycle, so that the wire runs the major loop and then
// minor loops of decreasing peak temperature, each cooled back to martensite.
// Default peaks: 2.0 V first (a full transformation even for a wire that loses 50 % more heat
// than the paper's: eq 10 with eps_h ~ 1), then a dense decaying series 1.6 .. 1.2 V whose peak
// temperatures cover T_s..T_f of wires around the paper's (minor loops, eqs 5-9) and fall just
// below T_s (eq 10 with a small eps_h, which separates q from e). Each descent goes down to
// `floor_V` and holds there so the wire is martensite again. Measured on a simulated wire
// (tools/tests): 12 peaks leave the minor-loop parameters well enough fixed that a closed-loop
// sine the fit never saw is predicted to the noise level; 7 peaks (one hour less) leave ~4x the
// noise. The optional probe (a step to probe_V, then off) excites the thermal time constant,
// which a quasi-static ramp barely shows: without it h and the transformation temperatures
// slide together (errors up to 0.6 K / 0.9 % instead of 0.1 K / 0.2 %).
struct TrainingSignal {
  double slope = 5.88e-3;  // V/s, both directions (paper)
  std::vector<double> peaks = {2.0, 1.6, 1.55, 1.5, 1.46, 1.42, 1.39, 1.36, 1.33, 1.3, 1.25, 1.2};
  double floor_V = 0.0;
  double hold_s = 20.0;    // at the floor after each descent (and at the start)
  double probe_V = 1.6;    // 0: no probe
  double probe_s = 30.0;   // on, then off, for this long each

  // nullptr if the signal can be built, else the problem.
  const char* check() const {
    if (!(slope > 0.0)) return "slope must be > 0";
    for (double p : peaks)
      if (!(p > floor_V)) return "every peak must be above the floor";
    return nullptr;
  }

  // Breakpoints (t, V) of the piecewise-linear signal; a repeated time is a jump.
  std::vector<std::pair<double, double>> breakpoints() const {
    std::vector<std::pair<double, double>> b;
    double t = 0.0;
    b.emplace_back(t, floor_V);
    t += hold_s;
    b.emplace_back(t, floor_V);
    for (double p : peaks) {
      t += (p - floor_V) / slope;
      b.emplace_back(t, p);
      t += (p - floor_V) / slope;
      b.emplace_back(t, floor_V);
      t += hold_s;
      b.emplace_back(t, floor_V);
    }
    if (probe_V > 0.0) {
      b.emplace_back(t, probe_V);
      t += probe_s;
      b.emplace_back(t, probe_V);
      b.emplace_back(t, 0.0);
      t += probe_s;
      b.emplace_back(t, 0.0);
    }
    return b;
  }

  // Sampled every dt (V held over each sample).
  VoltageSignal sample(double dt = 0.01) const {
    const std::vector<std::pair<double, double>> b = breakpoints();
    VoltageSignal s;
    size_t i = 0;
    for (double t = 0.0; t < b.back().first; t += dt) {
      while (i + 1 < b.size() && b[i + 1].first <= t) ++i;
      const double span = i + 1 < b.size() ? b[i + 1].first - b[i].first : 0.0;
      s.t.push_back(t);
      s.v.push_back(span > 0.0 ? b[i].second + (t - b[i].first) / span * (b[i + 1].second - b[i].second)
                               : b[i].second);
    }
    return s;
  }
};

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
