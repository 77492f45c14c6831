// Discrepancy benchmark: runs the workflow on every hidden-effect case (hidden_effects.hpp) and
// prints the confusion matrix (hidden effect -> effects named), the gap before/after and the
// time per log. Writes JSON.  bench_discrepancy [--json FILE] [--only SUBSTRING]
// The workflow is the tool's (`tools/sma discrepancy`: diagnose_reading, the re-heat reading
// decided on the log, then the effects), with the tool's default options.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include "sma_host/hidden_effects.hpp"
#include "sma_host/progress.hpp"

using namespace sma_host;

int main(int argc, char** argv) {
  const char* json_path = "bench_discrepancy.json";
  std::string only;  // run only the cases whose label contains this
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--json FILE] [--only SUBSTRING]\n", argv[0]);
      return 2;
    }
  }
  const sma::Params p;
  std::vector<HiddenCase> cases;
  uint64_t seed = 100;
  std::vector<uint64_t> seeds;  // each case keeps its seed when others are left out
  for (const HiddenCase& c : hidden_effect_cases()) {
    ++seed;
    if (c.label.find(only) == std::string::npos) continue;
    cases.push_back(c);
    seeds.push_back(seed);
  }
  if (cases.empty()) {
    std::fprintf(stderr, "%s: no case matches --only %s\n", argv[0], only.c_str());
    return 2;
  }
  std::map<std::string, std::map<std::string, int>> confusion;  // hidden -> named -> count
  FILE* f = std::fopen(json_path, "w");
  if (!f) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(f, "{\n  \"cases\": [\n");
  std::printf("| log | hidden | named (final values) | re-heat reading | RMS before mm | RMS after mm | excess gap shrink | s |\n"
              "|---|---|---|---|---|---|---|---|\n");
  int right = 0, n_effect = 0;
  double min_shrink = 1.0;
  sma_host::CaseLine progress;
  for (size_t i = 0; i < cases.size(); ++i) {
    const HiddenCase& c = cases[i];
    progress("[%2zu/%zu] %s", i + 1, cases.size(), c.label.c_str());
    const auto t0 = std::chrono::steady_clock::now();
    const Diagnosis d = diagnose_reading(p, hidden_effect_log(c, p, seeds[i]), Options(), [](const char*) {});
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::string named, hidden;
    for (const std::string& h : c.hidden) hidden += (hidden.empty() ? "" : " + ") + h;
    if (hidden.empty()) hidden = "none";
    bool all = d.effects.size() == c.hidden.size();
    for (const FittedEffect& e : d.effects) {
      char buf[96];
      std::snprintf(buf, sizeof buf, e.spec->n > 1 ? "%s(%.3g, %.3g)" : "%s(%.3g)", e.spec->name.c_str(), e.value[0], e.value[1]);
      named += (named.empty() ? "" : " + ") + std::string(buf);
      bool in = false;
      for (const std::string& h : c.hidden) in = in || h == e.spec->name;
      all = all && in;
      confusion[hidden][e.spec->name]++;
    }
    if (d.effects.empty()) confusion[hidden]["(nothing)"]++;
    const double g0 = excess_gap(d.rms_nominal, d.noise_mm), g1 = excess_gap(d.rms_final, d.noise_mm);
    const double shrink = g0 > 0 ? 1.0 - g1 / g0 : 1.0;
    if (!c.hidden.empty()) {
      ++n_effect;
      right += all;
      min_shrink = fmin(min_shrink, shrink);
    }
    const char* reading = reheat_name(d.params.reheat);
    std::printf("| %s | %s | %s | %s | %.4f | %.4f | %.1f %% | %.1f |\n", c.label.c_str(), hidden.c_str(),
                named.empty() ? "(nothing)" : named.c_str(), reading, d.rms_nominal, d.rms_final, 100 * shrink, secs);
    std::fprintf(f, "    {\"log\": \"%s\", \"hidden\": \"%s\", \"named\": \"%s\", \"right\": %s, \"reading\": \"%s\", "
                 "\"rms_mm_nominal\": %.6f, \"rms_mm_final\": %.6f, \"excess_gap_shrink\": %.4f, \"seconds\": %.2f}%s\n",
                 c.label.c_str(), hidden.c_str(), named.c_str(), (c.hidden.empty() ? d.effects.empty() : all) ? "true" : "false",
                 reading, d.rms_nominal, d.rms_final, shrink, secs, i + 1 < cases.size() ? "," : "");
  }
  progress.finish();
  std::printf("\nConfusion (hidden -> named, over both excitations and magnitudes):\n\n| hidden | named |\n|---|---|\n");
  for (const auto& row : confusion) {
    std::string cells;
    for (const auto& cell : row.second) cells += (cells.empty() ? "" : ", ") + cell.first + " x" + std::to_string(cell.second);
    std::printf("| %s | %s |\n", row.first.c_str(), cells.c_str());
  }
  std::printf("\nNamed right: %d of %d logs with hidden effects (%.0f %%); smallest excess-gap shrink %.1f %%\n", right,
              n_effect, 100.0 * right / n_effect, 100 * min_shrink);
  std::fprintf(f, "  ],\n  \"named_right\": %d,\n  \"logs_with_effects\": %d,\n  \"min_excess_gap_shrink\": %.4f\n}\n",
               right, n_effect, min_shrink);
  std::fclose(f);
  std::printf("wrote %s\n", json_path);
  return 0;
}
