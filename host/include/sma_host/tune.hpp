// Tuning: every controller is tuned for its own best result by the same method, never
// handicapped. Method: a coarse log-grid over its settings ((kp, ki, kd) for the PID modes;
// (track_s, offset_tau_s) for the preview controller, its trade-off cool_weight being the
// user's choice; the lead lead_s of inverse + PID with the known future on a grid, each lead
// with its own tuned (kp, ki, kd)), then coordinate descent with shrinking factors around the best point. Each
// controller is tuned per test and condition, for an objective (metrics.hpp):
//  - HeatingOnly (the paper's figure): max |error| while heating + 0.1x the RMS error;
//  - WholeRun (what the plot shows): whole-run RMS + 0.1x the whole-run max.
// On steps a run that does not reach zero steady-state error (sse_mm < 5 um) is rejected.
// Each setting is scored by the worse of its double and float runs (robust_cost); the
// fixed-point build reuses it.
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

enum class Objective { HeatingOnly, WholeRun };

inline const char* objective_name(Objective o) {
  return o == Objective::WholeRun ? "whole-run RMS + 0.1 max" : "max heating + 0.1 RMS";
}

inline double tune_cost(const RunSetup& s, const Metrics& m, Objective o = Objective::HeatingOnly) {
  if (s.reference.kind != sma::RefKind::Sine && !(m.sse_mm < 0.005)) return INFINITY;
  if (o == Objective::WholeRun) return m.rms_mm + 0.1 * m.max_mm;
  return m.max_heat_mm + 0.1 * m.rms_mm;
}

// The worse of the double and float runs: on this plant a gain set can sit on a knife edge
// where a rounding difference decides whether the wire overshoots into a minor loop (from
// which it cannot come back without cooling to T_MSi). Such a set is not a real optimum.
inline double robust_cost(const RunSetup& s, const sma::PidGains& g, Metrics* m_double,
                          Objective o = Objective::HeatingOnly) {
  const Metrics md = evaluate<double>(s, g);
  if (m_double) *m_double = md;
  const double cd = tune_cost(s, md, o);
  if (!std::isfinite(cd)) return cd;
  return fmax(cd, tune_cost(s, evaluate<float>(s, g), o));
}

inline TuneResult tune_pid(const RunSetup& base, Objective o = Objective::HeatingOnly) {
  TuneResult best;
  auto consider = [&](sma::PidGains g) {
    Metrics m;
    const double c = robust_cost(base, g, &m, o);
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

struct LeadTuneResult {
  double lead_s = 0.0;
  TuneResult pid;  // the gains tuned for that lead
};

// Inverse + PID with the known future (LeadConfig::lead_s): the lead on a grid from 1 s
// (about the reversal's reheat) to 12 s (past the ~9 s that the wire takes to cool passively
// from the top of its stroke to T_MSi), each with its PID tuned as tune_pid does; the best by
// the same objective.
inline LeadTuneResult tune_lead(RunSetup base, Objective o = Objective::WholeRun) {
  base.mode = sma::Mode::FeedforwardPid;
  LeadTuneResult best;
  for (double lead : {1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0}) {
    base.lead.lead_s = lead;
    const TuneResult r = tune_pid(base, o);
    if (r.cost < best.pid.cost) {
      best.lead_s = lead;
      best.pid = r;
    }
  }
  return best;
}

struct PreviewTuneResult {
  sma::PreviewConfig config;
  double cost = INFINITY;
  Metrics metrics;
  int evaluations = 0;
};

// The preview controller's two settings, by the same method: a coarse grid, then coordinate
// descent with shrinking factors; scored by the worse of double and float.
inline PreviewTuneResult tune_preview(RunSetup base, Objective o = Objective::WholeRun) {
  base.mode = sma::Mode::Preview;
  PreviewTuneResult best;
  auto consider = [&](sma::PreviewConfig c) {
    if (c.check()) return;
    RunSetup s = base;
    s.preview = c;
    const std::vector<Sample> rd = run_closed_loop<double>(s), rf = run_closed_loop<float>(s);
    const bool sine = s.reference.kind == sma::RefKind::Sine;
    const Metrics md = sine ? sine_metrics(rd, s.reference.sine_period_s) : step_metrics(rd, s.reference.step_s);
    const Metrics mf = sine ? sine_metrics(rf, s.reference.sine_period_s) : step_metrics(rf, s.reference.step_s);
    const double cost = fmax(tune_cost(s, md, o), tune_cost(s, mf, o));
    ++best.evaluations;
    if (cost < best.cost) {
      best.cost = cost;
      best.config = c;
      best.metrics = md;
    }
  };
  for (double tr : {0.1, 0.2, 0.4, 0.8, 1.6})
    for (double tau : {0.3, 1.0, 3.0}) {
      sma::PreviewConfig c = base.preview;
      c.track_s = tr;
      c.offset_tau_s = tau;
      consider(c);
    }
  for (double f : {1.4, 1.15}) {
    for (int axis = 0; axis < 2; ++axis) {
      for (double mul : {f, 1.0 / f}) {
        sma::PreviewConfig c = best.config;
        (axis == 0 ? c.track_s : c.offset_tau_s) *= mul;
        consider(c);
      }
    }
  }
  return best;
}

// A controller set up as every benchmark runs it, tuned by the stated method for objective o:
// the preview by tune_preview, inverse + PID with the known future (`lead`) by tune_lead, PID
// alone and inverse + PID by tune_pid; the feedforward alone has nothing to tune.
inline RunSetup tuned(RunSetup s, sma::Mode mode, bool lead, Objective o) {
  s.mode = mode;
  if (mode == sma::Mode::Preview) {
    s.preview = tune_preview(s, o).config;
  } else if (lead) {
    const LeadTuneResult t = tune_lead(s, o);
    s.lead.lead_s = t.lead_s;
    s.config.gains = t.pid.gains;
  } else if (mode != sma::Mode::Feedforward) {
    s.config.gains = tune_pid(s, o).gains;
  }
  return s;
}

}  // namespace sma_host

#endif  // SMA_HOST_TUNE_HPP
