// The identification engine shared by `tools/sma fit` (sma_fit), `tools/sma discrepancy`
// (discrepancy.hpp) and `tools/sma sim --replay`: one way to run the model along a rig log,
// one initial-state rule, one noise estimator, one covariance -> intervals / correlations, one
// per-run sensor offset, one set of error statistics (whole run, heating and cooling halves).
//
//   log -> replay (the library's sma::Plant on the log's own v_V; no second copy of the model)
//       -> residual over named parameters (FitResidual, FitFunctor) -> Levenberg-Marquardt (Eigen)
//       -> uncertainty(J, r): s^2 (J^T J)^+ by SVD, 95 % intervals, correlations.
#ifndef SMA_HOST_IDENTIFY_HPP
#define SMA_HOST_IDENTIFY_HPP

#include <math.h>
#include <Eigen/Dense>
#include <algorithm>
#include <string>
#include <vector>
#include "error.hpp"
#include "model.hpp"
#include "rig_log.hpp"
#include "sma/effects.hpp"
#include "sma/hysteresis.hpp"
#include "sma/params.hpp"
#include "sma_host/plant.hpp"

namespace sma_host {

// The model's states along a log.
struct Trace {
  std::vector<double> d;    // what the sensor reports (clean unless noise asked), mm
  std::vector<double> D;    // true displacement, mm
  std::vector<double> T;    // wire temperature, deg C
  std::vector<double> eps;  // austenite fraction
};

// ---- the initial-state rule ----------------------------------------------------------------
// The wire is at rest when a log starts. Its austenite fraction is `eps0` when one is given
// (>= 0), else the one the model's sensor reads at the log's start: the mean of the first
// readings (up to 5), through the model's calibration backwards, eps = (d - offset) / gain / g,
// clamped to 0..1; below 0.02 (noise, a sensor zero a little off) it is 0. At fraction 0 the
// wire is at the ambient temperature T_amb (+ ambient_offset_K); at a fraction > 0 it sits on
// the major heating curve at that fraction (eq 15): a wire heated there and held.
inline double initial_fraction(const Model& m, const std::vector<double>& d, double eps0 = -1.0) {
  if (eps0 >= 0.0) return sma::clamp(eps0, 0.0, 1.0);
  if (d.empty()) return 0.0;
  const size_t n = std::min<size_t>(d.size(), 5);
  double d0 = 0.0;
  for (size_t k = 0; k < n; ++k) d0 += d[k] / static_cast<double>(n);
  const double eps = sma::clamp((d0 - m.fx.sensor_offset_mm) / m.fx.sensor_gain / m.p.g, 0.0, 1.0);
  return eps > 0.02 ? eps : 0.0;
}

inline void reset_to_initial_state(sma::Plant& plant, const Model& m, double eps) {
  if (eps > 0.0) {
    const sma::PhaseCurves<double> curves(m.p);
    plant.reset(curves.heat_temperature(eps), eps);
  } else {
    plant.reset(m.fx.ambient_C(m.p.T_amb), 0.0);
  }
}

// ---- per-run sensor offset -----------------------------------------------------------------
// The least-squares sensor zero of one run for a model: mean(measured - model). A potentiometer's
// zero moves between runs; this is the offset "fitted alone" on a run the model was not fitted on.
inline double best_offset(const std::vector<double>& measured, const std::vector<double>& model) {
  double s = 0.0;
  for (size_t k = 0; k < measured.size(); ++k) s += measured[k] - model[k];
  return measured.empty() ? 0.0 : s / static_cast<double>(measured.size());
}

struct ReplayOptions {
  sma::RigOptions rig;  // noise etc.; v_supply is raised to the log's largest V (no clamping)
  bool noisy = false;   // measure() (noise, ADC step) instead of measure_clean()
  double eps0 = -1.0;   // fraction at the start; < 0: from the log's first readings (the rule)
  size_t stride = 1;    // record every stride-th row (the simulation runs all rows)
  bool want_states = true;
};

// Row k of a rig log holds the displacement measured at t_k and the voltage applied from t_k
// to t_{k+1} (as the firmware logs it: measure, compute, apply). `d` is the log's displacement
// (for the initial-state rule; may be empty: fraction 0 unless eps0 is given).
template <class Sink>
void run_model(const Model& m, const std::vector<double>& t, const std::vector<double>& v,
               const std::vector<double>& d, const ReplayOptions& o, Sink sink) {
  sma::RigOptions rig = o.rig;
  double vmax = 0.0;
  for (double x : v) vmax = fabs(x) > vmax ? fabs(x) : vmax;
  if (vmax * 1.0001 > rig.v_supply) rig.v_supply = vmax * 1.0001;  // the plant clamps V to it
  sma::Plant plant(m.p, m.fx, rig);
  reset_to_initial_state(plant, m, initial_fraction(m, d, o.eps0));
  for (size_t k = 0; k < t.size(); ++k) {
    sink(k, plant);
    if (k + 1 < t.size()) plant.step(v[k], t[k + 1] - t[k]);
  }
}

inline void replay(const Model& m, const std::vector<double>& t, const std::vector<double>& v,
                   const std::vector<double>& d, const ReplayOptions& o, Trace& out) {
  const size_t stride = o.stride ? o.stride : 1;
  const size_t nout = (t.size() + stride - 1) / stride;
  out.d.assign(nout, 0.0);
  out.D.assign(o.want_states ? nout : 0, 0.0);
  out.T.assign(o.want_states ? nout : 0, 0.0);
  out.eps.assign(o.want_states ? nout : 0, 0.0);
  run_model(m, t, v, d, o, [&](size_t k, sma::Plant& plant) {
    if (k % stride) return;
    const size_t j = k / stride;
    out.d[j] = o.noisy ? plant.measure() : plant.measure_clean();
    if (o.want_states) {
      out.D[j] = plant.displacement();
      out.T[j] = plant.temperature();
      out.eps[j] = plant.fraction();
    }
  });
}

// A log of several runs (concatenate below): each run is replayed on its own. The first starts
// by the rule above; each later run starts at rest at the ambient temperature (fraction 0) and
// reads through its own sensor zero: the model's output on it is shifted by the least-squares
// offset of that run (a potentiometer's zero moves between runs).
inline Trace replay(const Model& m, const RigLog& log, const ReplayOptions& o = ReplayOptions()) {
  Trace tr;
  if (log.run_starts.empty()) {
    replay(m, log.t, log.v, log.d, o, tr);
    return tr;
  }
  const size_t stride = o.stride ? o.stride : 1;
  std::vector<size_t> bounds = {0};
  for (size_t s : log.run_starts) bounds.push_back(s);
  bounds.push_back(log.size());
  for (size_t r = 0; r + 1 < bounds.size(); ++r) {
    const size_t a = bounds[r], b = bounds[r + 1];
    ReplayOptions ro = o;
    ro.stride = 1;
    if (r > 0) ro.eps0 = 0.0;
    Trace part;
    const std::vector<double> t(log.t.begin() + static_cast<long>(a), log.t.begin() + static_cast<long>(b));
    const std::vector<double> v(log.v.begin() + static_cast<long>(a), log.v.begin() + static_cast<long>(b));
    const std::vector<double> d(log.d.begin() + static_cast<long>(a), log.d.begin() + static_cast<long>(b));
    replay(m, t, v, d, ro, part);
    if (r > 0) {
      const double c = best_offset(d, part.d);
      for (double& y : part.d) y += c;
    }
    for (size_t k = a; k < b; ++k) {
      if (k % stride) continue;
      tr.d.push_back(part.d[k - a]);
      if (o.want_states) {
        tr.D.push_back(part.D[k - a]);
        tr.T.push_back(part.T[k - a]);
        tr.eps.push_back(part.eps[k - a]);
      }
    }
  }
  return tr;
}

// Several runs of one rig as one log: times shifted so they keep increasing (one sample period
// between runs), run_starts marking where each later run begins.
inline RigLog concatenate(const std::vector<const RigLog*>& logs) {
  RigLog all;
  if (logs.empty()) return all;
  all.name = logs[0]->name;
  all.columns = logs[0]->columns;
  for (const RigLog* l : logs) {
    const double shift = all.t.empty() ? 0.0 : all.t.back() + l->sample_period() - l->t.front();
    if (!all.t.empty()) {
      all.run_starts.push_back(all.t.size());
      all.name += "+" + l->name;
    }
    all.run_names.push_back(l->name);
    for (size_t k = 0; k < l->size(); ++k) {
      all.t.push_back(l->t[k] + shift);
      all.v.push_back(l->v[k]);
      all.d.push_back(l->d[k]);
    }
    all.rows_read += l->rows_read;
    all.dropped += l->dropped;
  }
  return all;
}

// ---- noise ---------------------------------------------------------------------------------
// White displacement noise of a log from its second differences (a slow signal cancels in
// them): median |N(0, 6 s^2)| = 0.6745 sqrt(6) s.
inline double noise_level(const std::vector<double>& d) {
  if (d.size() < 10) return 0.0;
  std::vector<double> dd;
  for (size_t k = 2; k < d.size(); ++k) dd.push_back(fabs(d[k] - 2 * d[k - 1] + d[k - 2]));
  std::nth_element(dd.begin(), dd.begin() + static_cast<long>(dd.size() / 2), dd.end());
  return dd[dd.size() / 2] / (0.6745 * sqrt(6.0));
}
inline double noise_level(const RigLog& log) { return noise_level(log.d); }

// ---- error statistics: whole run, heating and cooling halves ---------------------------------
struct ErrorStats {
  double rms = 0, max = 0;
  size_t n = 0;
};
struct RunErrors {
  ErrorStats all, heating, cooling;  // heating: the model's temperature rises, cooling: it falls
};

// residual r = measured - model; T: the model's temperature (for the halves).
inline RunErrors run_errors(const std::vector<double>& r, const std::vector<double>& T) {
  RunErrors e;
  double s[3] = {0, 0, 0};
  ErrorStats* out[3] = {&e.all, &e.heating, &e.cooling};
  auto add = [&](int i, double x) {
    s[i] += x * x;
    out[i]->n += 1;
    out[i]->max = std::max(out[i]->max, fabs(x));
  };
  for (size_t k = 0; k < r.size(); ++k) {
    add(0, r[k]);
    if (T.size() != r.size()) continue;
    const size_t a = k ? k - 1 : 0, b = k + 1 < T.size() ? k + 1 : k;
    add(T[b] - T[a] >= 0.0 ? 1 : 2, r[k]);
  }
  for (int i = 0; i < 3; ++i) {  // a half the run does not have: NaN (null in JSON, "-" in tables)
    out[i]->rms = out[i]->n ? sqrt(s[i] / static_cast<double>(out[i]->n)) : NAN;
    if (!out[i]->n) out[i]->max = NAN;
  }
  return e;
}

// ---- uncertainty from the Jacobian ---------------------------------------------------------
// cov = s^2 (J^T J)^+ with J in physical units, computed from the SVD of the column-normalised J
// (without squaring its condition number); a direction with a singular value below 1e-7 of the
// largest carries no information: the parameters in it are "unresolved" (interval infinite).
// The residual of neighbouring samples is correlated (model error), which makes the intervals
// optimistic by about sqrt((1 + rho) / (1 - rho)) for a lag-1 autocorrelation rho: `inflate`.
struct Uncertainty {
  Eigen::MatrixXd cov, corr;
  std::vector<double> sigma;     // standard deviations, physical units (inf: unresolved)
  std::vector<bool> unresolved;
  double condition = 0, lag1 = 0, inflate = 1;
  double ci95(size_t i) const { return 1.959964 * sigma[i]; }
  double ci95_inflated(size_t i) const { return 1.959964 * sigma[i] * inflate; }
};

inline double lag1_autocorrelation(const Eigen::VectorXd& r) {
  if (r.size() < 3) return 0.0;
  const double mean = r.mean();
  double num = 0, den = 0;
  for (Eigen::Index k = 0; k < r.size(); ++k) {
    den += (r[k] - mean) * (r[k] - mean);
    if (k) num += (r[k] - mean) * (r[k - 1] - mean);
  }
  return den > 0 ? num / den : 0.0;
}

inline Uncertainty uncertainty(const Eigen::MatrixXd& J, const Eigen::VectorXd& r) {
  Uncertainty u;
  const Eigen::Index np = J.cols();
  const double m = static_cast<double>(r.size());
  const double s2 = r.squaredNorm() / std::max(1.0, m - static_cast<double>(np));
  u.lag1 = lag1_autocorrelation(r);
  const double rho = std::min(0.99, std::max(0.0, u.lag1));
  u.inflate = sqrt((1 + rho) / (1 - rho));
  u.cov = Eigen::MatrixXd::Zero(np, np);
  u.corr = Eigen::MatrixXd::Identity(np, np);
  u.unresolved.assign(static_cast<size_t>(np), false);
  u.sigma.assign(static_cast<size_t>(np), 0.0);
  if (np == 0) return u;
  Eigen::VectorXd cn = J.colwise().norm().transpose();
  for (Eigen::Index i = 0; i < np; ++i) {
    if (!(cn[i] > 0)) {
      u.unresolved[static_cast<size_t>(i)] = true;
      cn[i] = 1.0;
    }
  }
  const Eigen::MatrixXd Jn = J * cn.cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Jn, Eigen::ComputeThinV);
  const Eigen::VectorXd sv = svd.singularValues();
  const double cutoff = 1e-7 * sv[0];
  Eigen::MatrixXd covn = Eigen::MatrixXd::Zero(np, np);
  for (Eigen::Index k = 0; k < sv.size(); ++k) {
    const Eigen::VectorXd vk = svd.matrixV().col(k);
    if (sv[k] > cutoff) {
      covn += vk * vk.transpose() / (sv[k] * sv[k]);
    } else {
      for (Eigen::Index i = 0; i < np; ++i)
        if (fabs(vk[i]) > 0.05) u.unresolved[static_cast<size_t>(i)] = true;
    }
  }
  u.cov = s2 * cn.cwiseInverse().asDiagonal() * covn * cn.cwiseInverse().asDiagonal();
  u.condition = sv[sv.size() - 1] > 0 ? sv[0] / sv[sv.size() - 1] : INFINITY;
  for (Eigen::Index i = 0; i < np; ++i) {
    const size_t ii = static_cast<size_t>(i);
    u.sigma[ii] = u.unresolved[ii] ? INFINITY : sqrt(std::max(0.0, u.cov(i, i)));
    for (Eigen::Index j = 0; j < np; ++j) {
      if (i == j) continue;
      const size_t jj = static_cast<size_t>(j);
      u.corr(i, j) = (!u.unresolved[ii] && !u.unresolved[jj] && u.cov(i, i) > 0 && u.cov(j, j) > 0)
                         ? u.cov(i, j) / sqrt(u.cov(i, i) * u.cov(j, j))
                         : NAN;
    }
  }
  return u;
}

