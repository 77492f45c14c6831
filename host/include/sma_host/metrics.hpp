// Tracking metrics of a closed-loop run (model.md, "Metrics a user would agree with").
//
// Whole-run figures (what a user sees on the plot):
//  - max_mm, rms_mm: |ref - position| over the whole scored run (the sine's first period is a
//    start-up transient from a cold wire and is skipped; steps are scored from t = 0);
//  - per phase, transitions included: "rise" = the reference rises (sine) or the segment after
//    an up-step (the jump, the transient and the hold); "fall" = it falls / after a down-step;
//  - wrong_way_mm: after each reversal of the reference (sine peak or valley) or step, how far
//    the position first moves away from the new direction (e.g. up after a down-step: the
//    minor-loop rise of eqs 5-6), measured from where it was at the reversal;
//  - wrong_way_before_mm: steps: once the position has arrived at a setpoint, how far it then
//    passes it on the side away from the NEXT setpoint before that step comes (a controller that
//    knows the future may cool early for a down-step and take the minor-loop rise while the
//    setpoint still holds: wrong_way_mm, measured after the step, does not see that move);
//  - settle_s / settle_max_s: steps: mean / worst time to come within 5 % of the step and stay.
//  - sse_mm: steps: for each step, the smallest |mean error| over a 2 s window (0.5 s apart) in
//    the step's second half, each of the window's seconds apart (the larger of the two: a
//    position passing through the setpoint is not at rest on it); the max over steps. A step that never sits on its setpoint has
//    a large one; a controller that leaves a setpoint early for the next move (preview) is not
//    charged for it here (the whole-run figures charge it).
// Any reference (a user's trajectory: ramps, holds, jumps; reference_metrics()): the same
// whole-run set read from the reference the run recorded: a hold is a stretch where it stays, a
// move one where it changes; rise / fall follow the direction of its last move (a hold belongs
// to the move that reached it); wrong-way from where each move starts (after a hold, or at a
// reversal); wrong-way before, SSE and time to 5 % per hold (time to 5 %: from when the
// reference arrives, of the move since the hold before; SSE as for a step, over the hold). A
// hold lasts kMinHoldS or more: a slow ramp logged to a few decimals repeats values.
// Paper-style figures, kept beside them and labelled as such (they count only part of the run):
//  - max_heat_mm, rms_heat_mm, max_cool_mm: sine: while the reference rises / falls (same as
//    the phases); steps: from the first arrival at the new setpoint on (so the jump and a
//    wrong-way move before arrival are not counted), a step never reached counts its last 2 s.
//  - overshoot_pct: steps: max excursion past a setpoint after arriving, % of the step.
#ifndef SMA_HOST_METRICS_HPP
#define SMA_HOST_METRICS_HPP

#include <math.h>
#include <cmath>
#include <vector>
#include "closed_loop.hpp"

