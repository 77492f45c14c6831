// Tuning: every controller is tuned for its own best result by the same method, never
// handicapped. Method: a coarse log-grid over (kp, ki, kd), then coordinate descent with
// shrinking factors around the best point. Each controller is tuned per test and condition,
// for the figure that test compares: the max |error| while heating (metrics.hpp), plus 0.1x
// the RMS error as a tie-breaker; on steps a run that does not reach zero steady-state error
// (< 5 um over the last 2 s of every step) is rejected. Each gain set is scored by the worse
// of its double and float runs (robust_cost); the fixed-point build reuses the gains.
#ifndef SMA_HOST_TUNE_HPP
#define SMA_HOST_TUNE_HPP

#include <math.h>
#include "closed_loop.hpp"
#include "metrics.hpp"

namespace sma_host {

struct TuneResult {
  sma::PidGains gains;
  double cost = INFINITY;
  Metrics metrics;
  int evaluations = 0;
};

// Metrics of one run of the setup's reference (sine or multi-step) with gains g, scalar T.
template <class T = double>
Metrics evaluate(RunSetup s, const sma::PidGains& g) {
  s.config.gains = g;
  const std::vector<Sample> run = run_closed_loop<T>(s);
  return s.reference.kind == sma::RefKind::Sine ? sine_metrics(run, s.reference.sine_period_s)
                                                : step_metrics(run, s.reference.step_s);
}

inline double tune_cost(const RunSetup& s, const Metrics& m) {
  if (s.reference.kind != sma::RefKind::Sine && !(m.sse_mm < 0.005)) return INFINITY;
  return m.max_heat_mm + 0.1 * m.rms_mm;
}

// The worse of the double and float runs: on this plant a gain set can sit on a knife edge
// where a rounding difference decides whether the wire overshoots into a minor loop (from
// which it cannot come back without cooling to T_MSi). Such a set is not a real optimum.
inline double robust_cost(const RunSetup& s, const sma::PidGains& g, Metrics* m_double) {
  const Metrics md = evaluate<double>(s, g);
  if (m_double) *m_double = md;
  const double cd = tune_cost(s, md);
  if (!std::isfinite(cd)) return cd;
  return fmax(cd, tune_cost(s, evaluate<float>(s, g)));
}

inline TuneResult tune_pid(const RunSetup& base) {
  TuneResult best;
  auto consider = [&](sma::PidGains g) {
    Metrics m;
    const double c = robust_cost(base, g, &m);
    ++best.evaluations;
    if (c < best.cost) {
      best.cost = c;
      best.gains = g;
      best.metrics = m;
    }
  };
  // Coarse grid: kp and ki in {0, 1/16 .. 128} (x2 steps), kd in {0, 0.1, 0.4}: from "almost
  // no feedback" to gains far past stability, so neither controller's optimum is cut off.
  static const double levels[] = {0,   0.0625, 0.125, 0.25, 0.5, 1,  2,
                                  4,   8,      16,    32,   64,  128};
  for (double kp : levels)
    for (double ki : levels)
      for (double kd : {0.0, 0.1, 0.4}) {
        sma::PidGains g = base.config.gains;
        g.kp = kp;
        g.ki = ki;
        g.kd = kd;
        consider(g);
      }
  // Coordinate descent with shrinking steps.
  for (double f : {1.6, 1.25, 1.1}) {
    for (int round = 0; round < 2; ++round) {
      for (int axis = 0; axis < 3; ++axis) {
        for (double mul : {f, 1.0 / f}) {
          sma::PidGains g = best.gains;
          double& x = axis == 0 ? g.kp : axis == 1 ? g.ki : g.kd;
          x = x * mul;  // a zero gain stays zero: the grid already chose it
          consider(g);
        }
      }
    }
  }
  return best;
}

}  // namespace sma_host

#endif  // SMA_HOST_TUNE_HPP