// ---- the LM residual over named parameters -----------------------------------------------------
// One residual object for every fit of the engine (`tools/sma fit`; the discrepancy workflow's
// fits of effects and base parameters can use it the same way): named parameters of a Model,
// normalised for the optimiser, the model replayed along one or several logs of one wire with a
// sensor zero per run, the minor-loop band tied to the fitted bands, a penalty for a
// non-physical set, and the forward-difference Jacobian Eigen's Levenberg-Marquardt wants.

// A fitted parameter: a flat key of the parameter table (sma/param_table.hpp), which gives its
// name and its place in a Model, or the sensor zero of one run of several.
struct ParamSpec {
  std::string name;  // fit_name(key) (h, T_AS, delay_s, j1, T_ii2), or offset_mm[<log>]
  double scale;      // normalisation: one unit of the optimiser's x (and the Jacobian step / 100)
  bool log;          // a quantity the table bounds away from zero, fitted as log (h, g, R, gain)
  uint8_t key;       // flat key; kNoKey: the sensor zero of run `run` (> 0) of several logs
  size_t run = 0;
  double lo = -INFINITY, hi = INFINITY;  // search clamp (not the table's range: fit_step)

  double* ref(Model& m) const { return key == sma::param::kNoKey ? nullptr : &value(m, key); }
  bool is(sma::param::Row r) const {
    return key != sma::param::kNoKey && sma::param::locate(key).row == static_cast<uint8_t>(r);
  }
};

