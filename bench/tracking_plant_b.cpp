// Tracking on plant B: the controllers, whose model is the library's (paper parameters), run
// in closed loop against the independently written plant B (plant_b.hpp): model != plant in
// the thermal discretisation (RK4 sub-steps vs exact step) and, with the literal reading, in
// the re-heat rule of the hysteresis. Rig-like and ideal conditions of model.md, the paper's
// sine and multi-step; PID alone, inverse + PID, inverse + PID with the known future ("lead":
// the board's leads, sma::lead_for, 5.25 s sine / 10 s steps) and preview, each with the
// firmware's default settings (console::default_gains, PreviewConfig()), double and float. For comparison the same
// controllers on the library's own plant. Prints a Markdown table and writes JSON.
//
//   bench_tracking_plant_b [--json FILE]
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include "sma/console.hpp"
#include "sma_host/metrics.hpp"
#include "sma_host/plant_b_loop.hpp"
#include "sma_host/progress.hpp"

using sma_host::Condition;
using sma_host::Metrics;
using sma_host::RunSetup;

namespace {
struct Row {
  std::string plant, test, condition, controller, scalar;
  Metrics m;
};

// plant: 0 = the library's Plant, 1 = plant B with the library's re-heat reading (return-point
// memory), 2 = plant B with model.md's literal reading (a new loop at every reversal).
template <class T>
Metrics run(int plant, const RunSetup& s) {
  std::vector<sma_host::Sample> r;
  if (plant == 0) {
    r = sma_host::run_closed_loop<T>(s);
  } else {
    sma_host::plant_b::Wire w;
    w.return_point_memory = plant == 1;
    r = sma_host::plant_b::run_closed_loop_b<T>(s, w);
  }
  return s.reference.kind == sma::RefKind::Sine ? sma_host::sine_metrics(r, s.reference.sine_period_s)
                                                : sma_host::step_metrics(r, s.reference.step_s);
}
}  // namespace

int main(int argc, char** argv) {
  const char* json_path = "tracking_plant_b.json";
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--json FILE]\n", argv[0]);
      return 2;
    }
  }
  const char* plant_names[] = {"library", "B (rpm)", "B (literal)"};
  // FeedforwardPid twice: the paper's, then with the known future (lead).
  const sma::Mode modes[] = {sma::Mode::Pid, sma::Mode::FeedforwardPid, sma::Mode::FeedforwardPid, sma::Mode::Preview};
  std::vector<Row> rows;
  sma_host::CaseLine progress;
  for (int c = 1; c >= 0; --c)
    for (int sine = 1; sine >= 0; --sine)
      for (int plant = 0; plant < 3; ++plant)
        for (size_t i = 0; i < sizeof modes / sizeof modes[0]; ++i) {
          const sma::Mode mode = modes[i];
          const bool lead = i == 2;
          RunSetup s;
          s.mode = mode;
          s.condition = c ? Condition::rig_like() : Condition::ideal();
          s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
          if (mode != sma::Mode::Preview) s.config.gains = sma::console::default_gains(mode);
          if (lead) s.lead.lead_s = sma::lead_for(s.reference.kind).lead_s;
          const char* name = lead ? "lead" : sma::mode_name(mode);
          progress("%-5s %-8s %-12s %s", sine ? "sine" : "steps", s.condition.name, plant_names[plant], name);
          for (int k = 0; k < 2; ++k) {
            Row r{plant_names[plant], sine ? "sine" : "multi-step", s.condition.name, name,
                  k ? "float" : "double", k ? run<float>(plant, s) : run<double>(plant, s)};
            rows.push_back(r);
          }
        }
  progress.finish();

  std::printf("Controllers with the library's model (paper parameters) and the firmware's default "
              "settings, true position; whole run (sine: after its first period; steps: from t = 0).\n\n");
  std::printf("| test | condition | plant | controller | scalar | max mm | RMS mm | max rise mm | max fall mm | "
              "RMS fall mm | wrong-way mm | SSE mm |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %s | %s | %s | %s | %s | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f |\n", r.test.c_str(),
                r.condition.c_str(), r.plant.c_str(), r.controller.c_str(), r.scalar.c_str(), r.m.max_mm,
                r.m.rms_mm, r.m.max_rise_mm, r.m.max_fall_mm, r.m.rms_fall_mm, r.m.wrong_way_mm, r.m.sse_mm);

  FILE* f = std::fopen(json_path, "w");
  if (!f) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(f, "{\n  \"runs\": [\n");
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    std::fprintf(f,
                 "    {\"plant\": \"%s\", \"test\": \"%s\", \"condition\": \"%s\", \"controller\": \"%s\", "
                 "\"scalar\": \"%s\", \"max_mm\": %.6f, \"rms_mm\": %.6f, \"max_rise_mm\": %.6f, "
                 "\"rms_rise_mm\": %.6f, \"max_fall_mm\": %.6f, \"rms_fall_mm\": %.6f, \"wrong_way_mm\": %.6f, "
                 "\"settle_s\": %.3f, \"settle_max_s\": %.3f, \"sse_mm\": %.6f}%s\n",
                 r.plant.c_str(), r.test.c_str(), r.condition.c_str(), r.controller.c_str(), r.scalar.c_str(),
                 r.m.max_mm, r.m.rms_mm, r.m.max_rise_mm, r.m.rms_rise_mm, r.m.max_fall_mm, r.m.rms_fall_mm,
                 r.m.wrong_way_mm, r.m.settle_s, r.m.settle_max_s, r.m.sse_mm, i + 1 < rows.size() ? "," : "");
  }
  std::fprintf(f, "  ]\n}\n");
  std::fclose(f);
  std::printf("wrote %s\n", json_path);
  return 0;
}
