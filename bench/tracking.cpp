// Tracking benchmark: the paper's two references on the simulated plant, for PID alone,
// feedforward alone, feedforward + PID, feedforward + PID with the known future ("lead":
// LeadConfig::lead_s, the Uno's compact use of it) and the preview controller
// (preview.hpp), in double,
// float and Q16.16 fixed point, in the ideal and rig-like conditions of model.md. Settings:
// tuned per controller, test and condition by sma_host::tune_pid / tune_preview (the same
// method and objective for all: whole-run RMS + 0.1x whole-run max, tune.hpp; the lead by
// tune_lead). Prints a
// Markdown table and writes JSON; also the plant's speed in simulated seconds per wall second.
//
//   bench_tracking [--json FILE] [--quick]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include "sma/fixed.hpp"
#include "sma_host/progress.hpp"
#include "sma_host/tune.hpp"

using sma_host::Condition;
using sma_host::Metrics;
using sma_host::RunSetup;

namespace {
struct Row {
  std::string test, condition, controller, scalar;
  sma::PidGains gains;
  sma::PreviewConfig preview;
  double lead_s;
  double board_lead_s;  // the board's lead of this reference (sma::lead_for; `lead 1`), s
  Metrics m;
};

template <class T>
Metrics run(const RunSetup& s) {
  const std::vector<sma_host::Sample> r = sma_host::run_closed_loop<T>(s);
  return s.reference.kind == sma::RefKind::Sine ? sma_host::sine_metrics(r, s.reference.sine_period_s)
                                                : sma_host::step_metrics(r, s.reference.step_s);
}
}  // namespace