// How the optimiser moves a row the engine fits: its unit step (scale 0: a row it never fits:
// rho, c, d0, L0 only enter through G and C, T_MS follows T_MF, m is Table II's, the loops' T_i
// sit at the log's reversals) and its search clamp.
// The table's range is not a clamp: a set outside it fails Params/Effects::check() and costs the
// penalty residual, so LM rejects the step and shortens it. A clamp at the range would turn the
// outside into a plateau: a parameter LM overshoots onto its bound (a loop's j at 0) keeps a
// zero Jacobian column there and never comes back, and the fit ends elsewhere. The only clamps
// are the sensor effects' and k_R's search ranges (the discrepancy vocabulary's, inside the table's).
struct FitStep {
  double scale;
  double lo = -INFINITY, hi = INFINITY;
};
// The search ranges of the effects' parameters (inside the table's range: test_discrepancy): the
// discrepancy vocabulary searches each effect within them, fit_step clamps the sensor effects'
// and k_R's to them.
struct SearchRange {
  double lo, hi;
};
inline SearchRange search_range(sma::param::Row r) {
  using R = sma::param::Row;
  switch (r) {
    case R::delay_s: return {0.0, 2.0};
    case R::tau_s: return {0.0, 5.0};
    case R::gain: return {0.5, 2.0};
    case R::offset_mm: return {-2.0, 2.0};
    case R::offset_K: return {-30.0, 30.0};
    case R::beta_per_K: return {0.0, 0.05};
    case R::k_R: return {-0.5, 1.0};
    case R::L_J: return {0.0, 20.0};
    case R::alpha_per_K: return {0.0, 1e-4};
    default: return {-INFINITY, INFINITY};
  }
}
inline FitStep fit_step(sma::param::Row r, const Model& m) {
  using R = sma::param::Row;
  switch (r) {
    case R::T_AS: case R::T_AF: case R::T_MF: case R::T_s: case R::T_f: case R::T_MSs: case R::T_MSf:
    case R::q: case R::e: case R::T_amb: case R::loop_T_ii:
      return {1.0};  // K
    case R::h: return {0.1};  // of log h
    case R::g: case R::R: case R::gain: return {0.05};  // of the log
    case R::loop_j: return {0.02};
    case R::offset_mm: return {0.01 * m.p.g};  // 1 % of the stroke
    case R::offset_K: return {2.0};
    case R::delay_s: return {0.1, search_range(r).lo, search_range(r).hi};
    case R::tau_s: return {0.2, search_range(r).lo, search_range(r).hi};
    case R::beta_per_K: return {1e-3};
    case R::k_R: return {0.1, search_range(r).lo, search_range(r).hi};
    case R::L_J: return {0.5};
    case R::alpha_per_K: return {1e-6};
    default: return {0.0};
  }
}

