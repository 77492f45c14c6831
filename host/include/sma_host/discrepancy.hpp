// The discrepancy workflow (interfaces.md, `tools/sma discrepancy`): find where the model and a
// rig log disagree, name the missing physical effect, add it with fitted parameters, repeat.
//
//   1. simulate the log's voltage with the model (sma::Plant: the library's own formulas, with
//      the candidate effects of effects.hpp; no second copy of the model here);
//   2. split the log into alternating blocks: even blocks fit, odd blocks judge (the simulation
//      always runs over the whole log, so the state is continuous);
//   3. fit every effect of the vocabulary that is not in the model yet (Eigen's
//      Levenberg-Marquardt, a few starting points), jointly with the effects already added;
//   4. add the candidate with the lowest held-out RMS if it shrinks the held-out RMS clearly
//      (min_gain) and its BIC on the held-out residual improves; stop when none does or when
//      the gap is at the noise. Noise cannot be "explained" on blocks it was not fitted on.
//   5. candidates whose held-out RMS is within `ambiguity` of the winner's are reported as
//      not separable on this log, with the excitation that would separate them.
#ifndef SMA_HOST_DISCREPANCY_HPP
#define SMA_HOST_DISCREPANCY_HPP

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <string>
#include <thread>
#include <unsupported/Eigen/NonLinearOptimization>
#include <unsupported/Eigen/NumericalDiff>
#include <vector>
#include "sma/effects.hpp"
#include "sma/hysteresis.hpp"
#include "sma/params.hpp"
#include "sma_host/plant.hpp"
#include "identify.hpp"
#include "signals.hpp"

namespace sma_host {

// ---- the vocabulary as fit problems --------------------------------------------------------

struct EffectSpec {
  sma::param::Row row[2];    // its parameters: rows of the parameter table (none: one only)
  double scale[2];           // typical size: the optimiser works on value / scale
  double start[3][2];        // starting points [start][param]
  int n_starts;
  const char* separate;      // what excitation tells it from its look-alikes
  // A base parameter each parameter is only observable jointly with (nullptr: none): held at
  // its given value when that base parameter is refitted.
  const char* held_with[2];
  // From the parameter table and search_range (identify.hpp; vocabulary() fills them in):
  double lo[2] = {0, 0}, hi[2] = {0, 0};  // search bounds
  std::string name = "";     // interfaces.md vocabulary
  int n = 0;                 // parameters (1 or 2)
  std::string param[2] = {"", ""};  // JSON names
  uint8_t key[2] = {sma::param::kNoKey, sma::param::kNoKey};