int main(int argc, char** argv) {
  const char* json_path = "bench_tracking.json";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--json FILE]\n", argv[0]);
      return 2;
    }
  }
  std::vector<Row> rows;
  // FeedforwardPid twice: the paper's (lead 0), then with the known future (lead).
  const sma::Mode modes[] = {sma::Mode::Pid, sma::Mode::Feedforward, sma::Mode::FeedforwardPid,
                             sma::Mode::FeedforwardPid, sma::Mode::Preview};
  const sma_host::Objective objective = sma_host::Objective::WholeRun;
  int done = 0;
  sma_host::CaseLine progress;
  for (int c = 0; c < 2; ++c)
    for (int sine = 1; sine >= 0; --sine)
      for (size_t i = 0; i < sizeof modes / sizeof modes[0]; ++i) {
        const sma::Mode mode = modes[i];
        const bool lead = i == 3;
        RunSetup s;
        s.condition = c ? Condition::rig_like() : Condition::ideal();
        s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
        s = sma_host::tuned(s, mode, lead, objective);
        const char* name = lead ? "lead" : sma::mode_name(mode);
        progress("[%2d/20] tuning and running %-5s %-7s %s", ++done, sine ? "sine" : "steps", name, s.condition.name);
        const char* names[] = {"double", "float", "fixed"};
        for (int k = 0; k < 3; ++k) {
          Row r{sine ? "sine" : "multi-step", s.condition.name, name, names[k],
                s.config.gains, s.preview, s.lead.lead_s, lead ? sma::lead_for(s.reference.kind).lead_s : 0.0,
                Metrics()};
          r.m = k == 0 ? run<double>(s) : k == 1 ? run<float>(s) : run<sma::Fixed>(s);
          rows.push_back(r);
        }
      }
  progress.finish();

  // Plant speed: simulated seconds per wall second, plain and with a thermal effect.
  double speed[2];
  for (int e = 0; e < 2; ++e) {
    sma::Effects fx;
    if (e) fx.latent_heat_J = 1.0;
    sma::Plant plant(sma::Params(), fx);
    const auto t0 = std::chrono::steady_clock::now();
    const int n = e ? 200000 : 2000000;
    for (int k = 0; k < n; ++k) plant.step(k % 5000 < 2500 ? 1.6 : 0.3, 0.01);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    speed[e] = n * 0.01 / wall;
  }

  std::printf("Tuned for: %s. Whole run (sine: after its first period; steps: from t = 0), phases "
              "with their transitions, then the paper-style partial figures (labelled). Preview rows: "
              "kp = track_s, ki = offset_tau_s, kd = cool_weight. Lead rows: inverse + PID with the known "
              "future (lead_s; peak window %.0f s).\n\n", sma_host::objective_name(objective),
              sma::LeadConfig().peak_window_s);
  std::printf("| test | condition | controller | scalar | kp | ki | kd | lead s | max mm | RMS mm | max rise mm | "
              "max fall mm | RMS fall mm | wrong-way mm (after / before a step) | settle max s | SSE mm | "
              "(paper) max heat mm | (paper) max cool mm |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (Row r : rows) {
    if (r.controller == "preview") r.gains = {r.preview.track_s, r.preview.offset_tau_s, r.preview.cool_weight};
    std::printf("| %s | %s | %s | %s | %.3g | %.3g | %.3g | %.3g | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f / %.4f | "
                "%.2f | %.4f | %.4f | %.4f |\n",
                r.test.c_str(), r.condition.c_str(), r.controller.c_str(), r.scalar.c_str(), r.gains.kp,
                r.gains.ki, r.gains.kd, r.lead_s, r.m.max_mm, r.m.rms_mm, r.m.max_rise_mm, r.m.max_fall_mm,
                r.m.rms_fall_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm, r.m.settle_max_s, r.m.sse_mm,
                r.m.max_heat_mm, r.m.max_cool_mm);
  }
  std::printf("\nPlant speed: %.0f simulated s per wall s (paper's model), %.0f (with latent heat, "
              "5 ms sub-steps)\n", speed[0], speed[1]);

  FILE* f = std::fopen(json_path, "w");
  if (!f) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(f, "{\n  \"plant_sim_s_per_wall_s\": %.1f,\n  \"plant_latent_sim_s_per_wall_s\": %.1f,\n  \"runs\": [\n",
               speed[0], speed[1]);
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    std::fprintf(f,
                 "    {\"test\": \"%s\", \"condition\": \"%s\", \"controller\": \"%s\", \"scalar\": \"%s\", "
                 "\"kp\": %g, \"ki\": %g, \"kd\": %g, \"max_mm\": %.6f, \"rms_mm\": %.6f, "
                 "\"max_rise_mm\": %.6f, \"rms_rise_mm\": %.6f, \"max_fall_mm\": %.6f, \"rms_fall_mm\": %.6f, "
                 "\"wrong_way_mm\": %.6f, \"wrong_way_before_mm\": %.6f, \"settle_s\": %.3f, \"settle_max_s\": %.3f, \"sse_mm\": %.6f, "
                 "\"max_heat_mm\": %.6f, \"rms_heat_mm\": %.6f, \"max_cool_mm\": %.6f, \"overshoot_pct\": %.3f, \"track_s\": %g, \"offset_tau_s\": %g, "
                 "\"cool_weight\": %g, \"lead_s\": %g, \"board_lead_s\": %g}%s\n",
                 r.test.c_str(), r.condition.c_str(), r.controller.c_str(), r.scalar.c_str(), r.gains.kp,
                 r.gains.ki, r.gains.kd, r.m.max_mm, r.m.rms_mm, r.m.max_rise_mm, r.m.rms_rise_mm,
                 r.m.max_fall_mm, r.m.rms_fall_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm, r.m.settle_s, r.m.settle_max_s,
                 r.m.sse_mm, r.m.max_heat_mm, r.m.rms_heat_mm, r.m.max_cool_mm, r.m.overshoot_pct,
                 r.preview.track_s, r.preview.offset_tau_s, r.preview.cool_weight, r.lead_s, r.board_lead_s,
                 i + 1 < rows.size() ? "," : "");
  }
  std::fprintf(f, "  ]\n}\n");
  std::fclose(f);
  std::printf("wrote %s\n", json_path);
  return 0;
}