// The spec of flat key k: name and place from the table, log if the table bounds it away from
// zero, step and clamp from fit_step; scale 0 for a key the engine does not fit.
inline ParamSpec param_spec(uint8_t k, const Model& m) {
  const sma::param::Place at = sma::param::locate(k);
  const FitStep st = fit_step(static_cast<sma::param::Row>(at.row), m);
  ParamSpec s{fit_name(k), st.scale, sma::param::row(at.row).lo > 0, k};
  s.lo = st.lo;
  s.hi = st.hi;
  return s;
}

// Every parameter a fit can name: the paper's (Table II), the rig's (T_amb, R) and the effects',
// in the table's order, then j and T_ii of each identified loop.
inline std::vector<ParamSpec> fittable_params(const Model& m) {
  using sma::param::Kind;
  std::vector<ParamSpec> s;
  for (uint8_t k = 0; k < sma::param::kKeys; ++k) {
    const ParamSpec p = param_spec(k, m);
    if (p.scale > 0 && key_kind(k) != Kind::Knot) s.push_back(p);
  }
  for (uint8_t i = 0; i < m.p.n_loops; ++i) {
    s.push_back(param_spec(sma::param::key_of<sma::param::Row::loop_j>(i), m));
    s.push_back(param_spec(sma::param::key_of<sma::param::Row::loop_T_ii>(i), m));
  }
  return s;
}