namespace sma_host {

struct Metrics {
  // Whole run.
  double max_mm = 0;        // max |ref - position|
  double rms_mm = 0;        // RMS of ref - position
  double max_rise_mm = 0;   // reference rising / after an up-step, transitions included
  double rms_rise_mm = 0;
  double max_fall_mm = 0;   // reference falling / after a down-step, transitions included
  double rms_fall_mm = 0;
  double wrong_way_mm = 0;  // max move away from the new direction after a reversal or step
  double wrong_way_before_mm = 0;  // steps: past a held setpoint, away from the next one
  double settle_s = 0;      // steps: mean time to enter and stay within 5 % of the step
  double settle_max_s = 0;  // steps: worst such time
  double sse_mm = 0;        // steps: steady-state error (see the header comment)
  // Paper-style (partial: see the header comment).
  double max_heat_mm = 0;
  double rms_heat_mm = 0;
  double max_cool_mm = 0;
  double overshoot_pct = 0;
};

// Which error the metrics score: the true position (default) or the measured one.
inline double err_of(const Sample& s, bool measured) {
  return s.ref - (measured ? s.meas : s.truth);
}
inline double pos_of(const Sample& s, bool measured) { return measured ? s.meas : s.truth; }

namespace detail {
// Sums for max / RMS of one class of samples.
struct Acc {
  double max = 0, sq = 0;
  long n = 0;
  void add(double e) {
    e = fabs(e);
    if (e > max) max = e;
    sq += e * e;
    ++n;
  }
  double rms() const { return n ? sqrt(sq / static_cast<double>(n)) : 0.0; }
};
// Wrong-way excursion from sample k0 to end (exclusive) when the reference now moves `up`.
inline double wrong_way(const std::vector<Sample>& run, size_t k0, size_t end, bool up, bool measured) {
  const double y0 = pos_of(run[k0], measured);
  double w = 0;
  for (size_t k = k0; k < end; ++k) {
    const double away = up ? y0 - pos_of(run[k], measured) : pos_of(run[k], measured) - y0;
    if (away > w) w = away;
  }
  return w;
}
// The smallest |mean error| over 2 s windows, 0.5 s apart, in the second half of [k0, end).
inline double steady_error(const std::vector<Sample>& run, size_t k0, size_t end, bool measured) {
  const double t0 = run[k0].t, t1 = run[end - 1].t;
  double best = INFINITY;
  for (double w = 0.5 * (t0 + t1); w + 2.0 <= t1 + 1e-9; w += 0.5) {
    // Each second of the window apart: the larger |mean error| of the two. A position passing
    // through the setpoint has errors of both signs, and one mean over the whole window called
    // that a nil error; noise still averages out within each second.
    double sum[2] = {0, 0};
    long n[2] = {0, 0};
    for (size_t k = k0; k < end; ++k)
      if (run[k].t >= w - 1e-9 && run[k].t < w + 2.0 - 1e-9) {
        const int half = run[k].t >= w + 1.0 - 1e-9;
        sum[half] += err_of(run[k], measured);
        ++n[half];
      }
    if (n[0] && n[1])
      best = fmin(best, fmax(fabs(sum[0] / static_cast<double>(n[0])), fabs(sum[1] / static_cast<double>(n[1]))));
  }
  return std::isfinite(best) ? best : 0.0;
}

// The whole run's and each phase's max and RMS into m.
inline void put_phases(Metrics& m, const Acc& all, const Acc& rise, const Acc& fall) {
  m.max_mm = all.max;
  m.rms_mm = all.rms();
  m.max_rise_mm = rise.max;
  m.rms_rise_mm = rise.rms();
  m.max_fall_mm = fall.max;
  m.rms_fall_mm = fall.rms();
}
}  // namespace detail

inline Metrics sine_metrics(const std::vector<Sample>& run, double period_s, bool measured = false) {
  Metrics m;
  detail::Acc all, rise, fall;
  int dir = 0;          // +1 rising, -1 falling, 0 unknown
  size_t phase_start = 0;
  bool phase_scored = false;
  auto close_phase = [&](size_t end) {
    if (phase_scored && dir != 0)
      m.wrong_way_mm = fmax(m.wrong_way_mm, detail::wrong_way(run, phase_start, end, dir > 0, measured));
  };
  for (size_t k = 1; k < run.size(); ++k) {
    const double dr = run[k].ref - run[k - 1].ref;
    const int d = dr > 0 ? 1 : dr < 0 ? -1 : dir;
    if (d != dir) {
      close_phase(k);
      // A reversal inside the scored part opens a phase whose wrong-way move is scored.
      phase_scored = dir != 0 && run[k].t >= period_s;
      dir = d;
      phase_start = k - 1;
    }
    if (run[k].t < period_s) continue;
    const double e = err_of(run[k], measured);
    all.add(e);
    if (d > 0) rise.add(e);
    if (d < 0) fall.add(e);
  }
  close_phase(run.size());
  detail::put_phases(m, all, rise, fall);
  // On a sine the paper's heating / cooling are exactly the rising / falling phases.
  m.max_heat_mm = rise.max;
  m.rms_heat_mm = rise.rms();
  m.max_cool_mm = fall.max;
  return m;
}

// Steps: how far the position passes each new setpoint in the step's direction (up: above
// it, down: below it) within the first window_s of the step, the max over the steps, mm. The
// window leaves out a deliberate early departure towards the next step.
inline double step_overshoot_mm(const std::vector<Sample>& run, double step_s, double window_s,
                                bool measured = false) {
  double over = 0;
  size_t start = 0;
  while (start < run.size()) {
    size_t end = start;
    while (end < run.size() && run[end].t < run[start].t + step_s - 1e-9) ++end;
    const double step = run[start].ref - (start > 0 ? run[start - 1].ref : 0.0);
    if (fabs(step) > 1e-9)
      for (size_t k = start; k < end && run[k].t < run[start].t + window_s; ++k)
        over = fmax(over, step > 0 ? -err_of(run[k], measured) : err_of(run[k], measured));
    start = end;
  }
  return over;
}

inline Metrics step_metrics(const std::vector<Sample>& run, double step_s, bool measured = false) {
  Metrics m;
  detail::Acc all, rise, fall, heat;
  double settle_sum = 0;
  long n_settle = 0;
  size_t start = 0;
  while (start < run.size()) {
    size_t end = start;
    while (end < run.size() && run[end].t < run[start].t + step_s - 1e-9) ++end;
    const double r = run[start].ref;
    const double prev = start > 0 ? run[start - 1].ref : 0.0;
    const double step = r - prev;
    const bool up = step > 0;
    detail::Acc& phase = up ? rise : fall;
    bool arrived = false;
    // The next setpoint's side: a move past r on the other side, after arriving, is wrong-way.
    const double next_dir = end < run.size() ? run[end].ref - r : 0.0;
    double last_out = run[start].t;  // last time outside the 5 % band
    double tail_sum = 0, tail_sq = 0, tail_max = 0;
    long tail_n = 0;
    for (size_t k = start; k < end; ++k) {
      const double e = err_of(run[k], measured);
      all.add(e);
      if (fabs(step) > 1e-9) phase.add(e);
      if (!arrived && (up ? e <= 0 : e >= 0)) arrived = true;
      if (arrived) {
        if (up) heat.add(e);
        else if (fabs(e) > m.max_cool_mm) m.max_cool_mm = fabs(e);
        const double over = up ? -e : e;  // past the setpoint
        if (next_dir > 1e-9 || next_dir < -1e-9)  // e = r - pos: positive below the setpoint
          m.wrong_way_before_mm = fmax(m.wrong_way_before_mm, next_dir > 0 ? e : -e);
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
    if (fabs(step) > 1e-9) {
      m.wrong_way_mm = fmax(m.wrong_way_mm, detail::wrong_way(run, start, end, up, measured));
      if (start > 0) {
        const double ts = last_out - run[start].t;
        settle_sum += ts;
        m.settle_max_s = fmax(m.settle_max_s, ts);
        ++n_settle;
      }
    }
    if (tail_n) m.sse_mm = fmax(m.sse_mm, detail::steady_error(run, start, end, measured));
    // Paper-style: a step the position never reached has its last 2 s as its error.
    if (!arrived && fabs(step) > 1e-9 && tail_n) {
      if (up) {
        heat.max = fmax(heat.max, tail_max);
        heat.sq += tail_sq;
        heat.n += tail_n;
      } else {
        m.max_cool_mm = fmax(m.max_cool_mm, tail_max);
      }
    }
    start = end;
  }
  detail::put_phases(m, all, rise, fall);
  m.settle_s = n_settle ? settle_sum / static_cast<double>(n_settle) : 0;
  m.max_heat_mm = heat.max;
  m.rms_heat_mm = heat.rms();
  return m;
}

// The whole-run set for any reference (the header comment), scored from t = from_s (0: the
// whole run; a sine's first period is a start-up transient: sine_metrics skips it). The run's
// start counts as a hold at 0 mm (a cold wire): its first setpoint is a move up. The paper-style
// figures are left at 0.
constexpr double kMinHoldS = 0.5;

inline Metrics reference_metrics(const std::vector<Sample>& run, double from_s = 0.0, bool measured = false) {
  Metrics m;
  if (run.empty()) return m;
  detail::Acc all, rise, fall;
  double settle_sum = 0;
  long n_settle = 0;
  const size_t n = run.size();
  // A move's start: the sample before the reference leaves a hold or turns, with its direction.
  size_t move_k = 0;
  int dir = run[0].ref > 0 ? 1 : run[0].ref < 0 ? -1 : 0;
  double hold_mm = 0.0;  // the last hold's value (the run starts from a cold wire at 0)
  auto close_move = [&](size_t end) {
    if (dir != 0 && run[move_k].t >= from_s - 1e-9)
      m.wrong_way_mm = fmax(m.wrong_way_mm, detail::wrong_way(run, move_k, end, dir > 0, measured));
  };
  size_t k = 0;
  while (k < n) {
    // The stretch [k, h) where the reference stays at run[k].ref.
    size_t h = k + 1;
    while (h < n && run[h].ref == run[k].ref) ++h;
    const bool hold = run[h - 1].t - run[k].t >= kMinHoldS - 1e-9;
    if (hold) {  // arrival, wrong-way before the next move, time to 5 %, SSE
      const double r = run[k].ref, move = r - hold_mm;
      const double next_dir = h < n ? run[h].ref - r : 0.0;
      bool arrived = false;
      double last_out = run[k].t;
      for (size_t i = k; i < h; ++i) {
        const double e = err_of(run[i], measured);
        if (!arrived && (move > 0 ? e <= 0 : e >= 0)) arrived = true;
        if (arrived && next_dir != 0.0 && run[i].t >= from_s - 1e-9)
          m.wrong_way_before_mm = fmax(m.wrong_way_before_mm, next_dir > 0 ? e : -e);
        if (fabs(e) > 0.05 * fabs(move)) last_out = run[i].t;
      }
      if (move != 0.0 && run[k].t >= from_s - 1e-9) {
        const double ts = last_out - run[k].t;
        settle_sum += ts;
        m.settle_max_s = fmax(m.settle_max_s, ts);
        ++n_settle;
        m.sse_mm = fmax(m.sse_mm, detail::steady_error(run, k, h, measured));
      }
      hold_mm = r;
    }
    // The samples of the stretch, and where the next move starts: its last sample (h - 1) is
    // where the wire is when the reference leaves it (a reversal inside a ramp: the turn).
    for (size_t i = k; i < h; ++i) {
      if (run[i].t < from_s - 1e-9) continue;
      const double e = err_of(run[i], measured);
      all.add(e);
      if (dir > 0) rise.add(e);
      if (dir < 0) fall.add(e);
    }
    if (h < n) {
      const int d = run[h].ref > run[h - 1].ref ? 1 : -1;
      if (hold || d != dir) {
        close_move(h);
        move_k = h - 1;
        dir = d;
      }
    }
    k = h;
  }
  close_move(n);
  detail::put_phases(m, all, rise, fall);
  m.settle_s = n_settle ? settle_sum / static_cast<double>(n_settle) : 0;
  return m;
}

}  // namespace sma_host

#endif  // SMA_HOST_METRICS_HPP
