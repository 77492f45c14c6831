// sma_fit: identification of the model from a training log, as in the paper's section III.B.
//
// The model is run only through the library (sma::Plant, via replay.hpp) on the log's own v_V;
// Eigen's Levenberg-Marquardt (unsupported/NonLinearOptimization) minimises the displacement
// residual d_model - d_mm over the chosen parameters. The Jacobian is a forward difference with
// a fixed step per parameter (the hysteresis is piecewise: derivatives from steps near machine
// precision would be noise). After the fit: covariance = s^2 (J^T J)^-1 (pseudo-inverse: a
// direction the log does not excite is reported as not identifiable), 95 % intervals, the
// correlation matrix, and the pairs that are hard to separate.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/types.h>

#include <Eigen/Dense>
#include <unsupported/Eigen/NonLinearOptimization>

#include "sma_host/initial_guess.hpp"
#include "sma_host/lm_progress.hpp"
#include "sma_tools/cli.hpp"
#include "sma_tools/params_json.hpp"
#include "sma_tools/replay.hpp"
#include "sma_tools/rig_log.hpp"

using namespace sma_tools;

static const char* kUsage =
    "usage: sma_fit LOG.csv [LOG2.csv ...] --out DIR [--params START.json] [--validate V.csv ...]\n"
    "               [--fit NAMES | --fix NAMES] [--max-points N] [--max-evals N] [--eps0 X]\n"
    "\n"
    "Fits the model to a training log (paper III.B: slow decaying voltage ramp with reversals)\n"
    "and writes DIR/params.json (contract format), DIR/fit.json, DIR/report.md,\n"
    "DIR/fit_curves.csv (and DIR/validate_curves.csv) for the plots.\n"
    "\n"
    "  --params START.json  start values and everything not fitted (default: the paper's)\n"
    "  --fit NAMES          comma list of parameters to fit (default: all of\n"
    "                       h,T_AS,T_AF,T_MF,q,e,T_MSs,T_MSf,g,offset_mm,j1..jn,T_ii1..T_iin\n"
    "                       where n = number of loops); also available: T_amb, gain, R,\n"
    "                       alpha_per_K (thermal_expansion), L_J (latent_heat),\n"
    "                       beta_per_K (convection_nonlinear), delay_s, tau_s, offset_K, k_R,\n"
    "                       T_s, T_f (else tied to the fitted bands, as T_MSs, T_MSf, the\n"
    "                       loops' T_i, T_ii when not fitted)\n"
    "  --fix NAMES          remove these from the default set\n"
    "  several LOGs         one wire fitted to all of them, with a sensor zero per run (they\n"
    "                       must share one sample rate and column set, else refused)\n"
    "  --validate V.csv ... logs not used for the fit: the fitted model predicts each (its sensor\n"
    "                       zero fitted alone); table of RMS / max error, whole run, heating and\n"
    "                       cooling halves (fit.json \"runs\", report.md)\n"
    "  --max-points N       residual samples used by the fit (default 6000, evenly spaced)\n"
    "  --max-evals N        budget of model runs for LM (default 400)\n"
    "  --eps0 X             austenite fraction at the start of each log (default: the engine's\n"
    "                       rule, from the log's first readings; docs/identification.md)\n"
    "  --max-bad F          refuse a log with more than this fraction of bad rows (0.01)\n"
    "  --loops-at-reversals move the loop knots T_i from the start values to the log's reversal\n"
    "                       temperatures inside (T_s, T_f), where j and T_ii are observed\n"
    "                       (default set of --fit only)\n"
    "  --guess              start from values read from the log (sma_host/initial_guess.hpp):\n"
    "                       h from a grid of replays, the bands where d moves, g, the offset,\n"
    "                       T_s/T_f/T_MSs/T_MSf/loops tied to the bands; R, d0, L0, T_amb kept\n"
    "  --band-hint C        with --guess: the wire's nominal heating band middle, degC; fixes\n"
    "                       the heating power's scale (R), which V and d alone cannot tell\n"
    "  --reheat R           the loop memory's reading of a re-heat short of transformation,\n"
    "                       return_point or new_loop (default: the start's, replaced by the\n"
    "                       other when the log is fitted clearly better with it; fit.json\n"
    "                       \"reheat\", params.json key \"reheat\")\n";