// What `tools/sma fit` fits unless told otherwise: the paper's identified set and the sensor zero.
inline std::vector<std::string> default_fit_names(const Model& m) {
  using R = sma::param::Row;
  using sma::param::key_of;
  std::vector<std::string> n;
  for (uint8_t k : {key_of<R::h>(), key_of<R::T_AS>(), key_of<R::T_AF>(), key_of<R::T_MF>(), key_of<R::q>(),
                    key_of<R::e>(), key_of<R::T_MSs>(), key_of<R::T_MSf>(), key_of<R::g>(), key_of<R::offset_mm>()})
    n.push_back(fit_name(k));
  for (uint8_t i = 0; i < m.p.n_loops; ++i) {
    n.push_back(fit_name(key_of<R::loop_j>(i)));
    n.push_back(fit_name(key_of<R::loop_T_ii>(i)));
  }
  return n;
}

// Over one or several logs of one wire: the shared parameters, and a sensor offset per run after
// the first (a potentiometer's zero moves between runs; specs with key kNoKey and their run).
// The residual is model - measured at every stride-th row of each log, or at the rows `only`
// (one log: e.g. the training blocks of a held-out split).
struct FitResidual {
  std::vector<const RigLog*> logs;
  Model start;
  std::vector<ParamSpec> specs;  // fitted, in order
  std::vector<double> x0;        // start values (physical)
  size_t stride = 1;
  std::vector<size_t> only;      // rows of logs[0] to use instead of the stride (one log)
  double eps0 = -1.0;            // < 0: the engine's initial-state rule
  double penalty = 1.0;          // residual of a non-physical set, mm
  bool tie_bands = true;         // tie_to_bands() (off: every parameter not fitted stays put)
  std::vector<double> run_offset;  // start sensor offsets of runs 1.. (run 0: the model's)
  mutable long runs = 0;         // model runs so far (one per log per residual)

