// Tracking when the model on the board is not the wire: (a) a fitted model that is off (T_AS
// and T_AF shifted, h or g scaled, or plant B as the wire), (b) a wire with latent heat and
// models of it from none to exact, (c) the end-to-end flow's wire (tools/vrig/e2e_flow.py WIRE:
// a hidden non-linear convection) with the model `sma fit` leaves without that effect. Rig-like, float (the firmware's scalar), default settings
// of every controller (console::default_gains, PreviewConfig()), true position, whole run; inverse
// + PID with the known future ("lead") at the board's leads (sma::lead_for: 5.25 s on the sine,
// 10 s on the multi-step) and the firmware's inverse + PID gains. The
// preview also in Q16.16 (the Uno's scalar) on the exact model and the wrong-h wires: its
// heat-loss observer (heat_gain.hpp) against float's.
// The steps' figures that matter here: SSE (zero steady-state error with a model that is not
// the plant), RMS against PID alone, and the up/down-step overshoot within 10 s of a step.
// Prints a Markdown table and writes JSON.
//
//   bench_tracking_model_error [--json FILE]
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include "sma/console.hpp"
#include "sma/fixed.hpp"
#include "sma_host/e2e_wire.hpp"
#include "sma_host/metrics.hpp"
#include "sma_host/plant_b_loop.hpp"
#include "sma_host/progress.hpp"

using sma_host::Metrics;
using sma_host::RunSetup;

namespace {
struct Case {
  std::string name;
  sma::Params model;      // what the board believes
  sma::Effects plant_fx;  // what the wire does (library plant)
  sma::Effects model_fx;
  bool plant_b = false;   // the wire is plant B (literal re-heat reading)
  sma::Params plant = sma::Params();  // the wire's parameters (library plant)
};

struct Row {
  std::string kase, test, controller;
  Metrics m;
  double overshoot_mm;
  const char* scalar;
};

template <class T = float>
std::vector<sma_host::Sample> run(const Case& c, const RunSetup& s) {
  return c.plant_b ? sma_host::plant_b::run_closed_loop_b<T>(s) : sma_host::run_closed_loop<T>(s);
}

std::vector<Case> cases() {
  std::vector<Case> out;
  const sma::Params p;
  out.push_back({"exact model", p, {}, {}, false});
  sma::Params m = p;
  m.T_AS += 2.0;
  m.T_AF += 2.0;
  out.push_back({"model T_AS, T_AF +2 K", m, {}, {}, false});
  m = p;
  m.T_AS -= 2.0;
  m.T_AF -= 2.0;
  out.push_back({"model T_AS, T_AF -2 K", m, {}, {}, false});
  m = p;
  m.h *= 0.9;
  out.push_back({"model h -10 %", m, {}, {}, false});
  m = p;
  m.h *= 1.1;
  out.push_back({"model h +10 %", m, {}, {}, false});
  m = p;
  m.g *= 1.03;
  out.push_back({"model g +3 %", m, {}, {}, false});
  out.push_back({"plant B (literal) as the wire", p, {}, {}, true});
  out.push_back({"e2e wire, fitted without its convection", sma_host::e2e_fit_without_convection(),
                 sma_host::e2e_wire_effects(), {}, false, sma_host::e2e_wire()});
  out.push_back({"e2e wire, the flow's whole fit (board's model)", sma_host::e2e_flow_fit(),
                 sma_host::e2e_wire_effects(), sma_host::e2e_flow_fit_effects(), false, sma_host::e2e_wire()});
  for (double L : {0.0, 0.5, 1.0}) {
    sma::Effects wire;
    wire.latent_heat_J = 1.0;
    sma::Effects model;
    model.latent_heat_J = L;
    char name[64];
    std::snprintf(name, sizeof name, "latent heat 1 J, model %.1f J", L);
    out.push_back({name, p, wire, model, false});
  }
  return out;
}
}  // namespace