namespace {

// The fitted parameters and the LM residual are the engine's (sma_host/identify.hpp): the
// residual object shared with the discrepancy workflow.
using sma_host::FitFunctor;
using sma_host::FitResidual;
using sma_host::ParamSpec;
using Row = sma::param::Row;
using sma::param::key_of;
using Problem = sma_host::FitResidual;
using LmFunctor = sma_host::FitFunctor;
std::vector<ParamSpec> all_specs(const Model& m) { return sma_host::fittable_params(m); }
std::vector<std::string> default_fit(const Model& m) { return sma_host::default_fit_names(m); }

// ---- statistics --------------------------------------------------------------------------------
struct Stats {
  double rms = 0, max = 0, mean = 0;
  double lag1 = 0;  // autocorrelation of the residual at one sample
};

Stats stats_of(const std::vector<double>& r) {
  Stats s;
  if (r.empty()) return s;
  double sum = 0, sq = 0;
  for (double x : r) {
    sum += x;
    sq += x * x;
    s.max = std::max(s.max, std::fabs(x));
  }
  const double n = static_cast<double>(r.size());
  s.mean = sum / n;
  s.rms = std::sqrt(sq / n);
  double num = 0, den = 0;
  for (size_t k = 0; k < r.size(); ++k) {
    den += (r[k] - s.mean) * (r[k] - s.mean);
    if (k) num += (r[k] - s.mean) * (r[k - 1] - s.mean);
  }
  s.lag1 = den > 0 ? num / den : 0.0;
  return s;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t k = static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
}

std::string fmt(double x, int prec = 4) {
  if (std::isnan(x)) return "-";
  if (!std::isfinite(x)) return "inf";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*g", prec, x);
  return buf;
}
std::string fixed(double x, int dec) {
  if (!std::isfinite(x)) return "inf";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", dec, x);
  return buf;
}

double start_offset(const RigLog& log) {
  const size_t n = std::min<size_t>(log.size(), 50);
  double s = 0;
  for (size_t k = 0; k < n; ++k) s += log.d[k];
  return s / static_cast<double>(n);
}

void write_curves(const std::string& path, const RigLog& log, const Trace& fit, const Trace& start,
                  const std::string& comment) {
  std::ofstream f(path);
  if (!f) throw Error(path + ": cannot write");
  f << "# " << comment << "\n";
  f << "t_s,v_V,d_mm,d_fit_mm,d_start_mm,T_fit_C,eps_fit,D_fit_mm\n";
  const size_t stride = std::max<size_t>(1, log.size() / 20000);
  char buf[256];
  for (size_t k = 0; k < log.size(); k += stride) {
    std::snprintf(buf, sizeof buf, "%.4f,%.5f,%.6f,%.6f,%.6f,%.4f,%.6f,%.6f\n", log.t[k], log.v[k],
                  log.d[k], fit.d[k], start.d[k], fit.T[k], fit.eps[k], fit.D[k]);
    f << buf;
  }
}

void make_dirs(const std::string& dir) {
  for (size_t pos = 1; pos <= dir.size(); ++pos) {
    if (pos < dir.size() && dir[pos] != '/') continue;
    const std::string part = dir.substr(0, pos);
    struct stat st;
    if (stat(part.c_str(), &st) == 0) {
      if (!S_ISDIR(st.st_mode)) throw Error(part + ": exists and is not a directory");
      continue;
    }
    if (mkdir(part.c_str(), 0777) != 0) throw Error(part + ": cannot create directory");
  }
}

struct RunRow {
  std::string log, role;
  double offset_mm;
  sma_host::RunErrors e;
};

struct Validation {
  std::string name;
  size_t rows = 0;
  Stats fitted_offset, tared;
  double tare_offset = 0;
};

int run(int argc, char** argv) {
  Args a(argc, argv);
  std::string out_dir, params_path, fit_list, fix_list;
  std::vector<std::string> log_paths, val_paths;
  size_t max_points = 6000;
  long max_evals = 400;
  double eps0 = -1.0;
  bool loops_at_reversals = false;
  bool guess = false;
  double band_hint = NAN;
  std::string reheat_arg;  // --reheat: the loop memory's reading fixed, not decided on the log
  LogReadOptions lro;
  if (a.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  while (!a.empty()) {
    const std::string k = a.next();
    if (k == "-h" || k == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (k == "--out") out_dir = a.value(k);
    else if (k == "--params") params_path = a.value(k);
    else if (k == "--validate") {
      val_paths.push_back(a.value(k));
      while (!a.empty() && !a.peek().empty() && a.peek()[0] != '-') val_paths.push_back(a.next());
    }
    else if (k == "--fit") fit_list = a.value(k);
    else if (k == "--fix") fix_list = a.value(k);
    else if (k == "--max-points") max_points = static_cast<size_t>(std::max(100.0, a.number(k)));
    else if (k == "--max-evals") max_evals = static_cast<long>(std::max(10.0, a.number(k)));
    else if (k == "--eps0") eps0 = a.number(k);
    else if (k == "--max-bad") lro.max_bad_fraction = a.number(k);
    else if (k == "--loops-at-reversals") loops_at_reversals = true;
    else if (k == "--guess") guess = true;
    else if (k == "--band-hint") band_hint = a.number(k);
    else if (k == "--reheat") {
      reheat_arg = a.value(k);
      reheat_option(reheat_arg);
    }
    else if (!k.empty() && k[0] == '-') throw Error("unknown option '" + k + "' (see --help)");
    else log_paths.push_back(k);
  }
  if (log_paths.empty()) throw Error("no training log given (see --help)");
  if (out_dir.empty()) throw Error("--out DIR is required");
  if (eps0 != -1.0 && !(eps0 >= 0.0 && eps0 <= 1.0)) throw Error("--eps0 must be in 0..1");

  // The start model: the params file (default: the paper's Table II). Start values estimated from
  // the logs themselves plug in here, as a function (logs, Model) -> Model.
  Model start = read_model(params_path);
  if (!reheat_arg.empty())
    start.p.reheat = reheat_option(reheat_arg);
  const std::string start_name = params_path.empty() ? "the paper's Table II" : params_path;
  std::vector<RigLog> logs;
  std::vector<std::string> notes;
  for (const std::string& path : log_paths) {
    logs.push_back(read_rig_log(path, lro));
    const RigLog& l = logs.back();
    if (l.dropped) {
      std::cerr << dropped_note(l) << "\n";
      notes.push_back(l.name + ": dropped " + std::to_string(l.dropped) + " bad rows of " + std::to_string(l.rows_read));
    }
  }
  std::vector<const RigLog*> log_ptrs;
  for (const RigLog& l : logs) log_ptrs.push_back(&l);
  sma_host::check_compatible(log_ptrs);
  const RigLog& log = logs[0];
  // Every training log must excite the wire (the checks below name the log that does not).
  for (size_t li = logs.size(); li-- > 0;) {
  const RigLog& lg = logs[li];

  // ---- is there anything to identify? ----------------------------------------------------------
  const double tau = start.p.heat_capacity() / start.p.conductance();
  if (lg.size() < 100 || lg.duration() < tau)
    throw Error(lg.name + ": too short to identify anything: " + std::to_string(lg.size()) +
                " rows over " + fixed(lg.duration(), 1) + " s (need >= 100 rows and >= " +
                fixed(tau, 1) + " s, one thermal time constant of the start model)");
  if (lg.duration() < 5.0 * tau)
    notes.push_back(lg.name + " lasts " + fixed(lg.duration(), 1) + " s, less than 5 thermal time constants (" +
                    fixed(5 * tau, 1) + " s) of the start model: the thermal parameters are poorly determined");
  const double vlo = *std::min_element(lg.v.begin(), lg.v.end());
  const double vhi = *std::max_element(lg.v.begin(), lg.v.end());
  if (!(vhi - vlo > 1e-3))
    throw Error(lg.name + ": no excitation: v_V is constant (" + fixed(vlo, 4) +
                " V) over the whole log; identification needs a voltage that heats the wire "
                "through its transformation and back (e.g. sma_sim --volt train)");
  const double noise_i = sma_host::noise_level(lg.d);
  const double dspan_i = percentile(lg.d, 0.99) - percentile(lg.d, 0.01);
  if (!(dspan_i > std::max(20.0 * noise_i, 1e-3)))
    throw Error(lg.name + ": no excitation: d_mm only spans " + fmt(dspan_i) +
                " mm (noise about " + fmt(noise_i) + " mm): the wire did not move");
  }
  const double vlo = *std::min_element(log.v.begin(), log.v.end());
  const double vhi = *std::max_element(log.v.begin(), log.v.end());
  const double noise = sma_host::noise_level(log.d);
  const double dspan = percentile(log.d, 0.99) - percentile(log.d, 0.01);
  if (guess) {  // start values from the (first) log itself: initial_guess.hpp
    sma_host::GuessOptions go;
    go.band_hint_C = band_hint;
    const sma_host::Guess gs = sma_host::initial_guess(log.t, log.v, log.d, start.p, start.fx, go);
    start.p = gs.p;
    start.fx = gs.fx;
    for (const auto& n : gs.notes) notes.push_back(n);
  }
  if (start.fx.sensor_offset_mm == 0.0) start.fx.sensor_offset_mm = start_offset(log);

  // Start model: does it transform at all on this voltage?
  Trace tr0;
  {
    ReplayOptions o;
    o.eps0 = eps0;
    replay(start, log.t, log.v, log.d, o, tr0);
  }
  const double Tmax0 = *std::max_element(tr0.T.begin(), tr0.T.end());
  if (Tmax0 < start.p.T_AS)
    throw Error(log.name + ": with the start parameters (" + start_name +
                ") the wire never reaches T_AS = " + fixed(start.p.T_AS, 1) + " degC (model max " +
                fixed(Tmax0, 1) + " degC at " + fixed(vhi, 3) +
                " V): give --params with R, h, d0, L0, T_amb of your wire");

  // ---- the re-heat reading ---------------------------------------------------------------------
  // How the loop memory reads a re-heat short of transformation (sma::Reheat, hysteresis.hpp) is
  // a choice of the model's structure, decided on the log: when the two readings predict it
  // differently with the start model, the whole fit below runs with each and the other reading
  // replaces the start's only when its residual is clearly smaller (excess over the noise below
  // 0.7 of the start reading's, and the RMS apart by more than a quarter of the noise).
  std::vector<Model> reading_starts = {start};
  double readings_apart = 0.0;
  if (reheat_arg.empty()) {
    Model alt = start;
    alt.p.reheat = start.p.reheat == sma::Reheat::new_loop ? sma::Reheat::return_point : sma::Reheat::new_loop;
    Trace tr_alt;
    ReplayOptions o;
    o.eps0 = eps0;
    o.want_states = false;
    replay(alt, log.t, log.v, log.d, o, tr_alt);
    for (size_t k = 0; k < tr_alt.d.size(); ++k) readings_apart += (tr_alt.d[k] - tr0.d[k]) * (tr_alt.d[k] - tr0.d[k]);
    readings_apart = std::sqrt(readings_apart / static_cast<double>(std::max<size_t>(1, tr_alt.d.size())));
    if (readings_apart > noise) reading_starts.push_back(alt);
  }
  struct ReadingRun {
    Problem pb;
    Eigen::VectorXd x;
    int status;
    Eigen::Index iterations;
    std::string stage1_note;
    std::vector<std::string> notes;
    double rms;
    size_t reading;  // index into reading_starts
    bool tie;        // the minor-loop band tied to the fitted bands
  };
  std::vector<ReadingRun> reading_runs;
  const std::vector<std::string> notes_before = notes;
  // ---- the minor-loop band: tied or kept ----------------------------------------------------------
  // Tied (identify.hpp tie_to_bands): T_s, T_f, the loops and T_MSs, T_MSf move with the fitted
  // transformation bands, as on a wire whose whole hysteresis is shifted. Kept: they stay at the
  // start's temperatures, as on a wire whose major loop moved but whose minor loops did not. Which
  // one a wire is cannot be known before the fit: for each reading the fit runs both and keeps the
  // tied one unless the other explains the log clearly better (RMS at least 10 % lower).
  for (size_t reading = 0; reading < reading_starts.size(); ++reading)
  for (int tie = 1; tie >= 0; --tie) {
  start = reading_starts[reading];
  notes = notes_before;

  // ---- parameters to fit -------------------------------------------------------------------------
  const std::vector<ParamSpec> specs_all = all_specs(start);
  std::vector<std::string> names = fit_list.empty() ? default_fit(start) : split_names(fit_list);
  for (const auto& f : split_names(fix_list)) {
    const auto it = std::find(names.begin(), names.end(), f);
    bool known = false;
    for (const auto& s : specs_all) known = known || s.name == f;
    if (!known) throw Error("--fix: unknown parameter '" + f + "'");
    if (it != names.end()) names.erase(it);
  }
  if (!tie && std::find(names.begin(), names.end(), "T_s") != names.end() &&
      std::find(names.begin(), names.end(), "T_f") != names.end())
    continue;  // both fitted: nothing is tied
  Problem pb;
  pb.logs = log_ptrs;
  pb.start = start;
  pb.eps0 = eps0;
  pb.tie_bands = tie != 0;
  size_t total_rows = 0;
  for (const RigLog& l : logs) total_rows += l.size();
  pb.stride = std::max<size_t>(1, (total_rows + max_points - 1) / max_points);
  pb.penalty = 10.0 * std::max(dspan, 1e-3);
  for (const auto& n : names) {
    const ParamSpec* found = nullptr;
    for (const auto& s : specs_all)
      if (s.name == n) found = &s;
    if (!found) {
      std::string known;
      for (const auto& s : specs_all) known += " " + s.name;
      throw Error("--fit: unknown parameter '" + n + "' (known:" + known + ")");
    }
    for (const auto& s : pb.specs)
      if (s.name == n) throw Error("--fit: '" + n + "' given twice");
    pb.specs.push_back(*found);
    Model tmp = start;
    pb.x0.push_back(*found->ref(tmp));
  }
  // A sensor zero per run after the first (a potentiometer's zero moves between runs): started
  // at the run's first readings, fitted with the rest when offset_mm is.
  const ParamSpec zero = sma_host::param_spec(key_of<Row::offset_mm>(), start);
  const bool fit_offset = std::find(names.begin(), names.end(), zero.name) != names.end();
  for (size_t r = 1; r < logs.size(); ++r) {
    pb.run_offset.push_back(start_offset(logs[r]));
    if (fit_offset) {
      ParamSpec run_zero = zero;
      run_zero.name += "[" + logs[r].name + "]";
      run_zero.key = sma::param::kNoKey;
      run_zero.run = r;
      pb.specs.push_back(run_zero);
      pb.x0.push_back(pb.run_offset.back());
    }
  }
  if (pb.specs.empty()) throw Error("nothing to fit");

  // A fit of the cooling parameters needs a log that cools the wire back through its
  // transformation: refused, naming the logs and the parameters, rather than misfitted.
  {
    std::vector<std::string> asked;
    for (const ParamSpec& sp : pb.specs)
      if (sma_host::cooling_param(sp.key)) asked.push_back(sp.name);
    std::vector<std::string> no_cooling;
    for (const RigLog& l : logs)
      if (!sma_host::cools_in_log(l)) no_cooling.push_back(l.name);
    std::string plist, llist;
    for (const std::string& n : asked) plist += (plist.empty() ? "" : ", ") + n;
    for (const std::string& n : no_cooling) llist += (llist.empty() ? "" : ", ") + n;
    if (!asked.empty() && no_cooling.size() == logs.size())
      throw Error(llist + ": the wire is never cooled back through its transformation (the measured position "
                  "never falls from its peak by 20 % of the stroke), so the cooling parameters " + plist +
                  " cannot be fitted on it: give a log that heats AND cools, or --fix " + plist);
    if (!asked.empty() && !no_cooling.empty())
      notes.push_back(llist + ": no cooling through the transformation: the cooling parameters (" + plist +
                      ") come from the other logs");
  }

  // ---- stage 1: the major loop and the thermal gain, from several starts of h --------------------
  // A quasi-static ramp fixes mostly G (T - T_amb) products: h and the transformation
  // temperatures slide along a valley together, and LM from one start can stop far down it. The
  // major-loop parameters are therefore first fitted alone from h0 x 2^(-1..1), and the best
  // becomes the start of the full fit.
  std::string stage1_note;
  {
    const Row major[] = {Row::h, Row::T_AS, Row::T_AF, Row::T_MF, Row::g, Row::offset_mm, Row::T_amb, Row::gain, Row::R};
    Problem p1 = pb;
    p1.specs.clear();
    p1.x0.clear();
    bool has_h = false;
    for (size_t i = 0; i < pb.specs.size(); ++i)
      for (Row r : major)
        if (pb.specs[i].is(r) || (pb.specs[i].key == sma::param::kNoKey && r == Row::offset_mm)) {
          p1.specs.push_back(pb.specs[i]);
          has_h = has_h || pb.specs[i].is(Row::h);
        }
    if (p1.specs.size() >= 1 && p1.specs.size() < pb.specs.size()) {
      std::vector<double> mults = {1.0};
      if (has_h) mults = {1.0, 0.5, 0.63, 0.79, 1.26, 1.59, 2.0};
      double best_sse = INFINITY;
      Model best = pb.start;
      std::vector<double> best_run_offset = pb.run_offset;
      double best_mult = 1.0;
      for (double mult : mults) {
        p1.start = pb.start;
        p1.start.p.h = pb.start.p.h * mult;
        p1.x0.clear();
        for (const auto& sp : p1.specs)
          p1.x0.push_back(sp.ref(p1.start) ? *sp.ref(p1.start) : pb.run_offset[sp.run - 1]);
        LmFunctor f1{&p1};
        Eigen::VectorXd x1 = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(p1.specs.size()));
        Eigen::LevenbergMarquardt<LmFunctor> lm1(f1);
        lm1.parameters.maxfev = 60;
        lm1.parameters.xtol = 1e-5;
        lm1.parameters.ftol = 1e-6;
        lm1.parameters.factor = 10.0;
        sma_host::minimize_reporting(lm1, x1, "fit stage 1");
        Eigen::VectorXd r1;
        const Model m1 = p1.model_at(x1);
        if (!p1.residual_at(x1, r1)) continue;
        if (r1.squaredNorm() < best_sse) {
          best_sse = r1.squaredNorm();
          best = m1;
          best_mult = mult;
          for (size_t r = 1; r < logs.size(); ++r) best_run_offset[r - 1] = p1.model_for_run(m1, x1, r).fx.sensor_offset_mm;
        }
      }
      pb.runs += p1.runs;
      pb.start = best;
      pb.run_offset = best_run_offset;
      for (size_t i = 0; i < pb.specs.size(); ++i)
        pb.x0[i] = pb.specs[i].ref(best) ? *pb.specs[i].ref(best) : pb.run_offset[pb.specs[i].run - 1];
      stage1_note = "stage 1 (major loop";
      stage1_note += has_h ? ", best of 7 starts of h: x" + fixed(best_mult, 2) + ")" : ")";
      stage1_note += ": RMS " + fmt(std::sqrt(best_sse / static_cast<double>(pb.rows()))) + " mm";
    }
  }

  // ---- loop knots at the log's reversals -----------------------------------------------------------
  // j and T_ii are only observed at the peak temperatures T_i the log reverses at; the model
  // interpolates them between knots. As in the paper (T_1..T_5 of Fig. 5 are the training's
  // reversals), the knots are put at the reversals of the stage-1 model's temperature inside
  // (T_s, T_f), so each fitted j_i, T_ii belongs to a loop the log really ran.
  if (fit_list.empty() && loops_at_reversals) {
    Trace tr1;
    ReplayOptions o;
    o.eps0 = eps0;
    replay(pb.start, log.t, log.v, log.d, o, tr1);
    std::vector<double> peaks;
    const double thr = 3.0;  // K: a reversal is a fall of at least this much after a peak
    double cand = tr1.T[0], low = tr1.T[0];
    bool rising = true;
    for (double T : tr1.T) {
      if (rising) {
        if (T > cand) cand = T;
        if (T < cand - thr) {
          peaks.push_back(cand);
          rising = false;
          low = T;
        }
      } else {
        if (T < low) low = T;
        if (T > low + thr) {
          rising = true;
          cand = T;
        }
      }
    }
    const sma::Params& P = pb.start.p;
    std::vector<double> inner;
    for (double T : peaks)
      if (T > P.T_s + 0.5 && T < P.T_f - 0.5) inner.push_back(T);
    std::sort(inner.begin(), inner.end());
    std::vector<double> knots;
    for (double T : inner)
      if (knots.empty() || T - knots.back() > 1.0) knots.push_back(T);
    while (knots.size() > sma::kMaxLoopKnots) {  // drop the knot closest to its neighbour
      size_t worst = 1;
      for (size_t i = 1; i < knots.size(); ++i)
        if (knots[i] - knots[i - 1] < knots[worst] - knots[worst - 1]) worst = i;
      knots.erase(knots.begin() + static_cast<long>(worst));
    }
    if (!knots.empty()) {
      double jmean = 0;
      for (int k = 0; k < P.n_loops; ++k) jmean += P.loops[k].j / P.n_loops;
      if (!(jmean > 0.01)) jmean = 0.1;
      Model m = pb.start;
      m.p.n_loops = static_cast<uint8_t>(knots.size());
      std::string list;
      for (size_t k = 0; k < knots.size(); ++k) {
        m.p.loops[k] = {knots[k], knots[k] - 2.0, jmean};
        list += (k ? ", " : "") + fixed(knots[k], 1);
      }
      pb.start = m;
      std::vector<ParamSpec> keep;
      std::vector<double> keep_x0;
      for (size_t i = 0; i < pb.specs.size(); ++i)
        if (!pb.specs[i].is(Row::loop_j) && !pb.specs[i].is(Row::loop_T_ii)) {
          keep.push_back(pb.specs[i]);
          keep_x0.push_back(pb.specs[i].ref(m) ? *pb.specs[i].ref(m) : pb.x0[i]);
        }
      for (const ParamSpec& sp : all_specs(m))
        if (sp.is(Row::loop_j) || sp.is(Row::loop_T_ii)) {
          keep.push_back(sp);
          keep_x0.push_back(*sp.ref(m));
        }
      pb.specs = keep;
      pb.x0 = keep_x0;
      notes.push_back("loop knots T_i moved to the log's reversals inside (T_s, T_f) = (" + fixed(P.T_s, 1) +
                      ", " + fixed(P.T_f, 1) + ") of the stage-1 model: " + list +
                      " degC");
    }
  }

  // Drop what this log does not excite (a zero column of the Jacobian after stage 1).
  LmFunctor fun{&pb};
  {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(pb.specs.size()));
    Eigen::MatrixXd J;
    fun.df(x, J);
    const double colmax = J.colwise().norm().maxCoeff();
    std::vector<ParamSpec> keep;
    std::vector<double> keep_x0;
    for (size_t i = 0; i < pb.specs.size(); ++i) {
      if (J.col(static_cast<Eigen::Index>(i)).norm() <= 1e-9 * colmax) {
        const ParamSpec& sp = pb.specs[i];
        const bool tied = sp.is(Row::loop_T_ii) || sp.is(Row::T_MSs) || sp.is(Row::T_MSf) || sp.is(Row::T_s) ||
                          sp.is(Row::T_f);
        notes.push_back(sp.name + ": not fitted: this log does not excite it (no sensitivity after stage 1); " +
                        (tied ? std::string("it follows its transformation band from ") + fmt(pb.x0[i], 6)
                              : "kept at its start value " + fmt(pb.x0[i], 6)));
      } else {
        keep.push_back(pb.specs[i]);
        keep_x0.push_back(pb.x0[i]);
      }
    }
    pb.specs = keep;
    pb.x0 = keep_x0;
    if (pb.specs.empty()) throw Error(log.name + ": no parameter is excited by this log");
  }
  const size_t np = pb.specs.size();
  if (pb.rows() < 3 * np)
    throw Error(log.name + ": too few samples (" + std::to_string(pb.rows()) + ") for " +
                std::to_string(np) + " parameters");

  // ---- Levenberg-Marquardt -----------------------------------------------------------------------
  Eigen::VectorXd x = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(np));
  Eigen::VectorXd f_start;
  pb.residual_at(x, f_start);
  Eigen::LevenbergMarquardt<LmFunctor> lm(fun);
  lm.parameters.maxfev = max_evals / static_cast<long>(np + 1) + 5;  // LM counts residual calls
  lm.parameters.xtol = 1e-6;
  lm.parameters.ftol = 1e-8;
  lm.parameters.factor = 10.0;
  const int status_r = sma_host::minimize_reporting(lm, x, "fit");
  Eigen::VectorXd f_end;
  pb.residual_at(x, f_end);
  reading_runs.push_back({pb, x, status_r, lm.iter, stage1_note, notes,
                          std::sqrt(f_end.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, f_end.size()))),
                          reading, tie != 0});
  }
  // Per reading: the tied band unless keeping the start's is clearly better.
  std::vector<ReadingRun> per_reading;
  for (size_t k = 0; k < reading_starts.size(); ++k) {
    const ReadingRun* tied = nullptr;
    const ReadingRun* kept = nullptr;
    for (const ReadingRun& r : reading_runs)
      if (r.reading == k) (r.tie ? tied : kept) = &r;
    ReadingRun pick = *tied;
    if (kept) {
      const bool keep_start = kept->rms < 0.9 * tied->rms;
      if (keep_start) pick = *kept;
      pick.notes.push_back(std::string("minor-loop band ") +
                           (keep_start ? "kept at the start's temperatures: it explains the log clearly better (RMS "
                                       : "tied to the fitted transformation bands, the prior, kept unless the other "
                                         "explains the log clearly better (RMS ") +
                           fmt(pick.rms) + " mm against " + fmt(keep_start ? tied->rms : kept->rms) + " mm " +
                           (keep_start ? "tied" : "kept") + ")");
    }
    per_reading.push_back(pick);
  }
  reading_runs = per_reading;
  size_t chosen = 0;
  std::string reading_note;
  if (reading_runs.size() == 2) {
    auto excess = [noise](double r) { return std::sqrt(std::max(r * r - noise * noise, 0.0)); };
    const double r0 = reading_runs[0].rms, r1 = reading_runs[1].rms;
    if (excess(r1) < 0.7 * excess(r0) && r0 - r1 > 0.25 * noise) chosen = 1;
    const sma::Reheat other = reading_starts[1 - chosen].p.reheat;
    reading_note = std::string(chosen ? "chose" : "kept") + " the re-heat reading " +
                   sma_tools::reheat_name(reading_starts[chosen].p.reheat) + ": fit RMS " +
                   fmt(reading_runs[chosen].rms) + " mm, against " + fmt(reading_runs[1 - chosen].rms) + " mm with " +
                   sma_tools::reheat_name(other) + " (noise " + fmt(noise) + " mm; the readings differ by " +
                   fmt(readings_apart) + " mm RMS on this log with the start model)";
  } else {
    reading_note = std::string("re-heat reading ") + sma_tools::reheat_name(start.p.reheat) +
                   (reheat_arg.empty() ? ": the two readings predict this log alike with the start model (" +
                                             fmt(readings_apart) + " mm RMS apart), not compared"
                                       : " (--reheat)");
  }
  start = reading_starts[chosen];
  Problem pb = reading_runs[chosen].pb;
  Eigen::VectorXd x = reading_runs[chosen].x;
  const int status = reading_runs[chosen].status;
  const Eigen::Index lm_iterations = reading_runs[chosen].iterations;
  const std::string stage1_note = reading_runs[chosen].stage1_note;
  notes = reading_runs[chosen].notes;
  notes.push_back(reading_note);
  std::cerr << "fit: " << reading_note << "\n";
  LmFunctor fun{&pb};
  const size_t np = pb.specs.size();
  Model fitted = pb.model_at(x);
  check_model(fitted, "fitted parameters");

  // ---- uncertainty -----------------------------------------------------------------------------
  Eigen::MatrixXd J;
  fun.df(x, J);
  Eigen::VectorXd fres;
  pb.residual_at(x, fres);
  for (size_t i = 0; i < np; ++i) J.col(static_cast<Eigen::Index>(i)) /= pb.dphys(x, i);  // physical units
  std::vector<double> fr(fres.data(), fres.data() + fres.size());
  const Stats fs = stats_of(fr);
  // The engine's covariance (identify.hpp): s^2 (J^T J)^+ by SVD, unresolved directions, and the
  // inflation for a correlated residual.
  const sma_host::Uncertainty unc = sma_host::uncertainty(J, fres);
  const double inflate = unc.inflate;
  const double cond = unc.condition;
  const std::vector<bool>& unresolved = unc.unresolved;
  const Eigen::MatrixXd& corr = unc.corr;
  std::vector<double> sigma(np), value(np), startv(np);
  for (size_t i = 0; i < np; ++i) {
    const Eigen::Index ii = static_cast<Eigen::Index>(i);
    (void)ii;
    sigma[i] = unc.sigma[i];
    const ParamSpec& sp = pb.specs[i];
    value[i] = sp.ref(fitted) ? *sp.ref(fitted) : pb.model_for_run(fitted, x, sp.run).fx.sensor_offset_mm;
    startv[i] = sp.ref(start) ? *sp.ref(start) : start_offset(logs[sp.run]);
  }
  for (size_t i = 0; i < np; ++i) {
    if (unresolved[i])
      notes.push_back(pb.specs[i].name + " = " + fmt(value[i], 6) +
                      " is not determined by this log on its own (only a combination with other parameters is)");
    else if (!(1.96 * sigma[i] * inflate < 0.5 * std::max(std::fabs(value[i]), pb.specs[i].scale)))
      notes.push_back(pb.specs[i].name + " = " + fmt(value[i], 6) + " is poorly determined (95 % interval +-" +
                      fmt(1.96 * sigma[i] * inflate, 3) + ")");
    const double ratio = value[i] / startv[i];
    if (pb.specs[i].log && (ratio > 5.0 || ratio < 0.2))
      notes.push_back(pb.specs[i].name + " moved from " + fmt(startv[i], 4) + " to " + fmt(value[i], 4) +
                      ": check the start values (R, d0, L0, T_amb) and that the log heats AND cools the wire");
  }
  struct Pair {
    std::string a, b;
    double r;
  };
  std::vector<Pair> strong;
  for (size_t i = 0; i < np; ++i)
    for (size_t j = i + 1; j < np; ++j) {
      const double r = corr(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      if (std::isfinite(r) && std::fabs(r) >= 0.9) strong.push_back({pb.specs[i].name, pb.specs[j].name, r});
    }
  std::sort(strong.begin(), strong.end(), [](const Pair& p, const Pair& q) { return std::fabs(p.r) > std::fabs(q.r); });

  if (fitted.p.T_AF > 200.0 || fitted.p.T_AS < fitted.p.T_amb - 20.0)
    notes.push_back("fitted T_AS..T_AF = " + fixed(fitted.p.T_AS, 1) + ".." + fixed(fitted.p.T_AF, 1) +
                    " degC is not a NiTi wire: from V and d alone only V^2 / (R G) is seen, so the "
                    "temperature scale comes from R, d0, L0 (and h): give your wire's values in --params");
  // T_MS is not used by the library's hysteresis (the major cooling branch starts at T_MSi of
  // eq 10); keep it consistent with the check T_MS > T_MF.
  if (fitted.p.T_MS != start.p.T_MS)
    notes.push_back("T_MS set to T_MF + 1 = " + fixed(fitted.p.T_MS, 2) +
                    " to stay > T_MF (T_MS itself is not used by the model)");
  check_model(fitted, "fitted parameters");
  if (!pb.fitted(Row::T_s) || !pb.fitted(Row::T_f))
    notes.push_back("minor-loop band T_s..T_f = " + fixed(fitted.p.T_s, 2) + ".." + fixed(fitted.p.T_f, 2) +
                    " degC (start " + fixed(start.p.T_s, 2) + ".." + fixed(start.p.T_f, 2) +
                    "), T_MSs, T_MSf = " + fixed(fitted.p.T_MSs, 2) + ", " + fixed(fitted.p.T_MSf, 2) +
                    (pb.tie_bands ? " degC: tied to the fitted transformation bands where not fitted themselves"
                                  : " degC: kept at the start's where not fitted themselves"));
  for (const auto& w : sma_host::plausibility_warnings(fitted.p, fitted.fx)) {
    std::cerr << "sma_fit: warning: " << w << "\n";
    notes.push_back("warning: " + w);
  }

  // ---- full-rate traces, validation --------------------------------------------------------------
  Trace trf, trs;
  {
    ReplayOptions o;
    o.eps0 = eps0;
    replay(fitted, log.t, log.v, log.d, o, trf);
    Model st = start;
    replay(st, log.t, log.v, log.d, o, trs);
  }
  std::vector<double> rfull(log.size()), rstart(log.size());
  for (size_t k = 0; k < log.size(); ++k) {
    rfull[k] = trf.d[k] - log.d[k];
    rstart[k] = trs.d[k] - log.d[k];
  }
  const Stats full = stats_of(rfull), st0 = stats_of(rstart);

  // The table of runs: each training run with its own fitted sensor zero, each validation run
  // with a zero fitted alone (the least-squares offset of the fitted model on it, the one thing
  // a new run may change); whole run, heating and cooling halves (the model's dT/dt).
  std::vector<RunRow> table;
  for (size_t r = 0; r < logs.size(); ++r) {
    ReplayOptions o;
    o.eps0 = eps0;
    const Model m = pb.model_for_run(fitted, x, r);
    const Trace tr = sma_host::replay(m, logs[r], o);
    std::vector<double> res(logs[r].size());
    for (size_t k = 0; k < res.size(); ++k) res[k] = logs[r].d[k] - tr.d[k];
    table.push_back({logs[r].name, "training", m.fx.sensor_offset_mm, sma_host::run_errors(res, tr.T)});
  }
  std::vector<Validation> vals;
  std::vector<RigLog> vlogs;
  std::vector<Trace> trvs, trv0s;
  for (const std::string& vp : val_paths) {
    vlogs.push_back(read_rig_log(vp, lro));
    const RigLog& vlog = vlogs.back();
    if (vlog.dropped) std::cerr << dropped_note(vlog) << "\n";
    Validation val;
    val.name = vlog.name;
    val.rows = vlog.size();
    ReplayOptions o;
    o.eps0 = eps0;
    Trace trv = sma_host::replay(fitted, vlog, o);
    std::vector<double> r1(vlog.size()), r2(vlog.size());
    // Tared: the sensor zero of this run from its first samples, as a user zeroes the sensor.
    {
      const size_t nt = std::min<size_t>(vlog.size(), 50);
      double sum = 0;
      for (size_t k = 0; k < nt; ++k) sum += vlog.d[k] - (trv.d[k] - fitted.fx.sensor_offset_mm);
      val.tare_offset = sum / static_cast<double>(nt);
    }
    for (size_t k = 0; k < vlog.size(); ++k) {
      r1[k] = trv.d[k] - vlog.d[k];
      r2[k] = trv.d[k] - fitted.fx.sensor_offset_mm + val.tare_offset - vlog.d[k];
    }
    val.fitted_offset = stats_of(r1);
    val.tared = stats_of(r2);
    // Its own zero, fitted alone: start at its first readings (the initial-state rule then
    // starts the wire where it reads), then the least-squares offset of the whole run.
    Model mv = fitted;
    mv.fx.sensor_offset_mm = start_offset(vlog);
    for (int it = 0; it < 2; ++it) {
      trv = sma_host::replay(mv, vlog, o);
      mv.fx.sensor_offset_mm += sma_host::best_offset(vlog.d, trv.d);
    }
    trv = sma_host::replay(mv, vlog, o);
    std::vector<double> res(vlog.size());
    for (size_t k = 0; k < res.size(); ++k) res[k] = vlog.d[k] - trv.d[k];
    table.push_back({vlog.name, "validation", mv.fx.sensor_offset_mm, sma_host::run_errors(res, trv.T)});
    Model st = start;
    st.fx.sensor_offset_mm = mv.fx.sensor_offset_mm;
    trv0s.push_back(sma_host::replay(st, vlog, o));
    trvs.push_back(trv);
    vals.push_back(val);
  }
  const Validation val = vals.empty() ? Validation() : vals[0];
  const std::string val_path = val_paths.empty() ? "" : val_paths[0];

  // ---- outputs -----------------------------------------------------------------------------------
  make_dirs(out_dir);
  {
    std::ofstream f(out_dir + "/params.json");
    if (!f) throw Error(out_dir + "/params.json: cannot write");
    f << model_to_json(fitted);
  }
  write_curves(out_dir + "/fit_curves.csv", log, trf, trs, "sma_fit: training log " + log.name);
  for (size_t i = 0; i < vlogs.size(); ++i)
    write_curves(out_dir + (i ? "/validate_curves_" + std::to_string(i + 1) + ".csv" : "/validate_curves.csv"), vlogs[i],
                 trvs[i], trv0s[i], "sma_fit: validation log " + vlogs[i].name);

  // Eigen's LevenbergMarquardtSpace::Status.
  std::string status_str;
  switch (status) {
    case 0: status_str = "improper input parameters"; break;
    case 1: status_str = "relative reduction of the sum of squares below ftol"; break;
    case 2: status_str = "relative change of the parameters below xtol"; break;
    case 3: status_str = "sum of squares and parameters converged (ftol and xtol)"; break;
    case 4: status_str = "residual orthogonal to the Jacobian (gtol)"; break;
    case 5: status_str = "stopped: too many model runs (--max-evals)"; break;
    case 6: status_str = "no further reduction of the sum of squares possible (ftol at machine precision)"; break;
    case 7: status_str = "no further improvement of the parameters possible (xtol at machine precision)"; break;
    case 8: status_str = "gradient at machine precision (gtol)"; break;
    default: status_str = "status " + std::to_string(status); break;
  }
  const bool converged = status >= 1 && status <= 8 && status != 5;
  const double z = 1.959964;

  {
    std::ofstream f(out_dir + "/fit.json");
    f << "{\n  \"log\": " << json::quote(log.name) << ",\n  \"rows\": " << log.size()
      << ",\n  \"dropped_rows\": " << log.dropped << ",\n  \"start_params\": " << json::quote(start_name)
      << ",\n  \"residual_samples\": " << pb.rows() << ",\n  \"stride\": " << pb.stride
      << ",\n  \"model_runs\": " << pb.runs << ",\n  \"lm_iterations\": " << lm_iterations
      << ",\n  \"reheat\": {\"reading\": " << json::quote(sma_tools::reheat_name(fitted.p.reheat))
      << ", \"why\": " << json::quote(reading_note) << "}"
      << ",\n  \"lm_status\": " << json::quote(status_str) << ",\n  \"converged\": " << (converged ? "true" : "false")
      << ",\n  \"rms_mm\": " << json::number(full.rms) << ",\n  \"max_mm\": " << json::number(full.max)
      << ",\n  \"rms_mm_start\": " << json::number(st0.rms) << ",\n  \"max_mm_start\": " << json::number(st0.max)
      << ",\n  \"noise_mm\": " << json::number(noise) << ",\n  \"residual_lag1\": " << json::number(fs.lag1)
      << ",\n  \"ci_inflation\": " << json::number(inflate) << ",\n  \"condition\": " << json::number(cond)
      << ",\n  \"parameters\": [";
    for (size_t i = 0; i < np; ++i) {
      f << (i ? "," : "") << "\n    {\"name\": " << json::quote(pb.specs[i].name)
        << ", \"start\": " << json::number(startv[i]) << ", \"value\": " << json::number(value[i])
        << ", \"sigma\": " << json::number(sigma[i]) << ", \"ci95\": " << json::number(z * sigma[i])
        << ", \"ci95_inflated\": " << json::number(z * sigma[i] * inflate) << "}";
    }
    f << "\n  ],\n  \"correlation\": [";
    for (size_t i = 0; i < np; ++i) {
      f << (i ? "," : "") << "\n    [";
      for (size_t j = 0; j < np; ++j)
        f << (j ? ", " : "") << json::number(corr(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)));
      f << "]";
    }
    f << "\n  ],\n  \"strong_correlations\": [";
    for (size_t i = 0; i < strong.size(); ++i)
      f << (i ? ", " : "") << "{\"a\": " << json::quote(strong[i].a) << ", \"b\": " << json::quote(strong[i].b)
        << ", \"r\": " << json::number(strong[i].r) << "}";
    f << "],\n  \"notes\": [";
    for (size_t i = 0; i < notes.size(); ++i) f << (i ? ", " : "") << json::quote(notes[i]);
    f << "]";
    if (!val_path.empty())
      f << ",\n  \"validation\": {\"log\": " << json::quote(val.name) << ", \"rows\": " << val.rows
        << ", \"rms_mm\": " << json::number(val.fitted_offset.rms) << ", \"max_mm\": "
        << json::number(val.fitted_offset.max) << ", \"rms_mm_tared\": " << json::number(val.tared.rms)
        << ", \"max_mm_tared\": " << json::number(val.tared.max) << ", \"tare_offset_mm\": "
        << json::number(val.tare_offset) << "}";
    f << ",\n  \"runs\": [";
    for (size_t i = 0; i < table.size(); ++i) {
      const RunRow& r = table[i];
      f << (i ? "," : "") << "\n    {\"log\": " << json::quote(r.log) << ", \"role\": " << json::quote(r.role)
        << ", \"offset_mm\": " << json::number(r.offset_mm) << ", \"rms_mm\": " << json::number(r.e.all.rms)
        << ", \"max_mm\": " << json::number(r.e.all.max) << ", \"rms_mm_heating\": " << json::number(r.e.heating.rms)
        << ", \"max_mm_heating\": " << json::number(r.e.heating.max) << ", \"rms_mm_cooling\": "
        << json::number(r.e.cooling.rms) << ", \"max_mm_cooling\": " << json::number(r.e.cooling.max) << "}";
    }
    f << "\n  ]\n}\n";
  }
  {
    std::ofstream f(out_dir + "/report.md");
    f << "# Identification report\n\n";
    f << "Training log `" << log.name << "`: " << log.size() << " rows over " << fixed(log.duration(), 1)
      << " s, v_V " << fixed(vlo, 3) << ".." << fixed(vhi, 3) << " V, d_mm span " << fmt(dspan)
      << " mm, noise about " << fmt(noise) << " mm";
    if (log.dropped) f << ", " << log.dropped << " bad rows dropped";
    f << ".\nStart values: " << start_name << ". Method: Levenberg-Marquardt (Eigen) on the displacement "
      << "residual of the library's simulated plant driven by the log's v_V, " << pb.rows()
      << " residual samples (one row in " << pb.stride << "), " << pb.runs << " model runs, "
      << lm_iterations << " iterations of the full fit: " << status_str << (converged ? "." : " (NOT converged).")
      << (stage1_note.empty() ? "" : " Before it, " + stage1_note + ".") << "\n\n";
    f << "## Fit quality\n\n| | RMS error (mm) | max error (mm) |\n|---|---|---|\n";
    f << "| start parameters | " << fmt(st0.rms) << " | " << fmt(st0.max) << " |\n";
    f << "| fitted, training log | " << fmt(full.rms) << " | " << fmt(full.max) << " |\n";
    if (!val_path.empty()) {
      f << "| fitted, validation `" << val.name << "` | " << fmt(val.fitted_offset.rms) << " | "
        << fmt(val.fitted_offset.max) << " |\n";
      f << "| same, sensor tared on its first samples (offset " << fmt(val.tare_offset) << " mm) | "
        << fmt(val.tared.rms) << " | " << fmt(val.tared.max) << " |\n";
    }
    f << "\n## Runs\n\nEach run with its own sensor zero (training runs: fitted with the wire; validation "
      << "runs: fitted alone, the model otherwise unchanged). Heating / cooling: where the model's "
      << "temperature rises / falls.\n\n| log | role | offset (mm) | RMS (mm) | max (mm) | RMS heating | "
      << "max heating | RMS cooling | max cooling |\n|---|---|---|---|---|---|---|---|---|\n";
    for (const RunRow& r : table)
      f << "| `" << r.log << "` | " << r.role << " | " << fmt(r.offset_mm) << " | " << fmt(r.e.all.rms) << " | "
        << fmt(r.e.all.max) << " | " << fmt(r.e.heating.rms) << " | " << fmt(r.e.heating.max) << " | "
        << fmt(r.e.cooling.rms) << " | " << fmt(r.e.cooling.max) << " |\n";
    f << "\n## Parameters\n\n95 % intervals from covariance = s^2 (J^T J)^-1 (s = residual RMS, J the "
      << "Jacobian in physical units). The residual of neighbouring samples is correlated (lag-1 "
      << "autocorrelation " << fixed(fs.lag1, 3) << "), which makes these intervals optimistic: the last "
      << "column widens them by sqrt((1+rho)/(1-rho)) = " << fixed(inflate, 2) << ". Model error (the "
      << "model is not the rig) is not in any of them.\n\n";
    f << "| parameter | start | fitted | +- 95 % | +- 95 % (correlated residual) |\n|---|---|---|---|---|\n";
    for (size_t i = 0; i < np; ++i)
      f << "| " << pb.specs[i].name << " | " << fmt(startv[i], 6) << " | " << fmt(value[i], 6) << " | "
        << fmt(z * sigma[i], 3) << " | " << fmt(z * sigma[i] * inflate, 3) << " |\n";
    f << "\nCondition number of the (column-normalised) Jacobian: " << fmt(cond, 3) << ".\n";
    f << "\n## Parameters that are hard to separate\n\n";
    if (strong.empty()) f << "No pair with |correlation| >= 0.9.\n";
    else {
      f << "Pairs with |correlation| >= 0.9: this log cannot tell them apart well; a change in one is "
        << "largely compensated by the other.\n\n| a | b | correlation |\n|---|---|---|\n";
      for (const auto& p : strong) f << "| " << p.a << " | " << p.b << " | " << fixed(p.r, 4) << " |\n";
    }
    bool any_unres = false;
    for (size_t i = 0; i < np; ++i) any_unres = any_unres || unresolved[i];
    if (any_unres) {
      f << "\nNot identifiable separately (a direction of J^T J with no information; only a "
        << "combination is fixed by the log):";
      for (size_t i = 0; i < np; ++i)
        if (unresolved[i]) f << " " << pb.specs[i].name;
      f << "\n";
    }
    if (!notes.empty()) {
      f << "\n## Notes\n\n";
      for (const auto& n : notes) f << "- " << n << "\n";
    }
    f << "\n## Files\n\n- `params.json`: the fitted model (interfaces.md format)\n- `fit.json`: the numbers of "
      << "this report, with the full correlation matrix\n- `fit_curves.csv`";
    if (!val_path.empty()) f << ", `validate_curves.csv`";
    f << ": measured and fitted displacement, model temperature and fraction (for the plots)\n";
  }

  std::cout << "sma_fit: " << log.name << ": " << np << " parameters, " << pb.runs << " model runs, "
            << status_str << "\n";
  std::cout << "  RMS " << fmt(full.rms) << " mm, max " << fmt(full.max) << " mm (start: RMS "
            << fmt(st0.rms) << ", max " << fmt(st0.max) << ")\n";
  for (size_t i = 0; i < np; ++i)
    std::cout << "  " << pb.specs[i].name << " = " << fmt(value[i], 6) << " +- " << fmt(z * sigma[i], 3)
              << "  (start " << fmt(startv[i], 6) << ")\n";
  for (const auto& p : strong) std::cout << "  correlated: " << p.a << " ~ " << p.b << " r=" << fixed(p.r, 3) << "\n";
  if (!val_path.empty())
    std::cout << "  validation " << val.name << ": RMS " << fmt(val.fitted_offset.rms) << " mm, max "
              << fmt(val.fitted_offset.max) << " mm (tared: RMS " << fmt(val.tared.rms) << ", max "
              << fmt(val.tared.max) << ")\n";
  if (table.size() > 1) {
    std::printf("  %-32s %-10s %9s %9s %9s %9s %9s %9s\n", "run", "role", "RMS mm", "max mm", "RMS heat",
                "max heat", "RMS cool", "max cool");
    for (const RunRow& r : table)
      std::printf("  %-32s %-10s %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f\n", r.log.c_str(), r.role.c_str(), r.e.all.rms,
                  r.e.all.max, r.e.heating.rms, r.e.heating.max, r.e.cooling.rms, r.e.cooling.max);
  }
  for (const auto& n : notes) std::cout << "  note: " << n << "\n";
  std::cout << "  wrote " << out_dir << "/params.json, fit.json, report.md\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return sma_tools::guarded_main("sma_fit", argc, argv, run); }