  // x (normalised) -> the physical value of parameter i
  double value(const Eigen::VectorXd& x, size_t i) const {
    const ParamSpec& s = specs[i];
    const double xi = x[static_cast<Eigen::Index>(i)];
    const double v = s.log ? x0[i] * exp(xi * s.scale) : x0[i] + xi * s.scale;
    return std::min(s.hi, std::max(s.lo, v));
  }
  // x (normalised) -> model (of run 0)
  Model model_at(const Eigen::VectorXd& x) const {
    Model m = start;
    for (size_t i = 0; i < specs.size(); ++i)
      if (double* v = specs[i].ref(m)) *v = value(x, i);
    if (tie_bands) tie_to_bands(m);
    // T_MS is not used by the hysteresis (the major cooling branch starts at T_MSi, eq 10), but
    // Params::check wants T_MS > T_MF: it follows T_MF instead of bounding it.
    if (!(m.p.T_MS > m.p.T_MF)) m.p.T_MS = m.p.T_MF + 1.0;
    return m;
  }
  bool fitted(sma::param::Row r) const {
    for (const ParamSpec& s : specs)
      if (s.is(r)) return true;
    return false;
  }
  // The minor-loop band moves with the wire: what is not fitted itself follows the band it lies
  // in, by the affine map of the start's band onto the present one. T_s, T_f and the loops'
  // T_i, T_ii lie in the heating band T_AS..T_AF (eqs 2, 7); T_MSs, T_MSf (eq 9) in the cooling
  // band T_MF..q + e (eq 10 at a full transformation). A wire whose temperatures shift then
  // keeps its loops where they were relative to its transformation instead of at the start's
  // (the paper's) temperatures.
  void tie_to_bands(Model& m) const {
    const sma::Params& s = start.p;
    const double wh0 = s.T_AF - s.T_AS, wh = m.p.T_AF - m.p.T_AS;
    if (wh0 > 0 && wh > 0 && (m.p.T_AS != s.T_AS || m.p.T_AF != s.T_AF)) {
      auto heat = [&](double x) { return m.p.T_AS + (x - s.T_AS) * wh / wh0; };
      if (!fitted(sma::param::Row::T_s)) m.p.T_s = heat(s.T_s);
      if (!fitted(sma::param::Row::T_f)) m.p.T_f = heat(s.T_f);
      for (int k = 0; k < m.p.n_loops; ++k) {
        m.p.loops[k].T_i = heat(s.loops[k].T_i);
        if (!fitted(sma::param::Row::loop_T_ii)) m.p.loops[k].T_ii = heat(s.loops[k].T_ii);
      }
    }
    const double c0 = s.q + s.e, c = m.p.q + m.p.e;
    const double wc0 = c0 - s.T_MF, wc = c - m.p.T_MF;
    if (wc0 > 0 && wc > 0 && (c != c0 || m.p.T_MF != s.T_MF)) {
      auto cool = [&](double x) { return m.p.T_MF + (x - s.T_MF) * wc / wc0; };
      if (!fitted(sma::param::Row::T_MSs)) m.p.T_MSs = cool(s.T_MSs);
      if (!fitted(sma::param::Row::T_MSf)) m.p.T_MSf = cool(s.T_MSf);
    }
  }
  // The model of run r: run 0's, with run r's own sensor offset.
  Model model_for_run(const Model& m0, const Eigen::VectorXd& x, size_t r) const {
    Model m = m0;
    if (r == 0) return m;
    m.fx.sensor_offset_mm = run_offset[r - 1];
    for (size_t i = 0; i < specs.size(); ++i)
      if (specs[i].key == sma::param::kNoKey && specs[i].run == r) m.fx.sensor_offset_mm = value(x, i);
    return m;
  }
  // d(physical)/d(x) at x, for the covariance in physical units.
  double dphys(const Eigen::VectorXd& x, size_t i) const {
    const ParamSpec& s = specs[i];
    const double xi = x[static_cast<Eigen::Index>(i)];
    return s.log ? x0[i] * exp(xi * s.scale) * s.scale : s.scale;
  }
  size_t rows_of(size_t r) const {
    if (r == 0 && !only.empty()) return only.size();
    return (logs[r]->size() + stride - 1) / stride;
  }
  size_t rows() const {
    size_t n = 0;
    for (size_t r = 0; r < logs.size(); ++r) n += rows_of(r);
    return n;
  }