int main(int argc, char** argv) {
  const char* json_path = "bench_tracking_model_error.json";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--json FILE]\n", argv[0]);
      return 2;
    }
  }
  // FeedforwardPid twice: the paper's, then with the known future (lead).
  const sma::Mode modes[] = {sma::Mode::Pid, sma::Mode::FeedforwardPid, sma::Mode::FeedforwardPid, sma::Mode::Preview};
  const std::vector<Case> cs = cases();
  // The Q16.16 preview on the cases its heat-loss observer is for (and the exact model).
  const size_t fixed_cases[] = {0, 3, 4};
  std::vector<Row> rows, fixed_rows;
  int done = 0;
  const int total = static_cast<int>(cs.size() * 2 * (sizeof modes / sizeof modes[0]) +
                                     2 * (sizeof fixed_cases / sizeof fixed_cases[0]));
  sma_host::CaseLine progress;
  auto one = [&](const Case& c, int sine, sma::Mode mode, bool fixed, bool lead) {
    progress("[%2d/%2d] %s%s", ++done, total, c.name.c_str(), fixed ? " (Q16.16)" : "");
    RunSetup s;
    s.mode = mode;
    s.condition = sma_host::Condition::rig_like();
    s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
    s.plant_params = c.plant;
    s.model_params = c.model;
    s.plant_effects = c.plant_fx;
    s.model_effects = c.model_fx;
    if (mode != sma::Mode::Preview) s.config.gains = sma::console::default_gains(mode);
    if (lead) s.lead.lead_s = sma::lead_for(s.reference.kind).lead_s;
    const std::vector<sma_host::Sample> r = fixed ? run<sma::Fixed>(c, s) : run(c, s);
    Row row{c.name, sine ? "sine" : "multi-step", lead ? "lead" : sma::mode_name(mode), Metrics(), 0.0,
            fixed ? "fixed" : "float"};
    if (sine) {
      row.m = sma_host::sine_metrics(r, s.reference.sine_period_s);
    } else {
      row.m = sma_host::step_metrics(r, s.reference.step_s);
      row.overshoot_mm = sma_host::step_overshoot_mm(r, s.reference.step_s, 10.0);
    }
    return row;
  };
  for (const Case& c : cs)
    for (int sine = 0; sine <= 1; ++sine)
      for (size_t i = 0; i < sizeof modes / sizeof modes[0]; ++i) rows.push_back(one(c, sine, modes[i], false, i == 2));
  for (size_t i : fixed_cases)
    for (int sine = 0; sine <= 1; ++sine) fixed_rows.push_back(one(cs[i], sine, sma::Mode::Preview, true, false));
  progress.finish();
  std::printf("Rig-like, float, default settings; true position, whole run (sine after its first "
              "period). Overshoot: past each new setpoint within 10 s of its step. Wrong-way: after / before\n"
              "a reversal or down-step (before: past a held setpoint, away from the next one).\n\n"
              "| case | test | controller | max mm | RMS mm | max fall mm | wrong-way mm | SSE mm | overshoot mm |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %s | %s | %s | %.4f | %.4f | %.4f | %.4f / %.4f | %s | %s |\n", r.kase.c_str(), r.test.c_str(),
                r.controller.c_str(), r.m.max_mm, r.m.rms_mm, r.m.max_fall_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm,
                r.test == "sine" ? "-" : std::to_string(r.m.sse_mm).substr(0, 6).c_str(),
                r.test == "sine" ? "-" : std::to_string(r.overshoot_mm).substr(0, 6).c_str());
  std::printf("\nThe preview in Q16.16 (the Uno's scalar; the same runs otherwise):\n\n"
              "| case | test | max mm | RMS mm | wrong-way mm | SSE mm | overshoot mm |\n"
              "|---|---|---|---|---|---|---|\n");
  for (const Row& r : fixed_rows)
    std::printf("| %s | %s | %.4f | %.4f | %.4f / %.4f | %s | %s |\n", r.kase.c_str(), r.test.c_str(), r.m.max_mm,
                r.m.rms_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm,
                r.test == "sine" ? "-" : std::to_string(r.m.sse_mm).substr(0, 6).c_str(),
                r.test == "sine" ? "-" : std::to_string(r.overshoot_mm).substr(0, 6).c_str());
  rows.insert(rows.end(), fixed_rows.begin(), fixed_rows.end());
  FILE* f = std::fopen(json_path, "w");
  if (!f) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(f, "{\n  \"runs\": [\n");
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    std::fprintf(f,
                 "    {\"case\": \"%s\", \"test\": \"%s\", \"condition\": \"rig-like\", \"scalar\": \"%s\", "
                 "\"controller\": \"%s\", \"max_mm\": %.6f, \"rms_mm\": %.6f, \"max_fall_mm\": %.6f, "
                 "\"wrong_way_mm\": %.6f, \"wrong_way_before_mm\": %.6f, \"sse_mm\": %.6f, \"overshoot_mm\": %.6f}%s\n",
                 r.kase.c_str(), r.test.c_str(), r.scalar, r.controller.c_str(), r.m.max_mm, r.m.rms_mm,
                 r.m.max_fall_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm, r.m.sse_mm, r.overshoot_mm,
                 i + 1 < rows.size() ? "," : "");
  }
  std::fprintf(f, "  ]\n}\n");
  std::fclose(f);
  std::printf("wrote %s\n", json_path);
  return 0;
}
