// The preview on the end-to-end flow's wire (sma_host::e2e_wire, its hidden non-linear
// convection) with a fitted model, at the model and over a neighbourhood of it: draws of h and g
// within +-0.2 %, T_AS and T_AF within +-0.1 K, each well inside the 95 % intervals `sma fit`
// reports for them on the flow's training log (h +-0.3 %, T_AS +-0.19 K, T_AF +-0.26 K before the
// residual's correlation inflates them ~14x). Two fits are only told apart by tracking if their
// neighbourhoods differ: at one point the preview's discrete decisions (the first hold's
// re-approach, the plan's switch) flip on changes far below what any log resolves
// (docs/control.md section 23). Rig-like, float, default PreviewConfig, true position, whole run.
// Prints a Markdown table and writes JSON.
//
//   bench_e2e_fit_neighbourhood [--draws N] [--json FILE] [PARAMS.json ...]
//   (no PARAMS: the flow's fit, sma_host::e2e_flow_fit() with its sensor offset)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <random>
#include <string>
#include <vector>
#include "sma_host/e2e_wire.hpp"
#include "sma_host/metrics.hpp"
#include "sma_tools/params_json.hpp"

namespace {

struct Figures {
  double steps_rms, steps_wrong_way_before, steps_sse, sine_max;
};

Figures run(const sma_host::Model& m) {
  Figures f{};
  for (int sine = 0; sine <= 1; ++sine) {
    sma_host::RunSetup s;
    s.mode = sma::Mode::Preview;
    s.condition = sma_host::Condition::rig_like();
    s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
    s.plant_params = sma_host::e2e_wire();
    s.plant_effects = sma_host::e2e_wire_effects();
    s.model_params = m.p;
    s.model_effects = m.fx;
    const std::vector<sma_host::Sample> r = sma_host::run_closed_loop<float>(s);
    if (sine) {
      f.sine_max = sma_host::sine_metrics(r, s.reference.sine_period_s).max_mm;
    } else {
      const sma_host::Metrics mm = sma_host::step_metrics(r, s.reference.step_s);
      f.steps_rms = mm.rms_mm;
      f.steps_wrong_way_before = mm.wrong_way_before_mm;
      f.steps_sse = mm.sse_mm;
    }
  }
  return f;
}

// min, median, 90th percentile
struct Spread {
  double min, median, p90;
};
Spread spread(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return {v[0], v[n / 2], v[(9 * (n - 1)) / 10]};
}

}  // namespace

int main(int argc, char** argv) {
  const char* json_path = "bench_e2e_fit_neighbourhood.json";
  int draws = 100;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else if (!std::strcmp(argv[i], "--draws") && i + 1 < argc) draws = std::atoi(argv[++i]);
    else if (argv[i][0] != '-') files.push_back(argv[i]);
    else {
      std::fprintf(stderr, "usage: %s [--draws N] [--json FILE] [PARAMS.json ...]\n", argv[0]);
      return 2;
    }
  }
  if (draws < 1) draws = 1;
  std::vector<std::pair<std::string, sma_host::Model>> models;
  if (files.empty()) {
    sma_host::Model m;
    m.p = sma_host::e2e_flow_fit();
    m.fx = sma_host::e2e_flow_fit_effects();
    models.push_back({"the flow's fit (e2e_flow_fit)", m});
  }
  for (const std::string& f : files) {
    try {
      models.push_back({f, sma_tools::read_model(f)});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", f.c_str(), e.what());
      return 1;
    }
  }
  std::printf("Preview on the e2e wire, rig-like float: at the model / min, median, 90th percentile over %d draws "
              "(h, g +-0.2 %%, T_AS, T_AF +-0.1 K).\n\n"
              "| model | steps RMS mm | wrong-way before mm | SSE mm | sine max mm |\n|---|---|---|---|---|\n",
              draws);
  FILE* out = std::fopen(json_path, "w");
  if (!out) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(out, "{\n  \"draws\": %d,\n  \"models\": [\n", draws);
  for (size_t k = 0; k < models.size(); ++k) {
    const sma_host::Model& m0 = models[k].second;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<Figures> fs;
    fs.push_back(run(m0));
    for (int i = 1; i < draws; ++i) {
      sma_host::Model m = m0;
      m.p.h *= 1.0 + 0.002 * u(rng);
      m.p.g *= 1.0 + 0.002 * u(rng);
      m.p.T_AS += 0.1 * u(rng);
      m.p.T_AF += 0.1 * u(rng);
      fs.push_back(run(m));
    }
    const char* names[] = {"steps_rms_mm", "wrong_way_before_mm", "sse_mm", "sine_max_mm"};
    Spread sp[4];
    for (int c = 0; c < 4; ++c) {
      std::vector<double> v;
      for (const Figures& f : fs)
        v.push_back(c == 0 ? f.steps_rms : c == 1 ? f.steps_wrong_way_before : c == 2 ? f.steps_sse : f.sine_max);
      sp[c] = spread(v);
    }
    const Figures& at = fs[0];
    const double point[4] = {at.steps_rms, at.steps_wrong_way_before, at.steps_sse, at.sine_max};
    std::printf("| %s |", models[k].first.c_str());
    for (int c = 0; c < 4; ++c) std::printf(" %.4f / %.4f, %.4f, %.4f |", point[c], sp[c].min, sp[c].median, sp[c].p90);
    std::printf("\n");
    std::fprintf(out, "    {\"model\": %s", sma_tools::json::quote(models[k].first).c_str());
    for (int c = 0; c < 4; ++c)
      std::fprintf(out, ", \"%s\": {\"at\": %.6f, \"min\": %.6f, \"median\": %.6f, \"p90\": %.6f}", names[c], point[c],
                   sp[c].min, sp[c].median, sp[c].p90);
    std::fprintf(out, "}%s\n", k + 1 < models.size() ? "," : "");
  }
  std::fprintf(out, "  ]\n}\n");
  std::fclose(out);
  std::printf("\nwrote %s\n", json_path);
  return 0;
}