  // Residuals; false if the set is not physical (then f = penalty everywhere).
  bool residual(const Model& m, Eigen::VectorXd& f, const Eigen::VectorXd* x = nullptr) const {
    const size_t n = rows();
    f.resize(static_cast<Eigen::Index>(n));
    if (m.p.check() || m.fx.check()) {
      f.setConstant(penalty);
      return false;
    }
    const Eigen::VectorXd none = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(specs.size()));
    Eigen::Index row = 0;
    for (size_t r = 0; r < logs.size(); ++r) {
      const bool rows_given = r == 0 && !only.empty();
      ReplayOptions o;
      o.stride = rows_given ? 1 : stride;
      o.eps0 = eps0;
      o.want_states = false;
      const Trace tr = sma_host::replay(model_for_run(m, x ? *x : none, r), *logs[r], o);
      ++runs;
      if (rows_given)
        for (size_t k : only) f[row++] = tr.d[k] - logs[r]->d[k];
      else
        for (size_t k = 0; k < rows_of(r); ++k) f[row++] = tr.d[k] - logs[r]->d[k * stride];
    }
    return true;
  }
  bool residual_at(const Eigen::VectorXd& x, Eigen::VectorXd& f) const { return residual(model_at(x), f, &x); }
};

// The residual as Eigen's Levenberg-Marquardt functor (unsupported/NonLinearOptimization).
struct FitFunctor {
  typedef double Scalar;
  enum { InputsAtCompileTime = Eigen::Dynamic, ValuesAtCompileTime = Eigen::Dynamic };
  typedef Eigen::VectorXd InputType;
  typedef Eigen::VectorXd ValueType;
  typedef Eigen::MatrixXd JacobianType;
  const FitResidual* pb;
  int inputs() const { return static_cast<int>(pb->specs.size()); }
  int values() const { return static_cast<int>(pb->rows()); }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    pb->residual_at(x, f);
    return 0;
  }
  // Forward differences with a fixed step of 0.01 normalised units (0.01 K for temperatures,
  // 0.1 % for h, g): the hysteresis is piecewise, so steps near machine precision would be noise.
  int df(const Eigen::VectorXd& x, Eigen::MatrixXd& J) const {
    Eigen::VectorXd f0, f1;
    pb->residual_at(x, f0);
    J.resize(f0.size(), x.size());
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      Eigen::VectorXd xs = x;
      double step = 0.01;
      xs[i] += step;
      if (!pb->residual_at(xs, f1)) {  // at a bound: step the other way
        xs[i] = x[i] - step;
        pb->residual_at(xs, f1);
        step = -step;
      }
      J.col(i) = (f1 - f0) / step;
    }
    return 0;
  }
};

