// sma_discrepancy LOG.csv [--params PARAMS.json] --out DIR [--max-effects N] [--min-gain F]
//                 [--block-s S] [--no-plots]
// The discrepancy workflow of interfaces.md: simulate the log with the model, show where it
// disagrees, name the missing effect(s), add them with fitted parameters, refit, repeat.
// Writes DIR/report.json (the contract), DIR/report.md, DIR/params.json (the corrected model),
// DIR/trace.csv and DIR/analysis.json (for the plots), and DIR/*.png through
// plot_discrepancy.py. Exit code: 0 done, 1 bad input (message names file, line, problem).
#include <sys/stat.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include "sma_host/discrepancy.hpp"
#include "sma_host/progress.hpp"
#include "sma_host/residual_analysis.hpp"
#include "sma_host/residuals.hpp"
#include "sma_tools/cli.hpp"
#include "sma_tools/json.hpp"
#include "sma_tools/params_json.hpp"
#include "sma_tools/rig_log.hpp"

namespace {
using sma_tools::Error;
using sma_tools::json::number;
using sma_tools::json::quote;

const char* kUsage =
    "usage: sma_discrepancy LOG.csv [LOG2.csv ...] [--params PARAMS.json] --out DIR [--max-effects N]\n"
    "                       [--min-gain F] [--block-s S] [--refit-base all|h,T_AS,...]\n"
    "                       [--validate V.csv ...] [--reheat return_point|new_loop] [--no-plots]\n"
    "  several LOGs   one wire, a sensor zero per run (one sample rate and column set, else refused)\n"
    "  --validate     runs predicted by the corrected model (zero fitted alone): table in report\n"
    "  --refit-base   base parameters refitted jointly with every candidate effect (default: none,\n"
    "                 the base model stays as given); use it when the base was fitted on a log where\n"
    "                 it could absorb the missing effect; `all`: every parameter tools/sma fit\n"
    "                 identifies (h, T_AS, T_AF, T_MF, q, e, T_MSs, T_MSf, g, j and T_ii of each loop)\n"
    "  --reheat       keep this reading of a re-heat short of transformation (default: the one of\n"
    "                 --params, replaced by the other when the log clearly prefers it: report.json\n"
    "                 \"reheat\" says which and why)\n";

std::string regimes_json(const std::vector<sma_host::RegimeRms>& r) {
  std::string s = "{";
  for (size_t i = 0; i < r.size(); ++i)
    s += (i ? ", " : "") + quote(r[i].regime) + ": {\"rms_mm\": " + number(r[i].rms_mm) +
         ", \"share\": " + number(r[i].share) + "}";
  return s + "}";
}

std::string list_json(const std::vector<double>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + number(v[i]);
  return s + "]";
}

std::string params_json(const sma_host::FittedEffect& e, bool ci) {
  std::string s = "{";
  for (int i = 0; i < e.spec->n; ++i)
    s += (i ? ", " : "") + quote(e.spec->param[i]) + ": " + number(ci ? e.ci95[i] : e.value[i]);
  return s + "}";
}

// Four significant digits for people (the JSON keeps full precision).
std::string num(double x) {
  if (std::isnan(x)) return "-";
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", x);
  return b;
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  if (!f || !(f << text)) throw Error(path + ": cannot write");
}

int run(int argc, char** argv) {
  sma_tools::Args args(argc, argv);
  std::string log_path, params_path, out;
  std::vector<std::string> log_paths, val_paths;
  sma_host::Options opt;
  bool plots = true;
  std::string reheat_arg;   // --reheat: the reading fixed, not chosen from the log
  bool refit_all = false;  // --refit-base all: resolved once the model's loop count is known
  while (!args.empty()) {
    const std::string a = args.next();
    if (a == "--params") params_path = args.value(a);
    else if (a == "--out") out = args.value(a);
    else if (a == "--max-effects") opt.max_effects = static_cast<int>(args.number(a));
    else if (a == "--min-gain") opt.min_gain = args.number(a);
    else if (a == "--block-s") opt.block_s = args.number(a);
    else if (a == "--no-plots") plots = false;
    else if (a == "--reheat") {
      reheat_arg = args.value(a);
      sma_tools::reheat_option(reheat_arg);
      opt.choose_reading = false;
    }
    else if (a == "--validate") {
      val_paths.push_back(args.value(a));
      while (!args.empty() && !args.peek().empty() && args.peek()[0] != '-') val_paths.push_back(args.next());
    }
    else if (a == "--refit-base") {
      for (const std::string& n : sma_tools::split_names(args.value(a))) {
        if (n == "all") {
          refit_all = true;
          continue;
        }
        const sma_host::BaseSpec* b = sma_host::find_base(n);
        if (!b) {
          std::string known = "all";
          for (const sma_host::BaseSpec& k : sma_host::refittable_base()) known += ", " + k.name;
          throw Error("--refit-base: unknown parameter '" + n + "' (" + known + ")");
        }
        opt.refit_base.push_back(b);
      }
    }
    else if (a == "-h" || a == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (!a.empty() && a[0] == '-') throw Error("unknown option " + a + "\n" + kUsage);
    else log_paths.push_back(a);
  }
  for (const std::string& lp : log_paths) log_path += (log_path.empty() ? "" : "+") + lp;
  if (log_path.empty() || out.empty()) throw Error(std::string("missing LOG.csv or --out DIR\n") + kUsage);
  if (!(opt.max_effects >= 0 && opt.max_effects <= 7)) throw Error("--max-effects must be 0..7");
  if (!(opt.min_gain > 0 && opt.min_gain < 1)) throw Error("--min-gain must be in (0, 1)");
  if (!(opt.block_s >= 1)) throw Error("--block-s must be >= 1 s");

  std::vector<sma_host::RigLog> files;
  for (const std::string& lp : log_paths) {
    files.push_back(sma_tools::read_rig_log(lp));
    const std::string note = sma_tools::dropped_note(files.back());
    if (!note.empty()) std::cerr << note << "\n";
  }
  std::vector<const sma_host::RigLog*> ptrs;
  for (const sma_host::RigLog& f : files) ptrs.push_back(&f);
  sma_host::check_compatible(ptrs);
  // Several runs of one wire: one log of several runs, each with its own sensor zero
  // (identify.hpp: concatenate, replay).
  const sma_host::RigLog file = files.size() == 1 ? files[0] : sma_host::concatenate(ptrs);
  sma_tools::Model model;
  if (!params_path.empty()) model = sma_tools::read_model(params_path);
  if (!reheat_arg.empty())
    model.p.reheat = sma_tools::reheat_option(reheat_arg);
  if (refit_all)
    for (const sma_host::BaseSpec* b : sma_host::all_base(model.p))
      if (std::find(opt.refit_base.begin(), opt.refit_base.end(), b) == opt.refit_base.end()) opt.refit_base.push_back(b);
  // A log must be long enough for held-out blocks and must excite the wire.
  // Refitting the cooling parameters needs a run that cools the wire back (identify.hpp).
  {
    std::string asked, lacking;
    for (const sma_host::BaseSpec* b : opt.refit_base) {
      if (sma_host::cooling_param(b->key)) asked += (asked.empty() ? "" : ", ") + b->name;
    }
    size_t cooling = 0;
    for (const sma_host::RigLog& fl : files) {
      if (sma_host::cools_in_log(fl)) ++cooling;
      else lacking += (lacking.empty() ? "" : ", ") + fl.name;
    }
    if (!asked.empty() && cooling == 0)
      throw Error(lacking + ": the wire is never cooled back through its transformation (the measured position never "
                  "falls from its peak by 20 % of the stroke), so --refit-base cannot refit " + asked +
                  " on it: give a run that heats AND cools, or leave them out of --refit-base");
  }
  for (const sma_host::RigLog& fl : files) {
  if (fl.duration() < 4 * opt.block_s)
    throw Error(fl.name + ": " + number(fl.duration()) + " s of log; at least " + number(4 * opt.block_s) +
                " s are needed (4 blocks of --block-s)");
  double vmin = fl.v[0], vmax = fl.v[0];
  for (double v : fl.v) {
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  if (vmax - vmin < 0.05) throw Error(fl.name + ": the voltage never changes (no excitation to learn from)");
  }

  const sma_host::RigLog& log = file;
  std::cerr << "discrepancy: " << log.size() << " samples, " << number(file.duration()) << " s\n";
  sma_host::RoundsProgress rounds("discrepancy: candidate effects fitted",
                                 double(sma_host::vocabulary().size() - sma_host::present_effects(model.fx).size()));
  const sma_host::Diagnosis d =
      sma_host::diagnose_reading(model.p, log, opt, [&rounds](const char*) { rounds.tick(); }, model.fx);
  rounds.finish();
  model.p.reheat = d.params.reheat;  // the nominal model of the report runs the chosen reading
  std::cerr << "discrepancy: re-heat reading: " << d.reading_why << "\n";

  // What a user must know before trusting the named effects.
  std::vector<std::string> warnings;
  for (const sma_host::FittedEffect& e : d.effects)
    for (int i = 0; i < e.spec->n; ++i)
      if (e.value[i] <= e.spec->lo[i] + 1e-9 || e.value[i] >= e.spec->hi[i] - 1e-9)
        warnings.push_back(std::string(e.spec->name) + "." + e.spec->param[i] + " sits at its bound " +
                           num(e.value[i]) + ": it stands in for a larger model error, not a measurement of it");
  if (d.rms_final > 3 * d.noise_mm)
    warnings.push_back("the gap left (" + num(d.rms_final) + " mm) is " + num(d.rms_final / d.noise_mm) +
                       "x the noise: the vocabulary does not explain this log; fit the base model first "
                       "(tools/sma fit) and run the discrepancy workflow on the fitted params");
  double dmin = log.d[0], dmax = log.d[0];
  for (double x : log.d) {
    dmin = std::min(dmin, x);
    dmax = std::max(dmax, x);
  }
  if (dmin < -5 * d.noise_mm - 0.01 * model.p.g || dmax > model.p.g * 1.05)
    warnings.push_back("positions from " + num(dmin) + " to " + num(dmax) + " mm lie outside the model's stroke 0.." +
                       num(model.p.g) + " mm: a sensor offset or a wrong g");
  for (const std::string& w : warnings) std::cerr << "warning: " << w << "\n";

  mkdir(out.c_str(), 0755);
  const sma::Effects final_fx = sma_host::effects_of(d.effects);
  const sma_host::Trace nominal = sma_host::trace(model.p, model.fx, log);
  const sma_host::Trace corrected = sma_host::trace(d.params, final_fx, log);
  // What is left after the last round, against the model's states (residual_analysis.hpp).
  std::vector<double> left(log.size());
  for (size_t k = 0; k < log.size(); ++k) left[k] = log.d[k] - corrected.d[k];
  const sma_host::ResidualAnalysis ra = sma_host::analyse_residual(log, corrected, left);
  // No candidate credible: the gap stays well above the noise, and the last round added nothing
  // (every candidate too small a gain, or at a bound).
  const bool unexplained = d.rms_final > 3 * d.noise_mm;
  const bool none_credible = unexplained && !d.rejected.empty();

  // The table of runs: each training run (its own sensor zero, see identify.hpp) and each
  // --validate run predicted by the final model with its zero fitted alone; whole run, heating
  // and cooling halves (the model's dT/dt).
  struct RunRow {
    std::string log, role;
    double offset_mm;
    sma_host::RunErrors e;
  };
  std::vector<RunRow> runs;
  {
    std::vector<size_t> bounds = {0};
    for (size_t b : log.run_starts) bounds.push_back(b);
    bounds.push_back(log.size());
    for (size_t r = 0; r + 1 < bounds.size(); ++r) {
      std::vector<double> res(left.begin() + static_cast<long>(bounds[r]), left.begin() + static_cast<long>(bounds[r + 1]));
      std::vector<double> T(corrected.T.begin() + static_cast<long>(bounds[r]),
                            corrected.T.begin() + static_cast<long>(bounds[r + 1]));
      double off = final_fx.sensor_offset_mm;
      if (r > 0) {  // the zero the replay fitted to this run (it starts at rest, fraction 0)
        sma_host::ReplayOptions ro;
        ro.eps0 = 0.0;
        off += sma_host::best_offset(files[r].d, sma_host::replay(sma_host::Model{d.params, final_fx}, files[r], ro).d);
      }
      runs.push_back({files[r].name, "training", off, sma_host::run_errors(res, T)});
    }
  }
  for (const std::string& vp : val_paths) {
    const sma_host::RigLog vlog = sma_tools::read_rig_log(vp);
    sma_host::Model mv{d.params, final_fx};
    sma_host::Trace tv;
    for (int it = 0; it < 3; ++it) {
      tv = sma_host::replay(mv, vlog);
      mv.fx.sensor_offset_mm += sma_host::best_offset(vlog.d, tv.d);
    }
    tv = sma_host::replay(mv, vlog);
    std::vector<double> res(vlog.size());
    for (size_t k = 0; k < res.size(); ++k) res[k] = vlog.d[k] - tv.d[k];
    runs.push_back({vlog.name, "validation", mv.fx.sensor_offset_mm, sma_host::run_errors(res, tv.T)});
  }

  // report.json: the contract's keys first, then what the human report and plots use.
  std::ostringstream j;
  j << "{\n  \"rms_mm_nominal\": " << number(d.rms_nominal) << ",\n  \"rms_mm_final\": " << number(d.rms_final)
    << ",\n  \"effects\": [";
  for (size_t i = 0; i < d.steps.size(); ++i) {
    const sma_host::Step& s = d.steps[i];
    sma_host::FittedEffect final_e = s.added;  // final (jointly refitted) values
    for (const sma_host::FittedEffect& e : d.effects)
      if (e.spec == s.added.spec) final_e = e;
    j << (i ? "," : "") << "\n    {\"name\": " << quote(s.added.spec->name) << ", \"params\": " << params_json(final_e, false)
      << ", \"ci95\": " << params_json(final_e, true) << ", \"rms_mm_before\": " << number(s.rms_before)
      << ", \"rms_mm_after\": " << number(s.rms_after) << ", \"lookalikes\": [";
    for (size_t k = 0; k < s.lookalikes.size(); ++k) j << (k ? ", " : "") << quote(s.lookalikes[k]);
    j << "]}";
  }
  // The effects of the given params (not added by this run), refined on this log: their values
  // and intervals tell whether the log confirms them.
  j << (d.steps.empty() ? "" : "\n  ") << "],\n  \"given_effects\": [";
  {
    bool first = true;
    for (const sma_host::FittedEffect& e : d.effects) {
      bool added = false;
      for (const sma_host::Step& s : d.steps) added = added || s.added.spec == e.spec;
      if (added) continue;
      j << (first ? "" : ",") << "\n    {\"name\": " << quote(e.spec->name) << ", \"params\": " << params_json(e, false)
        << ", \"ci95\": " << params_json(e, true) << ", \"at_bound\": " << (sma_host::at_bound(e) ? "true" : "false") << "}";
      first = false;
    }
  }
  j << "],\n  \"noise_mm\": " << number(d.noise_mm) << ",\n  \"log\": " << quote(log_path)
    << ",\n  \"samples\": " << log.size() << ",\n  \"dropped_rows\": " << file.dropped << ",\n  \"candidates\": [";
  for (size_t i = 0; i < d.steps.size(); ++i) {
    j << (i ? "," : "") << "\n    [";
    for (size_t k = 0; k < d.steps[i].candidates.size(); ++k)
      j << (k ? ", " : "") << "{\"name\": " << quote(d.steps[i].candidates[k].name)
        << ", \"rms_mm_heldout\": " << number(d.steps[i].candidates[k].rms_test) << "}";
    j << "]";
  }
  j << "\n  ],\n  \"rms_mm_heldout_final\": " << number(d.rms_test_final) << ",\n  \"rejected\": [";
  for (size_t k = 0; k < d.rejected.size(); ++k)
    j << (k ? ", " : "") << "{\"name\": " << quote(d.rejected[k].name)
      << ", \"rms_mm_heldout\": " << number(d.rejected[k].rms_test) << "}";
  j << "],\n  \"pruned\": [";
  for (size_t k = 0; k < d.pruned.size(); ++k) j << (k ? ", " : "") << quote(d.pruned[k]);
  j << "],\n  \"residual_analysis\": {\"rms_mm\": " << number(ra.rms_mm) << ", \"follows\": " << quote(ra.follows)
    << ", \"no_credible_candidate\": " << (none_credible ? "true" : "false") << ", \"at_bound\": [";
  for (size_t k = 0; k < d.at_bound.size(); ++k) j << (k ? ", " : "") << quote(d.at_bound[k]);
  j << "], \"not_credible\": [";
  for (size_t k = 0; k < d.not_credible.size(); ++k) j << (k ? ", " : "") << quote(d.not_credible[k]);
  j << "], \"states\": [";
  for (size_t k = 0; k < ra.states.size(); ++k) {
    const sma_host::StateFit& sf = ra.states[k];
    j << (k ? "," : "") << "\n      {\"state\": " << quote(sf.state) << ", \"unit\": " << quote(sf.unit)
      << ", \"r2_linear\": " << number(sf.r2_linear) << ", \"r2_binned\": " << number(sf.r2_binned)
      << ", \"slope_mm_per_unit\": " << number(sf.slope) << ", \"bin_state\": " << list_json(sf.bin_x)
      << ", \"bin_mean_mm\": " << list_json(sf.bin_mean) << "}";
  }
  j << "]},\n  \"runs\": [";
  for (size_t i = 0; i < runs.size(); ++i) {
    const RunRow& r = runs[i];
    j << (i ? "," : "") << "\n    {\"log\": " << quote(r.log) << ", \"role\": " << quote(r.role)
      << ", \"offset_mm\": " << number(r.offset_mm) << ", \"rms_mm\": " << number(r.e.all.rms)
      << ", \"max_mm\": " << number(r.e.all.max) << ", \"rms_mm_heating\": " << number(r.e.heating.rms)
      << ", \"max_mm_heating\": " << number(r.e.heating.max) << ", \"rms_mm_cooling\": " << number(r.e.cooling.rms)
      << ", \"max_mm_cooling\": " << number(r.e.cooling.max) << "}";
  }
  j << "],\n  \"reheat\": {\"reading\": " << quote(sma_host::reheat_name(d.params.reheat))
    << ", \"rms_mm_heldout\": {\"return_point\": " << number(d.reading_rms_test[0])
    << ", \"new_loop\": " << number(d.reading_rms_test[1]) << "}, \"why\": " << quote(d.reading_why) << "}";
  j << ",\n  \"warnings\": [";
  for (size_t i = 0; i < warnings.size(); ++i) j << (i ? ", " : "") << quote(warnings[i]);
  j << "]\n}\n";
  write_file(out + "/report.json", j.str());

  sma_tools::Model corrected_model = model;
  corrected_model.p = d.params;
  corrected_model.fx = final_fx;
  write_file(out + "/params.json", sma_tools::model_to_json(corrected_model));

  // Residual analysis before/after and the time series for the plots.
  std::vector<double> r0, r1;
  for (size_t k = 0; k < log.size(); ++k) {
    r0.push_back(log.d[k] - nominal.d[k]);
    r1.push_back(log.d[k] - corrected.d[k]);
  }
  const double dt = file.duration() / static_cast<double>(log.size() - 1);
  const int lag10 = static_cast<int>(10.0 / dt), lag2 = static_cast<int>(2.0 / dt);
  const int stride = std::max(1, lag10 / 100);
  auto thin = [stride](const std::vector<double>& v) {
    std::vector<double> o;
    for (size_t i = 0; i < v.size(); i += static_cast<size_t>(stride)) o.push_back(v[i]);
    return o;
  };
  const std::vector<sma_host::RegimeRms> reg0 = sma_host::residual_by_regime(log, nominal),
                                         reg1 = sma_host::residual_by_regime(log, corrected);
  std::ostringstream a;
  a << "{\n  \"dt_s\": " << number(dt * stride) << ",\n  \"regimes_before\": " << regimes_json(reg0)
    << ",\n  \"regimes_after\": " << regimes_json(reg1)
    << ",\n  \"autocorr_before\": " << list_json(thin(sma_host::cross_correlation(r0, r0, lag10)))
    << ",\n  \"autocorr_after\": " << list_json(thin(sma_host::cross_correlation(r1, r1, lag10)))
    << ",\n  \"xcorr_v_min_lag_s\": " << number(-lag2 * dt)
    << ",\n  \"xcorr_v_before\": " << list_json(thin(sma_host::cross_correlation(r0, log.v, lag10, -lag2)))
    << ",\n  \"xcorr_v_after\": " << list_json(thin(sma_host::cross_correlation(r1, log.v, lag10, -lag2))) << "\n}\n";
  write_file(out + "/analysis.json", a.str());

  std::ostringstream tr;
  tr << "t_s,v_V,d_mm,d_nominal_mm,d_corrected_mm,T_nominal_C,eps_nominal,T_corrected_C,eps_corrected\n";
  for (size_t k = 0; k < log.size(); ++k)
    tr << number(log.t[k]) << "," << number(log.v[k]) << "," << number(log.d[k]) << "," << number(nominal.d[k]) << ","
       << number(corrected.d[k]) << "," << number(nominal.T[k]) << "," << number(nominal.eps[k]) << ","
       << number(corrected.T[k]) << "," << number(corrected.eps[k]) << "\n";
  write_file(out + "/trace.csv", tr.str());

  // The human report.
  std::ostringstream md;
  md << "# Discrepancy report: " << log_path << "\n\n" << log.size() << " samples over " << num(file.duration())
     << " s";
  if (file.dropped) md << " (" << file.dropped << " bad rows dropped)";
  md << "; sensor noise estimated at " << num(d.noise_mm * 1000) << " um RMS.\n\n"
     << "| | RMS gap, mm |\n|---|---|\n| " << (params_path.empty() ? "paper's model" : "starting model (" + params_path + ")")
     << " | " << num(d.rms_nominal) << " |\n| with the effects below | "
     << num(d.rms_final) << " |\n\n";
  if (!d.rejected.empty())
    md << "Stopped: the best remaining candidate, `" << d.rejected[0].name << "`, would change the held-out RMS from "
       << num(d.rms_test_final) << " to " << num(d.rejected[0].rms_test) << " mm, less than the " << num(100 * opt.min_gain)
       << " % needed (the noise is " << num(d.noise_mm) << " mm).\n\n";
  for (const std::string& n : d.pruned)
    md << "Dropped at the end: `" << n << "` (added in an early round, its final value is within its 95 % "
          "interval of no effect: it stood in for an effect added later).\n\n";
  if (d.steps.empty()) {
    md << "No effect of the vocabulary shrinks the gap on held-out parts of this log by " << num(100 * opt.min_gain)
       << " % or more: nothing was added.\n\n";
  } else {
    md << "| # | effect | parameters (95 % interval) | RMS before, mm | RMS after, mm | not separable here from |\n"
          "|---|---|---|---|---|---|\n";
    for (size_t i = 0; i < d.steps.size(); ++i) {
      const sma_host::Step& s = d.steps[i];
      sma_host::FittedEffect e = s.added;
      for (const sma_host::FittedEffect& f : d.effects)
        if (f.spec == s.added.spec) e = f;
      std::string ps, look;
      for (int k = 0; k < e.spec->n; ++k)
        ps += (k ? ", " : "") + std::string(e.spec->param[k]) + " = " + num(e.value[k]) + " ± " + num(e.ci95[k]);
      for (const std::string& l : s.lookalikes) look += (look.empty() ? "" : ", ") + l;
      md << "| " << i + 1 << " | `" << e.spec->name << "` | " << ps << " | " << num(s.rms_before) << " | "
         << num(s.rms_after) << " | " << (look.empty() ? "-" : look) << " |\n";
    }
    md << "\n";
    for (const sma_host::Step& s : d.steps)
      if (!s.lookalikes.empty())
        md << "- `" << s.added.spec->name << "` fits this log about as well as " << s.lookalikes.size()
           << " other effect(s); to separate them record " << s.added.spec->separate << ".\n";
  }
  {
    std::string given;
    for (const sma_host::FittedEffect& e : d.effects) {
      bool added = false;
      for (const sma_host::Step& s : d.steps) added = added || s.added.spec == e.spec;
      if (added) continue;
      given += "| `" + std::string(e.spec->name) + "` | ";
      for (int k = 0; k < e.spec->n; ++k)
        given += (k ? ", " : "") + std::string(e.spec->param[k]) + " = " + num(e.value[k]) + " ± " + num(e.ci95[k]);
      given += sma_host::at_bound(e) ? " (at a bound: not confirmed by this log) |\n" : " |\n";
    }
    if (!given.empty())
      md << "Effects of the given params, refined on this log:\n\n| effect | parameters (95 % interval) |\n|---|---|\n"
         << given << "\n";
  }
  if (!opt.refit_base.empty()) {
    md << "Base parameters refitted jointly with the effects:\n\n| parameter | given | refitted (95 % interval) |\n|---|---|---|\n";
    for (size_t i = 0; i < opt.refit_base.size(); ++i) {
      const sma_host::BaseSpec* b = opt.refit_base[i];
      md << "| " << b->name << " | " << num(b->get(model.p)) << " | " << num(b->get(d.params)) << " ± "
         << num(i < d.base_ci95.size() ? d.base_ci95[i] : 0.0) << " |\n";
    }
    md << "\n";
  }
  for (const std::string& w : warnings) md << "\n**Warning:** " << w << ".\n";
  md << "\n**Re-heat reading** (loop memory, a re-heat short of transformation): " << d.reading_why << ".\n";
  md << "\n## Runs (corrected model)\n\nTraining runs with their own sensor zero; validation runs predicted with "
        "their zero fitted alone. Heating / cooling: where the model's temperature rises / falls.\n\n"
        "| log | role | offset, mm | RMS, mm | max, mm | RMS heating | max heating | RMS cooling | max cooling |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  for (const RunRow& r : runs)
    md << "| `" << r.log << "` | " << r.role << " | " << num(r.offset_mm) << " | " << num(r.e.all.rms) << " | "
       << num(r.e.all.max) << " | " << num(r.e.heating.rms) << " | " << num(r.e.heating.max) << " | "
       << num(r.e.cooling.rms) << " | " << num(r.e.cooling.max) << " |\n";
  md << "\n## What the residual follows\n\n";
  if (none_credible)
    md << "**The vocabulary does not explain this log**: " << (d.steps.empty() ? "" : "after the effects above, ")
       << "the gap left (" << num(d.rms_final) << " mm) is " << num(d.rms_final / d.noise_mm)
       << "x the noise, no further candidate is credible, and "
       << (!d.not_credible.empty()
               ? std::string("the candidates that would shrink it are stand-ins (their value differs between the "
                             "halves of the log, or they make a held-out part worse: not added)")
               : d.at_bound.empty() ? std::string("no candidate shrinks it enough")
                                    : "the candidates that would shrink it end at a bound of their range (not added)")
       << ". The model lacks something; the residual against the model's states shows where:\n\n";
  else
    md << "The residual left after the last round (RMS " << num(ra.rms_mm) << " mm) against the model's states:\n\n";
  md << "| state | R^2 (binned means) | R^2 (straight line) | slope, mm per unit |\n|---|---|---|---|\n";
  for (const sma_host::StateFit& sf : ra.states)
    md << "| " << sf.state << " (" << sf.unit << ") | " << num(sf.r2_binned) << " | " << num(sf.r2_linear) << " | "
       << num(sf.slope) << " |\n";
  md << "\n" << (ra.follows.empty() ? std::string("The residual follows none of these states clearly (best R^2 < 0.3).")
                                    : "The residual follows **" + ra.follows + "** most (plot: `residual_states.png`).")
     << "\n";
  if (!d.at_bound.empty()) {
    md << "\nNot added, at a bound of their range (stand-ins, not measurements):";
    for (const std::string& n : d.at_bound) md << " `" << n << "`";
    md << ".\n";
  }
  if (!d.not_credible.empty()) {
    md << "\nNot added, stand-ins for a difference of the base model (one value does not fit the whole log):\n\n";
    for (const std::string& n : d.not_credible) md << "- `" << n.substr(0, n.find(':')) << "`" << n.substr(n.find(':')) << "\n";
  }
  md << "\n## Where the gap lives (residual RMS, mm)\n\n| regime | share of log | paper's model | corrected |\n|---|---|---|---|\n";
  for (size_t i = 0; i < reg0.size(); ++i)
    md << "| " << reg0[i].regime << " | " << num(100 * reg0[i].share) << " % | " << num(reg0[i].rms_mm) << " | "
       << num(reg1[i].rms_mm) << " |\n";
  md << "\nPlots: `fit.png` (measured, paper's model, corrected), `residuals.png` (before/after, with their "
        "autocorrelation and cross-correlation with the voltage), `loops.png` (displacement against the model's "
        "temperature). Data: `trace.csv`, `analysis.json`; corrected model: `params.json`.\n";
  write_file(out + "/report.md", md.str());

  if (plots) {
    const std::string cmd = "python3 \"" + std::string(SMA_DISCREPANCY_PLOT) + "\" \"" + out + "\"";
    if (std::system(cmd.c_str()) != 0) std::cerr << "discrepancy: plotting failed (the reports are written)\n";
  }
  if (runs.size() > 1) {
    std::printf("%-32s %-10s %9s %9s %9s %9s %9s %9s\n", "run", "role", "RMS mm", "max mm", "RMS heat", "max heat",
                "RMS cool", "max cool");
    for (const RunRow& r : runs)
      std::printf("%-32s %-10s %9.4f %9.4f %9.4f %9.4f %9.4f %9.4f\n", r.log.c_str(), r.role.c_str(), r.e.all.rms,
                  r.e.all.max, r.e.heating.rms, r.e.heating.max, r.e.cooling.rms, r.e.cooling.max);
  }
  if (!ra.follows.empty() && unexplained) std::cout << "the gap left follows the model's " << ra.follows << "\n";
  std::cout << "gap " << number(d.rms_nominal) << " mm -> " << number(d.rms_final) << " mm;";
  for (const sma_host::FittedEffect& e : d.effects) std::cout << " " << e.spec->name;
  if (d.effects.empty()) std::cout << " nothing added";
  std::cout << "\nwrote " << out << "/report.json, report.md, params.json\n";
  return 0;
}
}  // namespace

int main(int argc, char** argv) { return sma_tools::guarded_main("sma discrepancy", argc, argv, run); }
