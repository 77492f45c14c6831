// sma_metrics LOG.csv --test sine|steps|traj [--period S] [--step S] [--start S]
// Tracking metrics of a closed-loop rig log (needs ref_mm), with the definitions of the
// benchmark and the tests (host/include/sma_host/metrics.hpp): whole-run max and RMS, per
// phase (rise / fall, transitions included), wrong-way excursion, settling, steady-state error,
// and the paper-style partial figures (max_heat_mm, ...); on the measured position. Prints JSON.
// --start drops the log before that time (the command that started the run). traj: any
// reference (a user trajectory), read from the log's ref_mm (reference_metrics: whole run).
#include <iostream>
#include <utility>
#include "sma_host/metrics.hpp"
#include "sma_tools/cli.hpp"
#include "sma_tools/json.hpp"
#include "sma_tools/rig_log.hpp"

namespace {
using sma_tools::Error;
using sma_tools::json::number;

int run(int argc, char** argv) {
  sma_tools::Args args(argc, argv);
  std::string path, test;
  double period = 50.0, step = 25.0, start = 0.0;
  while (!args.empty()) {
    const std::string a = args.next();
    if (a == "--test") test = args.value(a);
    else if (a == "--period") period = args.number(a);
    else if (a == "--step") step = args.number(a);
    else if (a == "--start") start = args.number(a);
    else if (a == "-h" || a == "--help") {
      std::cout << "usage: sma_metrics LOG.csv --test sine|steps|traj [--period S] [--step S] [--start S]\n";
      return 0;
    } else if (!a.empty() && a[0] == '-') throw Error("unknown option " + a);
    else path = a;
  }
  if (path.empty() || (test != "sine" && test != "steps" && test != "traj"))
    throw Error("usage: sma_metrics LOG.csv --test sine|steps|traj");
  if (!(period > 0 && step > 0)) throw Error("--period and --step must be > 0");
  const sma_tools::RigLog log = sma_tools::read_rig_log(path);
  if (!log.has_ref()) throw Error(path + ": no ref_mm column: metrics need the reference");
  std::vector<sma_host::Sample> run;
  for (size_t k = 0; k < log.size(); ++k)
    if (log.t[k] >= start)
      run.push_back({log.t[k] - start, log.ref[k], log.d[k], log.d[k], log.v[k], 0.0, 0.0});
  if (run.size() < 2) throw Error(path + ": no samples after --start");
  const sma_host::Metrics m = test == "sine"    ? sma_host::sine_metrics(run, period, true)
                             : test == "steps" ? sma_host::step_metrics(run, step, true)
                                               : sma_host::reference_metrics(run, 0.0, true);
  const std::pair<const char*, double> fields[] = {
      {"max_mm", m.max_mm},           {"rms_mm", m.rms_mm},
      {"max_rise_mm", m.max_rise_mm}, {"rms_rise_mm", m.rms_rise_mm},
      {"max_fall_mm", m.max_fall_mm}, {"rms_fall_mm", m.rms_fall_mm},
      {"wrong_way_mm", m.wrong_way_mm}, {"wrong_way_before_mm", m.wrong_way_before_mm},
      {"settle_s", m.settle_s},
      {"settle_max_s", m.settle_max_s}, {"sse_mm", m.sse_mm},
      {"max_heat_mm", m.max_heat_mm}, {"rms_heat_mm", m.rms_heat_mm},
      {"max_cool_mm", m.max_cool_mm}, {"overshoot_pct", m.overshoot_pct}};
  std::cout << "{";
  for (size_t i = 0; i < sizeof fields / sizeof fields[0]; ++i)
    std::cout << (i ? ", " : "") << "\"" << fields[i].first << "\": " << number(fields[i].second);
  std::cout << "}\n";
  return 0;
}
}  // namespace

int main(int argc, char** argv) { return sma_tools::guarded_main("sma_metrics", argc, argv, run); }
