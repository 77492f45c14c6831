// Tracking metrics of a closed-loop run, as the paper reads Fig. 10 and 13.
//  - heating / cooling: the reference rises / falls (sine), or the run is after an up / down
//    step (multi-step);
//  - the sine's first period is a start-up transient (the wire starts cold): it is skipped;
//  - on steps the jump itself is not a tracking error of the controller: heating/cooling errors
//    count from the first time the position reaches the new setpoint (that is overshoot and
//    the error while holding), and the rise is reported as the settling time; a step never
//    reached counts its last 2 s (where it settled short).
#ifndef SMA_HOST_METRICS_HPP
#define SMA_HOST_METRICS_HPP

#include <math.h>
#include <vector>
#include "closed_loop.hpp"

namespace sma_host {

struct Metrics {
  double rms_mm = 0;        // RMS of ref - truth over the scored part
  double max_heat_mm = 0;   // max |error| while heating
  double rms_heat_mm = 0;   // RMS error while heating (the part the controller drives; cooling is
                            // passive: the bias spring and the air set its error, not the model)
  double max_cool_mm = 0;   // max |error| while cooling
  double overshoot_pct = 0; // steps: max overshoot past a setpoint, % of the step
  double settle_s = 0;      // steps: mean time to enter and stay within 5 % of the step
  double sse_mm = 0;        // steps: max |mean error| over the last 2 s of each step
};

// Which error the metrics score: the true position (default) or the measured one.
inline double err_of(const Sample& s, bool measured) {
  return s.ref - (measured ? s.meas : s.truth);
}

inline Metrics sine_metrics(const std::vector<Sample>& run, double period_s, bool measured = false) {
  Metrics m;
  double sum = 0, heat_sum = 0;
  long n = 0, heat_n = 0;
  for (size_t k = 1; k < run.size(); ++k) {
    if (run[k].t < period_s) continue;
    const double e = fabs(err_of(run[k], measured));
    sum += e * e;
    ++n;
    const double dr = run[k].ref - run[k - 1].ref;
    if (dr > 0) {
      heat_sum += e * e;
      ++heat_n;
      if (e > m.max_heat_mm) m.max_heat_mm = e;
    }
    if (dr < 0 && e > m.max_cool_mm) m.max_cool_mm = e;
  }
  m.rms_mm = n ? sqrt(sum / static_cast<double>(n)) : 0;
  m.rms_heat_mm = heat_n ? sqrt(heat_sum / static_cast<double>(heat_n)) : 0;
  return m;
}

inline Metrics step_metrics(const std::vector<Sample>& run, double step_s, bool measured = false) {
  Metrics m;
  double sum = 0, settle_sum = 0, heat_sum = 0;
  long n = 0, n_settle = 0, heat_n = 0;
  size_t start = 0;
  while (start < run.size()) {
    size_t end = start;
    while (end < run.size() && run[end].t < run[start].t + step_s - 1e-9) ++end;
    const double r = run[start].ref;
    const double prev = start > 0 ? run[start - 1].ref : 0.0;
    const double step = r - prev;
    const bool up = step > 0;
    bool arrived = false;
    double last_out = run[start].t;  // last time outside the 5 % band
    double tail_sum = 0, tail_sq = 0, tail_max = 0;
    long tail_n = 0;
    for (size_t k = start; k < end; ++k) {
      const double e = err_of(run[k], measured);
      sum += e * e;
      ++n;
      if (!arrived && (up ? e <= 0 : e >= 0)) arrived = true;
      if (arrived) {
        if (up && fabs(e) > m.max_heat_mm) m.max_heat_mm = fabs(e);
        if (up) {
          heat_sum += e * e;
          ++heat_n;
        }
        if (!up && fabs(e) > m.max_cool_mm) m.max_cool_mm = fabs(e);
        const double over = up ? -e : e;  // past the setpoint
        if (fabs(step) > 1e-9 && over > 0)
          m.overshoot_pct = fmax(m.overshoot_pct, 100.0 * over / fabs(step));
      }
      if (fabs(e) > 0.05 * fabs(step)) last_out = run[k].t;
      if (run[k].t >= run[start].t + step_s - 2.0) {
        tail_sum += e;
        tail_sq += e * e;
        tail_max = fmax(tail_max, fabs(e));
        ++tail_n;
      }
    }
    if (start > 0) {
      settle_sum += last_out - run[start].t;
      ++n_settle;
    }
    if (tail_n) m.sse_mm = fmax(m.sse_mm, fabs(tail_sum / static_cast<double>(tail_n)));
    // A step the position never reached still has an error while heating (cooling): its last
    // 2 s, where it settled short of the setpoint.
    if (!arrived && fabs(step) > 1e-9 && tail_n) {
      if (up) {
        m.max_heat_mm = fmax(m.max_heat_mm, tail_max);
        heat_sum += tail_sq;
        heat_n += tail_n;
      } else {
        m.max_cool_mm = fmax(m.max_cool_mm, tail_max);
      }
    }
    start = end;
  }
  m.rms_mm = n ? sqrt(sum / static_cast<double>(n)) : 0;
  m.settle_s = n_settle ? settle_sum / static_cast<double>(n_settle) : 0;
  m.rms_heat_mm = heat_n ? sqrt(heat_sum / static_cast<double>(heat_n)) : 0;
  return m;
}

}  // namespace sma_host

#endif  // SMA_HOST_METRICS_HPP
