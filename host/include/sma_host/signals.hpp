// Open-loop voltage signals for identification and for testing the discrepancy workflow.
//  - TrainingSignal: the paper's training signal (section III.B, Fig. 4), below;
//  - voltage_steps: a staircase up through the transformation and back, with holds long
//    enough (several tau) for steady states: excites the dynamics that the ramp hides.
#ifndef SMA_HOST_SIGNALS_HPP
#define SMA_HOST_SIGNALS_HPP

#include <math.h>
#include <algorithm>
#include <utility>
#include <vector>
#include "sma/training.hpp"

namespace sma_host {

struct VoltageSignal {
  std::vector<double> t, v;  // V(t) held from t[k] to t[k + 1]
};

// The paper's training signal: sma::TrainingPlan (sma/training.hpp, shared with the firmware's
// built-in training run), with a vector of peaks for convenience on the host.
struct TrainingSignal {
  sma::TrainingPlan plan;  // slope, floor, hold, probe_s (peaks and probes are set from the vectors)
  std::vector<double> peaks = std::vector<double>(plan.peaks, plan.peaks + plan.n_peaks);
  std::vector<double> probes = std::vector<double>(plan.probes, plan.probes + plan.n_probes);

  TrainingSignal() = default;

  // nullptr if the signal can be built, else the problem.
  const char* check() const {
    if (peaks.size() > sma::kMaxTrainingPeaks) return "at most 12 peaks";
    if (probes.size() > sma::kMaxTrainingProbes) return "at most 8 probe levels";
    return resolved().check();
  }

  sma::TrainingPlan resolved() const {
    sma::TrainingPlan p = plan;
    p.n_peaks = static_cast<uint8_t>(std::min<size_t>(peaks.size(), sma::kMaxTrainingPeaks));
    for (uint8_t k = 0; k < p.n_peaks; ++k) p.peaks[k] = peaks[k];
    p.n_probes = static_cast<uint8_t>(std::min<size_t>(probes.size(), sma::kMaxTrainingProbes));
    for (uint8_t k = 0; k < p.n_probes; ++k) p.probes[k] = probes[k];
    return p;
  }

  // Sampled every dt (V held over each sample): the plan's own voltage_at().
  VoltageSignal sample(double dt = 0.01) const {
    const sma::TrainingPlan p = resolved();
    VoltageSignal s;
    const double end = p.duration();
    for (double t = 0.0, k = 0.0; t < end; t = ++k * dt) {  // k counts: no drift of t
      s.t.push_back(t);
      s.v.push_back(p.voltage_at(t));
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

// Default staircase: the training run's probe (through the transformation, a minor loop, back
// to cold), between 20 s at rest before and after.
inline VoltageSignal default_steps(double dt = 0.01) {
  const sma::TrainingPlan plan;
  std::vector<double> levels(1, 0.0);
  levels.insert(levels.end(), plan.probes, plan.probes + plan.n_probes);
  levels.push_back(0.0);
  return voltage_steps(levels, 20.0, dt);
}

}  // namespace sma_host

#endif  // SMA_HOST_SIGNALS_HPP