// ---- several logs at once: what must agree ---------------------------------------------------
// Logs fitted together must have the same sample rate (within 2 %) and the same column set:
// they are refused, naming the log that differs, rather than silently resampled (the residuals
// of a faster log would outweigh the others, and a missing column means another rig set-up).
inline void check_compatible(const std::vector<const RigLog*>& logs) {
  if (logs.size() < 2) return;
  const RigLog& a = *logs[0];
  const double dt0 = a.sample_period();
  for (size_t i = 1; i < logs.size(); ++i) {
    const RigLog& b = *logs[i];
    const double dt = b.sample_period();
    if (fabs(dt - dt0) > 0.02 * dt0)
      throw Error(b.name + ": sampled every " + std::to_string(dt * 1000.0) + " ms, but " + a.name + " every " +
                  std::to_string(dt0 * 1000.0) +
                  " ms: logs fitted together must have one sample rate (refused, not resampled: resample "
                  "the log yourself, or fit it alone)");
    std::vector<std::string> ca = a.columns, cb = b.columns;
    std::sort(ca.begin(), ca.end());
    std::sort(cb.begin(), cb.end());
    if (ca != cb) {
      std::string sa, sb;
      for (const std::string& c : a.columns) sa += (sa.empty() ? "" : ",") + c;
      for (const std::string& c : b.columns) sb += (sb.empty() ? "" : ",") + c;
      throw Error(b.name + ": columns " + sb + " differ from " + a.name + "'s (" + sa +
                  "): logs fitted together must come from one rig set-up with one column set");
    }
  }
}

// The parameters only a log that cools the wire back through its transformation excites: the
// cooling band and its start (T_MF, q, e of eq 10, T_MSs, T_MSf of eq 9) and the minor loops
// (j, T_ii: the loops open at a reversal from heating to cooling, eq 7). kNoKey: false.
inline bool cooling_param(uint8_t key) {
  using R = sma::param::Row;
  if (key == sma::param::kNoKey) return false;
  switch (static_cast<R>(sma::param::locate(key).row)) {
    case R::T_MF: case R::q: case R::e: case R::T_MSs: case R::T_MSf: case R::loop_j: case R::loop_T_ii: return true;
    default: return false;
  }
}

// True if the log shows the wire cooling back: the measured position (averaged over 0.5 s) falls
// from its running peak by at least `min_drop` of the log's stroke (1st..99th percentile), i.e.
// part of the reverse transformation was recorded. From the data, not from a start model (a bad
// start model may never cool on the log's voltage). Without it the cooling parameters
// (cooling_param) have nothing to be fitted on.
inline bool cools_in_log(const RigLog& log, double min_drop = 0.2) {
  const size_t n = log.size();
  if (n < 3) return false;
  std::vector<double> sorted = log.d;
  std::sort(sorted.begin(), sorted.end());
  const double span = sorted[(n - 1) * 99 / 100] - sorted[(n - 1) / 100];
  if (!(span > 0)) return false;
  const double dt = log.sample_period();
  const size_t w = std::max<size_t>(1, dt > 0 ? static_cast<size_t>(0.5 / dt) : 1);
  double sum = 0, peak = -INFINITY;
  for (size_t k = 0; k < n; ++k) {
    sum += log.d[k];
    if (k >= w) sum -= log.d[k - w];
    if (k + 1 < w) continue;
    const double avg = sum / static_cast<double>(w);
    peak = std::max(peak, avg);
    if (peak - avg >= min_drop * span) return true;
  }
  return false;
}

}  // namespace sma_host

#endif  // SMA_HOST_IDENTIFY_HPP