  double get(const sma::Effects& fx, int i) const { return value(fx, key[i]); }
  double& at(sma::Effects& fx, int i) const { return value(fx, key[i]); }
};

inline const std::vector<EffectSpec>& vocabulary() {
  using R = sma::param::Row;
  static const std::vector<EffectSpec> v = [] {
    std::vector<EffectSpec> s = {
      // A third start at 10 ms: a sensor that averages over the 10 ms tick (the firmware's
      // telemetry) lags by ~5 ms, which LM does not reach from 50 ms past the bound at 0.
      {{R::delay_s, R::none}, {0.1, 1},
       {{0.05, 0}, {0.4, 0}, {0.01, 0}}, 3, "a sharp voltage step: a delay shifts the whole edge, a lag rounds it", {nullptr, nullptr}},
      {{R::tau_s, R::none}, {0.2, 1},
       {{0.1, 0}, {1.0, 0}, {0.01, 0}}, 3, "a sharp voltage step: a lag rounds the edge, a delay shifts it", {nullptr, nullptr}},
      {{R::gain, R::offset_mm}, {0.1, 0.05}, {{1.0, 0.0}, {1.1, 0.0}}, 2,
       "holds at both ends of the stroke (cold and fully transformed)", {"g", nullptr}},  // gain x g
      {{R::offset_K, R::none}, {2, 1},
       {{-3, 0}, {3, 0}}, 2, "steady holds at several voltages: an offset shifts all steady states equally", {nullptr, nullptr}},
      // Three starts over the plausible range: with the whole base refitted, a wire of beta 0.006
      // is reached from 0.005 only; from 0.002 and 0.01 LM stops in side minima where g and T_AS
      // absorb the rest.
      {{R::beta_per_K, R::none}, {0.005, 1}, {{0.002, 0}, {0.005, 0}, {0.01, 0}}, 3,
       "steady holds at several voltages: its loss grows with the temperature rise", {nullptr, nullptr}},
      {{R::k_R, R::none}, {0.1, 1},
       {{-0.1, 0}, {0.1, 0}}, 2, "holds inside the transformation band at a constant voltage", {nullptr, nullptr}},
      {{R::L_J, R::none}, {1, 1},
       {{0.5, 0}, {3.0, 0}}, 2, "fast voltage steps through the transformation band", {nullptr, nullptr}},
      {{R::alpha_per_K, R::none}, {1e-5, 1}, {{5e-6, 0}, {2e-5, 0}}, 2,
       "heating past the end of the transformation: the position falls as the hot wire lengthens", {nullptr, nullptr}},
    };
    for (EffectSpec& e : s) {
      e.n = e.row[1] == R::none ? 1 : 2;
      for (int i = 0; i < e.n; ++i) {
        e.key[i] = sma::param::first_key(e.row[i]);
        e.lo[i] = search_range(e.row[i]).lo;
        e.hi[i] = search_range(e.row[i]).hi;
        e.param[i] = param_of_key(e.key[i]);
      }
      e.name = effect_of_key(e.key[0]);
    }
    return s;
  }();
  return v;
}

// Base parameters the workflow may refit jointly with the effects (Options::refit_base): the
// ones a fit on the same log can trade against a missing effect. `all` in the CLI is the whole
// list: the set tools/sma fit identifies (sma_fit's default), so that the base a fit biased to
// absorb a missing effect is re-identified together with that effect.
struct BaseSpec {
  uint8_t key;       // flat key of the parameter table
  double scale;      // typical change
  std::string name;  // the fit's (fit_name)
  double get(const sma::Params& p) const { return ref(const_cast<sma::Params&>(p)); }
  double& ref(sma::Params& p) const {
    sma::Effects none;  // (a base key is a Params one: the pointer is into p)
    return *sma::param::value_ptr(p, none, key);
  }
};

inline const std::vector<BaseSpec>& refittable_base() {
  using sma::param::Row;
  using sma::param::key_of;
  static const std::vector<BaseSpec> v = [] {
    std::vector<BaseSpec> s = {
        {key_of<Row::h>(), 20.0, ""},         {key_of<Row::T_AS>(), 2.0, ""},
        {key_of<Row::T_AF>(), 2.0, ""},       {key_of<Row::T_MF>(), 2.0, ""},
        {key_of<Row::q>(), 2.0, ""},          {key_of<Row::e>(), 2.0, ""},
        {key_of<Row::T_MSs>(), 2.0, ""},      {key_of<Row::T_MSf>(), 2.0, ""},
        {key_of<Row::g>(), 0.05, ""},         {key_of<Row::loop_j>(0), 0.02, ""},
        {key_of<Row::loop_T_ii>(0), 1.0, ""}, {key_of<Row::loop_j>(1), 0.02, ""},
        {key_of<Row::loop_T_ii>(1), 1.0, ""}, {key_of<Row::loop_j>(2), 0.02, ""},
        {key_of<Row::loop_T_ii>(2), 1.0, ""}, {key_of<Row::T_amb>(), 2.0, ""},
    };
    for (BaseSpec& b : s) b.name = fit_name(b.key);
    return s;
  }();
  return v;
}

inline const BaseSpec* find_base(const std::string& name) {
  for (const BaseSpec& b : refittable_base())
    if (name == b.name) return &b;
  return nullptr;
}

// `all`: every refittable base parameter the model has (loops beyond n_loops are skipped), but
// not T_amb (a measured quantity, and degenerate with h on a log without a cold hold).
inline std::vector<const BaseSpec*> all_base(const sma::Params& p) {
  std::vector<const BaseSpec*> out;
  for (const BaseSpec& b : refittable_base()) {
    const std::string n = b.name;
    if (n == "T_amb") continue;
    if ((n[0] == 'j' || n.compare(0, 4, "T_ii") == 0) && (n.back() - '0') > p.n_loops) continue;
    out.push_back(&b);
  }
  return out;
}

inline const EffectSpec* find_effect(const std::string& name) {
  for (const EffectSpec& e : vocabulary())
    if (name == e.name) return &e;
  return nullptr;
}

// ---- simulation ----------------------------------------------------------------------------

// What the model says the sensor reads for the log's voltage history, and its states: the
// engine's replay (identify.hpp) with its one initial-state rule.
inline std::vector<double> predict(const sma::Params& p, const sma::Effects& fx, const RigLog& log) {
  ReplayOptions o;
  o.want_states = false;
  return replay(Model{p, fx}, log, o).d;
}

inline Trace trace(const sma::Params& p, const sma::Effects& fx, const RigLog& log) {
  return replay(Model{p, fx}, log);
}

// A log simulated by the plant (for tests and demos): the voltage signal, hidden effects, noise.
inline RigLog simulate_log(const sma::Params& p, const sma::Effects& fx, const VoltageSignal& s,
                           double noise_mm, uint64_t seed = 1) {
  sma::RigOptions rig;
  rig.noise_mm = noise_mm;
  rig.seed = seed;
  sma::Plant plant(p, fx, rig);
  RigLog log;
  for (size_t k = 0; k < s.t.size(); ++k) {
    log.t.push_back(s.t[k]);
    log.v.push_back(s.v[k]);
    log.d.push_back(plant.measure());
    if (k + 1 < s.t.size()) plant.step(s.v[k], s.t[k + 1] - s.t[k]);
  }
  return log;
}

// ---- fitting -------------------------------------------------------------------------------

struct Options {
  double block_s = 10.0;    // train / held-out block length
  double min_gain = 0.10;   // a candidate must cut the held-out RMS by at least this fraction
  double ambiguity = 0.05;  // runner-ups within this fraction of the winner's RMS are look-alikes
  int max_effects = 3;
  int max_residuals = 6000; // residuals per fit (the log is strided down to this)
  int threads = 2;          // candidates fitted at once
  // Credibility of a winner (credibility()): its parameter fitted on the two halves of the log
  // may differ by at most this fraction of its size (or within the noise of the two fits), and
  // no held-out block may get worse by more than block_worse of its RMS (and 2x the noise, and
  // a quarter of the candidate's overall held-out gain).
  double half_rel = 0.5;
  double block_worse = 0.25;
  bool check_credibility = true;
  bool pair_search = true;  // two candidates fitted jointly when no single one is credible
  // Decide the re-heat reading of the loop memory (sma::Reheat) from the log before naming
  // effects (diagnose_reading()); false: the given params' reading is kept.
  bool choose_reading = true;
  // Base parameters refitted jointly with every candidate (names of refittable_base()); empty:
  // the base model stays as given and only the effects are fitted.
  std::vector<const BaseSpec*> refit_base;
};

struct Split {
  std::vector<size_t> train, test;
};

// Training and held-out blocks of block_s alternate.
inline Split split_blocks(const RigLog& log, const Options& o) {
  Split s;
  std::vector<size_t> train, test;
  for (size_t k = 0; k < log.size(); ++k) {
    const long block = static_cast<long>((log.t[k] - log.t[0]) / o.block_s);
    ((block % 2) ? test : train).push_back(k);
  }
  const size_t stride = std::max<size_t>(1, train.size() / static_cast<size_t>(o.max_residuals));
  for (size_t i = 0; i < train.size(); i += stride) s.train.push_back(train[i]);
  s.test = test;
  return s;
}

inline double rms_on(const std::vector<double>& pred, const RigLog& log, const std::vector<size_t>& idx) {
  double sum = 0;
  for (size_t k : idx) sum += (log.d[k] - pred[k]) * (log.d[k] - pred[k]);
  return idx.empty() ? 0 : sqrt(sum / static_cast<double>(idx.size()));
}

// One effect of the model with its fitted parameters.
struct FittedEffect {
  const EffectSpec* spec;
  double value[2];
  double ci95[2];  // half-width of the 95 % interval
};

inline void apply(sma::Effects& fx, const FittedEffect& f) {
  for (int i = 0; i < f.spec->n; ++i) f.spec->at(fx, i) = f.value[i];
}

inline sma::Effects effects_of(const std::vector<FittedEffect>& list) {
  sma::Effects fx;
  for (const FittedEffect& f : list) apply(fx, f);
  return fx;
}

struct FitOutcome {
  std::vector<FittedEffect> effects;
  sma::Params params;             // the base model (refitted when Options::refit_base is set)
  std::vector<double> base_ci95;  // 95 % half-widths of the refitted base parameters
  double rms_train = INFINITY, rms_test = INFINITY, rms_all = INFINITY;
  double max_corr = 0;            // largest |correlation| between two fitted parameters
  std::string corr_pair;          // which two
};

// Held, not fitted: a parameter only observable jointly with a refitted base parameter (the
// vocabulary's held_with; e.g. a sensor's calibration gain and the stroke g act only as their
// product on a position log: fitting both, they drift apart and the controller, which reads
// positions through the gain, tracks a scaled reference).
inline bool frozen(const EffectSpec& e, int i, const std::vector<const BaseSpec*>& base) {
  if (!e.held_with[i]) return false;
  for (const BaseSpec* b : base)
    if (b->name == e.held_with[i]) return true;
  return false;
}

// Fit the parameters of `effects` (their values are starting points) on the training blocks.
// hold_effects: the effects stay at their given values and only the base is fitted.
// The residual is the engine's (identify.hpp FitResidual / FitFunctor, the one `fit` uses), on
// the training rows, with the vocabulary's scales and bounds for the effects and the refittable
// base's scales for the base; the bands are not tied (every parameter not fitted stays put).
inline FitOutcome fit_effects(const sma::Params& p, std::vector<FittedEffect> effects, const RigLog& log,
                              const Split& split, const std::vector<const BaseSpec*>& base = {},
                              bool hold_effects = false) {
  FitResidual pb;
  pb.logs = {&log};
  pb.start = Model{p, effects_of(effects)};
  pb.only = split.train;
  pb.tie_bands = false;
  pb.penalty = 1.0;  // mm: a non-physical trial
  auto spec_of = [&pb](uint8_t key, double scale, double lo, double hi) {
    ParamSpec out = param_spec(key, pb.start);
    out.scale = scale;
    out.log = false;
    out.lo = lo;
    out.hi = hi;
    return out;
  };
  for (const FittedEffect& e : effects)
    for (int i = 0; i < e.spec->n; ++i)
      if (!hold_effects && !frozen(*e.spec, i, base)) {
        pb.specs.push_back(spec_of(e.spec->key[i], e.spec->scale[i], e.spec->lo[i], e.spec->hi[i]));
        pb.x0.push_back(sma::clamp(e.value[i], e.spec->lo[i], e.spec->hi[i]));
      }
  const size_t n_effect_params = pb.specs.size();
  for (const BaseSpec* b : base) {
    pb.specs.push_back(spec_of(b->key, b->scale, -INFINITY, INFINITY));
    pb.x0.push_back(b->get(p));
  }
  const Eigen::Index n = static_cast<Eigen::Index>(pb.specs.size());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  if (n > 0) {
    FitFunctor fun{&pb};
    Eigen::LevenbergMarquardt<FitFunctor> lm(fun);
    lm.parameters.maxfev = 60 * (n + 1);
    lm.parameters.xtol = 1e-6;
    lm.minimize(x);
  }
  const Model fitted = pb.model_at(x);
  FitOutcome out;
  out.params = fitted.p.check() == nullptr ? fitted.p : p;
  for (FittedEffect& e : effects)
    for (int i = 0; i < e.spec->n; ++i) e.value[i] = e.spec->get(fitted.fx, i);
  const std::vector<double> pred = predict(out.params, effects_of(effects), log);
  out.rms_train = rms_on(pred, log, split.train);
  out.rms_test = rms_on(pred, log, split.test);
  std::vector<size_t> all(log.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = k;
  out.rms_all = rms_on(pred, log, all);
  // Confidence: from a finite-difference Jacobian at the optimum, in the optimiser's scaled
  // units (one unit = one scale of the parameter).
  if (n > 0) {
    Eigen::VectorXd r0, r1;
    pb.residual_at(x, r0);
    Eigen::MatrixXd J(r0.size(), n);
    for (Eigen::Index c = 0; c < n; ++c) {
      Eigen::VectorXd xh = x;
      const double h = 1e-3 * std::max(1.0, fabs(x[c]));
      xh[c] += h;
      pb.residual_at(xh, r1);
      J.col(c) = (r1 - r0) / h;
    }
    // The engine's covariance (identify.hpp). A parameter pinned at its bound (a zero column)
    // gets no width here; the report warns about bounds.
    const Uncertainty u = uncertainty(J, r0);
    auto half = [&](Eigen::Index c) {
      return 1.96 * sqrt(fmax(u.cov(c, c), 0.0)) * pb.specs[static_cast<size_t>(c)].scale;
    };
    Eigen::Index j = 0;
    for (FittedEffect& e : effects)
      for (int i = 0; i < e.spec->n; ++i)
        e.ci95[i] = hold_effects || frozen(*e.spec, i, base) ? 0.0 : half(j++);  // held: not fitted
    for (size_t b = n_effect_params; b < pb.specs.size(); ++b) out.base_ci95.push_back(half(j++));
    for (Eigen::Index a2 = 0; a2 < n; ++a2)
      for (Eigen::Index b2 = a2 + 1; b2 < n; ++b2) {
        const double c = u.corr(a2, b2);
        if (isfinite(c) && fabs(c) > out.max_corr) {
          out.max_corr = fabs(c);
          out.corr_pair = std::to_string(a2) + "-" + std::to_string(b2);
        }
      }
  }
  out.effects = effects;
  return out;
}

// Runs job(0..n-1) on up to `threads` threads (each job independent).
template <class Job>
void in_parallel(size_t n, int threads, Job job) {
  std::atomic<size_t> next(0);
  auto worker = [&]() {
    for (size_t i = next++; i < n; i = next++) job(i);
  };
  std::vector<std::thread> pool;
  for (int k = 1; k < threads && static_cast<size_t>(k) < n; ++k) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

// ---- selection -----------------------------------------------------------------------------

struct CandidateScore {
  std::string name;
  double rms_test;
  FitOutcome fit;
};

struct Step {
  FittedEffect added;
  double rms_before, rms_after;  // over the whole log
  std::vector<std::string> lookalikes;  // not separable from `added` on this log
  std::vector<CandidateScore> candidates;
};

struct Diagnosis {
  double noise_mm = 0;
  double rms_nominal = 0, rms_final = 0;  // over the whole log
  std::vector<Step> steps;
  std::vector<FittedEffect> effects;      // final, jointly refitted
  std::vector<double> nominal, corrected; // predictions
  std::vector<CandidateScore> rejected;   // the last round, when nothing was added
  std::vector<std::string> pruned;        // added, then at their no-effect value in the end
  sma::Params params;                     // final base model (refitted if Options::refit_base)
  std::vector<double> base_ci95;
  double rms_test_final = 0;              // held-out RMS of the final model
  std::vector<std::string> at_bound;      // candidates not added: they ended at a bound
  std::vector<std::string> not_credible;  // candidates not added: stand-ins (credibility()), with why
  // The re-heat reading (params.reheat): the held-out RMS of the final model with each reading
  // (NaN: not run on this log) and why the one in params was kept.
  double reading_rms_test[2] = {NAN, NAN};  // [return_point, new_loop]
  std::string reading_why;
};

// BIC of a held-out residual with k extra parameters; n_eff discounts the autocorrelation of
// model errors (one independent sample per 2 s of log, half of them held out).
inline double bic(double rms, double n_eff, int k) { return n_eff * ::log(rms * rms + 1e-30) + k * ::log(n_eff); }

// The effects already present in `fx` (parameters that differ from the paper's model), as
// starting points: a params file with effects is refined, not thrown away.
inline std::vector<FittedEffect> present_effects(const sma::Effects& fx) {
  const sma::Effects none;
  std::vector<FittedEffect> out;
  for (const EffectSpec& s : vocabulary()) {
    bool on = false;
    for (int i = 0; i < s.n; ++i) on = on || s.get(fx, i) != s.get(none, i);
    if (on) out.push_back({&s, {s.get(fx, 0), s.n > 1 ? s.get(fx, 1) : 0.0}, {0, 0}});
  }
  return out;
}

// A base that, with the candidate effect at `value`, keeps the given base's steady states: the
// start a base fitted without the effect needs. A fit that lacks a heat loss growing with the
// temperature rise (convection_nonlinear, beta) reads it as a larger h and stretched
// temperatures: P = h_fit A dT_fit = h A dT (1 + beta dT). With h = h_fit / (1 + beta dT_mid)
// (dT_mid: the middle of the band) every temperature maps by beta dT^2 + dT = dT_fit (1 + beta
// dT_mid). An ambient offset reads as all temperatures shifted by it. Only refitted parameters
// are moved (the others stay part of the model). Other effects: the base unchanged.
inline sma::Params equivalent_base(const sma::Params& p, const EffectSpec& spec, const double* value,
                                   const std::vector<const BaseSpec*>& base) {
  using R = sma::param::Row;
  using sma::param::key_of;
  const double beta = spec.row[0] == R::beta_per_K ? value[0] : 0.0;
  const double shift = spec.row[0] == R::offset_K ? value[0] : 0.0;
  if (beta <= 0.0 && shift == 0.0) return p;
  const double dT_mid = 0.5 * (p.T_AS + p.T_AF) - p.T_amb;
  auto map_T = [&](double T) {
    if (beta <= 0.0) return T + shift;
    const double c = (T - p.T_amb) * (1.0 + beta * dT_mid);
    return p.T_amb + (c > 0.0 ? (sqrt(1.0 + 4.0 * beta * c) - 1.0) / (2.0 * beta) : c);
  };
  sma::Params q = p;
  for (const BaseSpec* b : base) {
    // The wire's temperatures (a degC key but the ambient's) map; e (eq 10: T_MSi = q eps_h + e)
    // is one, q the difference of two.
    const bool wire_T = key_unit(b->key) == "degC" && b->key != key_of<R::T_amb>();
    if (b->key == key_of<R::h>() && beta > 0.0) b->ref(q) = p.h / (1.0 + beta * dT_mid);
    else if (b->key == key_of<R::q>()) b->ref(q) = map_T(p.q + p.e) - map_T(p.e);
    else if (wire_T) b->ref(q) = map_T(b->get(p));
  }
  return q.check() == nullptr ? q : p;
}

// True if a fitted parameter of `f` ends at its physical bound.
inline bool at_bound(const FittedEffect& f) {
  for (int i = 0; i < f.spec->n; ++i) {
    const double tol = 1e-6 * (f.spec->hi[i] - f.spec->lo[i]);
    if (f.value[i] <= f.spec->lo[i] + tol || f.value[i] >= f.spec->hi[i] - tol) {
      const sma::Effects none;
      if (f.value[i] != f.spec->get(none, i)) return true;  // a bound that is "no effect" is fine
    }
  }
  return false;
}

// True if every parameter of `f` is at the value that means "no effect" (sma::Effects'
// defaults), within its 95 % interval.
inline bool at_neutral(const FittedEffect& f) {
  const sma::Effects none;
  for (int i = 0; i < f.spec->n; ++i) {
    const double tol = fmax(f.ci95[i], 1e-9 * f.spec->scale[i]);
    if (fabs(f.value[i] - f.spec->get(none, i)) > tol) return false;
  }
  return true;
}

// ---- credibility: an effect against a stand-in ------------------------------------------------
//
// A physical effect has one value over the whole log and helps wherever the log excites it. A
// stand-in (an effect fitted to absorb a difference of the base model itself, e.g. another
// minor-loop rule) takes whatever value trades the base's error best: its fitted value differs
// between the two halves of the log, and it makes some held-out blocks worse to make others
// better. Both are checked on the winner of a round before it is added.
struct Credibility {
  bool ok = true;
  double half[2][2] = {{0, 0}, {0, 0}};     // the new effect's parameters fitted on each half
  double half_ci[2][2] = {{0, 0}, {0, 0}};  // their 95 % half-widths
  double worst_block = 0;                   // largest held-out block RMS increase, mm
  double worst_block_before = 0;            // that block's RMS before, mm
  std::string why;                          // empty when credible
};

// The held-out blocks of a split (runs of consecutive rows).
inline std::vector<std::vector<size_t>> heldout_blocks(const Split& s) {
  std::vector<std::vector<size_t>> out;
  for (size_t i = 0; i < s.test.size(); ++i) {
    if (i == 0 || s.test[i] != s.test[i - 1] + 1) out.emplace_back();
    out.back().push_back(s.test[i]);
  }
  return out;
}

inline Credibility credibility(const FitOutcome& current, const FitOutcome& win, const RigLog& log,
                               const Split& split, const Options& o, double noise, size_t n_new = 1) {
  Credibility c;
  const sma::Effects none;
  // 1. The same model fitted on the training blocks of each half of the log.
  const double t_mid = 0.5 * (log.t.front() + log.t.back());
  Split half[2];
  for (size_t k : split.train) half[log.t[k] < t_mid ? 0 : 1].train.push_back(k);
  FitOutcome fh[2];
  for (int h = 0; h < 2; ++h) {
    half[h].test = split.test;
    fh[h] = fit_effects(win.params, win.effects, log, half[h], o.refit_base);
  }
  for (size_t e = win.effects.size() - n_new; e < win.effects.size(); ++e) {
  const FittedEffect& added = win.effects[e];
  for (int h = 0; h < 2; ++h)
    for (int i = 0; i < added.spec->n; ++i) {
      c.half[h][i] = fh[h].effects[e].value[i];
      c.half_ci[h][i] = fh[h].effects[e].ci95[i];
    }
  // The first parameter measures the effect's size (a calibration's gain; its offset trades
  // with the sensor zero and the stroke and is not judged).
  for (int i = 0; i < 1; ++i) {
    if (frozen(*added.spec, i, o.refit_base)) continue;
    const double n0 = added.spec->get(none, i);
    const double a = c.half[0][i] - n0, b = c.half[1][i] - n0;
    const double diff = fabs(a - b);
    const double sigma = sqrt(c.half_ci[0][i] * c.half_ci[0][i] + c.half_ci[1][i] * c.half_ci[1][i]) / 1.96;
    const double size = fmax(fabs(a), fabs(b));
    if (diff > o.half_rel * size && diff > 3.0 * sigma && size > 0.05 * added.spec->scale[i]) {
      c.ok = false;
      c.why = std::string(added.spec->name) + "." + added.spec->param[i] + " " + std::to_string(c.half[0][i]) +
              " on the first half, " + std::to_string(c.half[1][i]) + " on the second";
    }
  }
  }
  // 2. No held-out block made clearly worse.
  const std::vector<double> p0 = predict(current.params, effects_of(current.effects), log);
  const std::vector<double> p1 = predict(win.params, effects_of(win.effects), log);
  for (const std::vector<size_t>& blk : heldout_blocks(split)) {
    const double r0 = rms_on(p0, log, blk), r1 = rms_on(p1, log, blk);
    if (r1 - r0 > c.worst_block) {
      c.worst_block = r1 - r0;
      c.worst_block_before = r0;
    }
  }
  // Small next to what the candidate gains overall (a rest block a few um worse while the
  // transformation blocks improve by 0.1 mm) is the price of a partial model, not a trade.
  const double gain = current.rms_test - win.rms_test;
  if (c.worst_block > fmax(fmax(o.block_worse * c.worst_block_before, 2.0 * noise), 0.25 * gain) && c.ok) {
    c.ok = false;
    c.why = "a held-out block gets worse (" + std::to_string(c.worst_block_before) + " -> " +
            std::to_string(c.worst_block_before + c.worst_block) + " mm)";
  }
  return c;
}

template <class Progress>
Diagnosis diagnose(const sma::Params& p, const RigLog& log, const Options& o, Progress progress,
                   const sma::Effects& start = sma::Effects()) {
  Diagnosis d;
  d.noise_mm = noise_level(log);
  const Split split = split_blocks(log, o);
  const double n_eff = fmax(2.0, (log.t.back() - log.t.front()) / 2.0);  // held-out half, 1 per s
  d.nominal = predict(p, sma::Effects(), log);
  std::vector<size_t> all(log.size());
  for (size_t k = 0; k < all.size(); ++k) all[k] = k;
  d.rms_nominal = rms_on(d.nominal, log, all);
  FitOutcome current = fit_effects(p, present_effects(start), log, split, o.refit_base);
  std::vector<const EffectSpec*> idle;  // candidates that won at their neutral value
  // max_effects counts the effects this run adds; those of the given params are refined, not
  // counted (a fitted params file with three effects must still be offered the others).
  const int n_given = static_cast<int>(current.effects.size());
  auto n_added = [&]() { return static_cast<int>(current.effects.size()) - n_given; };
  while (n_added() < o.max_effects) {
    if (current.rms_test < 1.15 * d.noise_mm) break;  // nothing left above the noise
    std::vector<CandidateScore> scores;
    std::vector<const EffectSpec*> todo;
    for (const EffectSpec& spec : vocabulary()) {
      bool have = std::find(idle.begin(), idle.end(), &spec) != idle.end();
      for (const FittedEffect& e : current.effects) have = have || e.spec == &spec;
      if (!have) todo.push_back(&spec);
    }
    // The candidates are independent fits: o.threads of them at a time.
    std::vector<CandidateScore> found(todo.size());
    in_parallel(todo.size(), o.threads, [&](size_t c) {
      const EffectSpec& spec = *todo[c];
      FitOutcome best;
      // Starts: the spec's values from two bases, the last round's (current.params) and the given
      // one (p): the base refit can land in another basin than the given fit's, and the effect's
      // own basin may only be reachable from one of them; then "no effect" from the last round's
      // (its optimum: LM can only improve on it). The best held-out RMS wins.
      // A third base for the effects a fit reads as other parameters (equivalent_base): the given
      // one mapped so that, with the effect at its start value, its steady states stay the same.
      const sma::Effects none;
      const int n_bases = o.refit_base.empty() ? 1 : 3;
      for (int b = 0; b < n_bases; ++b) {
        for (int s = 0; s <= spec.n_starts; ++s) {
          const bool neutral = s == spec.n_starts;
          if (neutral && b > 0) continue;
          std::vector<FittedEffect> trial = current.effects;
          FittedEffect add{&spec, {0, 0}, {0, 0}};
          for (int i = 0; i < spec.n; ++i) add.value[i] = neutral ? spec.get(none, i) : spec.start[s][i];
          trial.push_back(add);
          sma::Params base0 = b == 0 ? current.params : p;
          if (b == 2) {
            base0 = equivalent_base(p, spec, add.value, o.refit_base);
            bool moved = false;
            for (const BaseSpec* bs : o.refit_base) moved = moved || bs->get(base0) != bs->get(p);
            if (!moved) continue;  // not such an effect: the same start as base 1
          }
          const FitOutcome f = fit_effects(base0, trial, log, split, o.refit_base);
          if (f.rms_test < best.rms_test) best = f;
        }
      }
      found[c] = {spec.name, best.rms_test, best};
      progress(spec.name.c_str());  // a candidate done (on one of o.threads threads)
    });
    scores = found;
    std::sort(scores.begin(), scores.end(),
              [](const CandidateScore& a, const CandidateScore& b) { return a.rms_test < b.rms_test; });
    if (scores.empty()) break;
    // A candidate whose fitted parameter ends at its bound stands in for a larger model error
    // (it is not a measurement of the effect): not credible, the next one is judged instead.
    // A candidate that fails credibility() is a stand-in for a difference of the base model:
    // the next one is judged instead (at most 3 such checks per round).
    size_t w = 0;
    int checks = 0;
    bool found_one = false;
    for (; w < scores.size(); ++w) {
      const CandidateScore& cand = scores[w];
      if (at_bound(cand.fit.effects.back())) {
        d.at_bound.push_back(cand.name);
        continue;
      }
      // Both tests on the held-out blocks; BIC charges the winner for its extra parameters.
      const bool clear_gain = cand.rms_test < (1.0 - o.min_gain) * current.rms_test;
      const bool bic_better =
          bic(cand.rms_test, n_eff, cand.fit.effects.back().spec->n) < bic(current.rms_test, n_eff, 0);
      if (!clear_gain || !bic_better) break;  // the later ones gain even less
      if (!o.check_credibility || at_neutral(cand.fit.effects.back())) {
        found_one = true;
        break;
      }
      if (checks++ >= 3) break;
      const Credibility c = credibility(current, cand.fit, log, split, o, d.noise_mm);
      if (getenv("SMA_DISC_DEBUG"))
        fprintf(stderr, "\n[cred] %s held-out %.4f -> %.4f: halves %.4g (+-%.2g) / %.4g (+-%.2g); worst block %.4f -> %.4f: %s\n",
                cand.name.c_str(), current.rms_test, cand.rms_test, c.half[0][0], c.half_ci[0][0], c.half[1][0],
                c.half_ci[1][0], c.worst_block_before, c.worst_block_before + c.worst_block,
                c.ok ? "credible" : c.why.c_str());
      if (c.ok) {
        found_one = true;
        break;
      }
      d.not_credible.push_back(cand.name + ": " + c.why);
    }
    // Pairs that only help together (e.g. a resistance that falls with the fraction advances a
    // sine's response, a sensor lag delays it: each alone makes the fit worse): when no single
    // candidate is credible and the gap is well above the noise, the best candidates of this
    // round are fitted two at a time; the best pair is added if it beats the best single one
    // clearly and both of its effects are credible.
    if (!found_one && o.pair_search && current.rms_test > 3.0 * d.noise_mm &&
        n_added() + 2 <= o.max_effects) {
      const size_t top = std::min<size_t>(4, scores.size());
      std::vector<std::pair<size_t, size_t>> pairs;
      for (size_t a = 0; a < top; ++a)
        for (size_t b = a + 1; b < top; ++b) pairs.emplace_back(a, b);
      for (size_t k = 0; k < pairs.size(); ++k) progress("pairs");
      std::vector<FitOutcome> pf(pairs.size());
      in_parallel(pairs.size(), o.threads, [&](size_t k) {
        for (int st = 0; st < 2; ++st) {
          std::vector<FittedEffect> trial = current.effects;
          for (size_t m : {pairs[k].first, pairs[k].second}) {
            const FittedEffect& single = scores[m].fit.effects.back();
            FittedEffect add{single.spec, {0, 0}, {0, 0}};
            for (int i = 0; i < single.spec->n; ++i) add.value[i] = st == 0 ? single.value[i] : single.spec->start[0][i];
            trial.push_back(add);
          }
          const FitOutcome f = fit_effects(current.params, trial, log, split, o.refit_base);
          if (f.rms_test < pf[k].rms_test) pf[k] = f;
        }
      });
      size_t best = pairs.size();
      for (size_t k = 0; k < pairs.size(); ++k) {
        const size_t n = pf[k].effects.size();
        if (n < 2) continue;
        bool usable = true;
        for (size_t e = n - 2; e < n; ++e) usable = usable && !at_bound(pf[k].effects[e]) && !at_neutral(pf[k].effects[e]);
        if (usable && (best == pairs.size() || pf[k].rms_test < pf[best].rms_test)) best = k;
      }
      if (best < pairs.size()) {
        const FitOutcome& pw = pf[best];
        const int k_par = pw.effects[pw.effects.size() - 2].spec->n + pw.effects.back().spec->n;
        const bool clear_gain = pw.rms_test < (1.0 - o.min_gain) * current.rms_test &&
                                pw.rms_test < (1.0 - o.min_gain) * scores[0].rms_test;
        const bool bic_better = bic(pw.rms_test, n_eff, k_par) < bic(current.rms_test, n_eff, 0);
        const std::string pair_name = scores[pairs[best].first].name + " + " + scores[pairs[best].second].name;
        if (clear_gain && bic_better) {
          const Credibility c = credibility(current, pw, log, split, o, d.noise_mm, 2);
          if (getenv("SMA_DISC_DEBUG"))
            fprintf(stderr, "\n[cred] pair %s held-out %.4f -> %.4f: %s\n", pair_name.c_str(), current.rms_test,
                    pw.rms_test, c.ok ? "credible" : c.why.c_str());
          if (c.ok) {
            for (size_t e = pw.effects.size() - 2; e < pw.effects.size(); ++e) {
              Step step;
              step.added = pw.effects[e];
              step.rms_before = current.rms_all;
              step.rms_after = pw.rms_all;
              step.candidates = scores;
              d.steps.push_back(step);
            }
            current = pw;
            continue;
          }
          d.not_credible.push_back(pair_name + ": " + c.why);
        }
      }
    }
    if (!found_one) {
      d.rejected = scores;
      break;
    }
    const CandidateScore& win = scores[w];
    if (at_neutral(win.fit.effects.back())) {
      // The winner's own parameter stayed at "no effect": the gain came from refitting the rest
      // from a new starting point. Keep that better fit, without the idle effect, and do not
      // offer it again (it would be reported with a value of 0 +- 0).
      current = win.fit;
      current.effects.pop_back();
      idle.push_back(win.fit.effects.back().spec);
      continue;
    }
    Step step;
    step.added = win.fit.effects.back();
    step.rms_before = current.rms_all;
    step.rms_after = win.fit.rms_all;
    for (size_t i = w + 1; i < scores.size(); ++i)
      if (scores[i].rms_test < (1.0 + o.ambiguity) * win.rms_test) step.lookalikes.push_back(scores[i].name);
    step.candidates = scores;
    d.steps.push_back(step);
    current = win.fit;
  }
  // An effect added early can end at its no-effect value once the later ones are fitted with it
  // (it stood in for them): it leaves the final model and the list of added effects.
  std::vector<FittedEffect> kept;
  for (const FittedEffect& e : current.effects) {
    bool added = false;
    for (const Step& st : d.steps) added = added || st.added.spec == e.spec;
    if (added && at_neutral(e)) {
      d.pruned.push_back(e.spec->name);
      d.steps.erase(std::remove_if(d.steps.begin(), d.steps.end(),
                                   [&](const Step& st) { return st.added.spec == e.spec; }),
                    d.steps.end());
    } else {
      kept.push_back(e);
    }
  }
  if (!d.pruned.empty()) current = fit_effects(current.params, kept, log, split, o.refit_base);
  d.effects = current.effects;
  d.params = current.params;
  d.base_ci95 = current.base_ci95;
  d.rms_test_final = current.rms_test;
  d.corrected = predict(current.params, effects_of(current.effects), log);
  d.rms_final = rms_on(d.corrected, log, all);
  return d;
}

inline Diagnosis diagnose(const sma::Params& p, const RigLog& log, const Options& o = Options()) {
  return diagnose(p, log, o, [](const char*) {});
}

// ---- the re-heat reading -------------------------------------------------------------------

// The reading of a re-heat that stops short of transformation is a choice of the model's
// structure (hysteresis.hpp), not an effect: it is decided first, with the effects fitted under
// each reading. When the two readings predict the log alike (no such re-heat, or one that
// changes nothing the sensor sees) the given reading is kept without a second run. Otherwise
// the whole diagnosis runs with each, and the other reading replaces the given one only when
// its final held-out gap is clearly smaller: its excess over the noise below 0.7 of the given
// reading's and the two RMS apart by more than a quarter of the noise.
template <class Progress>
Diagnosis diagnose_reading(const sma::Params& p, const RigLog& log, const Options& o, Progress progress,
                           const sma::Effects& start = sma::Effects()) {
  const int given = p.reheat == sma::Reheat::new_loop ? 1 : 0;
  if (!o.choose_reading) {
    Diagnosis d = diagnose(p, log, o, progress, start);
    d.reading_why = std::string("given (") + reheat_name(p.reheat) + "): not compared";
    return d;
  }
  sma::Params alt = p;
  alt.reheat = given ? sma::Reheat::return_point : sma::Reheat::new_loop;
  const double noise = noise_level(log);
  const std::vector<double> a = predict(p, start, log), b = predict(alt, start, log);
  double diff = 0.0;
  for (size_t k = 0; k < a.size(); ++k) diff += (a[k] - b[k]) * (a[k] - b[k]);
  diff = a.empty() ? 0.0 : ::sqrt(diff / static_cast<double>(a.size()));
  char buf[320];
  if (diff < noise) {
    Diagnosis d = diagnose(p, log, o, progress, start);
    std::snprintf(buf, sizeof buf,
                  "kept %s: the two readings of a re-heat predict this log alike (%.2g mm RMS apart, "
                  "noise %.2g mm)", reheat_name(p.reheat), diff, noise);
    d.reading_why = buf;
    return d;
  }
  Diagnosis dg = diagnose(p, log, o, progress, start);
  Diagnosis da = diagnose(alt, log, o, progress, start);
  auto excess = [noise](double r) { return ::sqrt(std::max(r * r - noise * noise, 0.0)); };
  const bool switch_reading = excess(da.rms_test_final) < 0.7 * excess(dg.rms_test_final) &&
                              dg.rms_test_final - da.rms_test_final > 0.25 * noise;
  Diagnosis& d = switch_reading ? da : dg;
  d.reading_rms_test[given] = dg.rms_test_final;
  d.reading_rms_test[1 - given] = da.rms_test_final;
  std::snprintf(buf, sizeof buf,
                "%s %s: final held-out gap %.4g mm with %s, %.4g mm with %s (noise %.2g mm; the readings "
                "differ by %.2g mm RMS on this log)",
                switch_reading ? "chose" : "kept", reheat_name(d.params.reheat), d.rms_test_final,
                reheat_name(d.params.reheat), (switch_reading ? dg : da).rms_test_final,
                reheat_name((switch_reading ? dg : da).params.reheat), noise, diff);
  d.reading_why = buf;
  return d;
}

}  // namespace sma_host

#endif  // SMA_HOST_DISCREPANCY_HPP
