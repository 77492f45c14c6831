// plant2_make_logs: rig logs (interfaces.md: t_s,v_V,d_mm at 100 Hz) from plant B
// (host/include/sma_host/plant_b.hpp), with hidden effects of the vocabulary, for the
// discrepancy benchmark bench/discrepancy_plant2.py. Writes DIR/<case>.csv and DIR/cases.json
// (what is hidden in each log; the logs themselves do not say).
//
//   plant2_make_logs --out DIR [--quick] [--only SUBSTRING[,SUBSTRING...]] [--reading literal|rpm] [--list]
// --reading: what a re-heat that transforms nothing does to the loop it interrupted (plant_b.hpp):
// `literal` (default) opens a new loop at every reversal; `rpm` keeps it (return-point memory,
// the library's reading), which isolates the effects from this difference of the base model.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <algorithm>
#include <string>
#include <vector>
#include "excitations.hpp"
#include "sma_host/model.hpp"
#include "sma_host/plant_b.hpp"
#include "sma_host/plant_b_rig.hpp"
#include "sma_host/plant_b_sensor.hpp"

namespace {

using sma_host::plant_b::SensorEffects;
using sma_host::plant_b::Wire;
using sma_host::plant_b::WireEffects;

// An effect of the vocabulary hidden in a log: its name and its parameters (the parameter
// table's keys, sma/param_table.hpp) at their hidden values.
struct Hidden {
  std::string name;
  std::vector<std::pair<uint8_t, double>> params;
};

struct Case {
  std::string name, excitation;
  std::vector<Hidden> hidden;
  bool adc;     // ADC quantization on top of the noise
  bool quick;   // part of the --quick subset
  uint64_t seed;
};

constexpr double kNoiseMm = 0.002;          // 2 um RMS (model.md, rig-like)
constexpr double kAdcMm = 2.0 / 1024.0;     // 10-bit ADC over a 2 mm span

// Strong magnitudes: ordinary for a real rig. Weak: a third of the strong departure from the
// identity value (sma::Effects' default: gain 1, else 0).
double strong_value(sma::param::Row r) {
  using R = sma::param::Row;
  switch (r) {
    case R::delay_s: return 0.255;
    case R::tau_s: return 0.6;
    case R::gain: return 1.15;
    case R::offset_mm: return 0.04;
    case R::offset_K: return -4.5;
    case R::beta_per_K: return 0.01;
    case R::k_R: return -0.2;
    case R::L_J: return 3.0;
    case R::alpha_per_K: return 1.1e-5;
    default: break;
  }
  fprintf(stderr, "plant2_make_logs: no strong value for %s\n", sma_host::key_name(sma::param::first_key(r)).c_str());
  exit(2);
}

// Every effect of the vocabulary in the table's order, at its strong magnitude.
const std::vector<Hidden>& levels() {
  static const std::vector<Hidden> v = [] {
    std::vector<Hidden> out;
    for (uint8_t k = 0; k < sma::param::kKeys; ++k) {
      if (sma_host::key_kind(k) != sma::param::Kind::Effect) continue;
      const std::string name = sma_host::effect_of_key(k);
      if (out.empty() || out.back().name != name) out.push_back({name, {}});
      out.back().params.push_back({k, strong_value(static_cast<sma::param::Row>(sma::param::locate(k).row))});
    }
    return out;
  }();
  return v;
}

Hidden level(const std::string& name, bool strong) {
  const sma_host::Model identity;
  for (const Hidden& l : levels())
    if (l.name == name) {
      Hidden h{name, {}};
      for (const auto& p : l.params) {
        const double k = strong ? 1.0 : 1.0 / 3.0, one = sma_host::value(identity, p.first);
        h.params.push_back({p.first, one + k * (p.second - one)});
      }
      return h;
    }
  fprintf(stderr, "plant2_make_logs: unknown effect %s\n", name.c_str());
  exit(2);
}

std::vector<Case> cases() {
  const char* ex[4] = {"sine", "ramp6", "stairs", "steps"};
  std::vector<Case> out;
  uint64_t seed = 1100;
  for (int e = 0; e < 4; ++e) {
    const bool adc = std::string(ex[e]) == "stairs";
    out.push_back({std::string(ex[e]) + "-clean", ex[e], {}, adc, e < 2, ++seed});
    int i = 0;
    for (const Hidden& l : levels()) {
      for (int strong = 1; strong >= 0; --strong) {
        // quick: the strong level of each effect, on one excitation each (rotating)
        const bool quick = strong == 1 && (i % 4) == e;
        out.push_back({std::string(ex[e]) + "-" + l.name + (strong ? "-strong" : "-weak"), ex[e],
                       {level(l.name, strong != 0)}, adc, quick, ++seed});
      }
      ++i;
    }
  }
  struct Pair {
    const char *ex, *a, *b;
    bool quick;
  };
  const Pair pairs[] = {{"sine", "sensor_delay", "ambient_offset", true},
                        {"ramp6", "latent_heat", "resistance_phase", false},
                        {"stairs", "sensor_lag", "convection_nonlinear", false},
                        {"steps", "sensor_calibration", "thermal_expansion", true},
                        {"stairs", "ambient_offset", "latent_heat", false},
                        {"sine", "resistance_phase", "sensor_lag", false}};
  for (const Pair& p : pairs)
    out.push_back({std::string(p.ex) + "-" + p.a + "+" + p.b, p.ex, {level(p.a, true), level(p.b, true)},
                   std::string(p.ex) == "stairs", p.quick, ++seed});
  return out;
}

// The hidden effects of a case as the library's Effects (the others at their identity value).
sma::Effects hidden_effects(const Case& c) {
  sma_host::Model m;
  for (const Hidden& h : c.hidden)
    for (const auto& p : h.params) sma_host::value(m, p.first) = p.second;
  return m.fx;
}

bool g_return_point_memory = false;

bool write_log(const Case& c, const std::string& path) {
  Wire wire;
  wire.return_point_memory = g_return_point_memory;
  // Plant B's own reading of each effect (plant_b.hpp): convection as a conductance growing with
  // the temperature rise, latent heat as a temperature drop per unit of transformation.
  const sma::Effects fx = hidden_effects(c);
  const WireEffects wf = sma_host::plant_b::wire_effects(fx, wire);
  SensorEffects sf = sma_host::plant_b::sensor_effects(fx);
  sf.noise_mm = kNoiseMm;
  sf.adc_mm = c.adc ? kAdcMm : 0.0;

  const plant2::Program prog = plant2::excitation(c.excitation, c.seed);
  sma_host::plant_b::WirePlant plant(wire, wf);
  sma_host::plant_b::Sensor sensor(sf, plant2::kDt, c.seed * 7919u + 1u);
  FILE* f = fopen(path.c_str(), "w");
  if (!f) {
    fprintf(stderr, "plant2_make_logs: cannot write %s\n", path.c_str());
    return false;
  }
  fprintf(f, "# rig: plant_b (tools/plant2/make_logs), 100 Hz, seed %llu\n", static_cast<unsigned long long>(c.seed));
  fprintf(f, "t_s,v_V,d_mm\n");
  for (size_t k = 0; k < prog.v.size(); ++k) {
    fprintf(f, "%.2f,%.4f,%.5f\n", static_cast<double>(k) * plant2::kDt, prog.v[k], sensor.read(plant.displacement_mm()));
    plant.step(prog.v[k], plant2::kDt);
  }
  return fclose(f) == 0;
}

void write_manifest(const std::vector<Case>& cs, const std::string& path) {
  FILE* f = fopen(path.c_str(), "w");
  if (!f) {
    fprintf(stderr, "plant2_make_logs: cannot write %s\n", path.c_str());
    exit(1);
  }
  fprintf(f, "{\n  \"noise_mm\": %.6f,\n  \"adc_mm\": %.8f,\n  \"reading\": \"%s\",\n  \"cases\": [\n", kNoiseMm,
          kAdcMm, g_return_point_memory ? "rpm" : "literal");
  for (size_t i = 0; i < cs.size(); ++i) {
    const Case& c = cs[i];
    fprintf(f, "    {\"name\": \"%s\", \"file\": \"%s.csv\", \"excitation\": \"%s\", \"adc\": %s, \"quick\": %s, "
               "\"hidden\": {", c.name.c_str(), c.name.c_str(), c.excitation.c_str(), c.adc ? "true" : "false",
            c.quick ? "true" : "false");
    for (size_t j = 0; j < c.hidden.size(); ++j) {
      fprintf(f, "%s\"%s\": {", j ? ", " : "", c.hidden[j].name.c_str());
      for (size_t k = 0; k < c.hidden[j].params.size(); ++k)
        fprintf(f, "%s\"%s\": %.9g", k ? ", " : "", sma_host::param_of_key(c.hidden[j].params[k].first).c_str(),
                c.hidden[j].params[k].second);
      fprintf(f, "}");
    }
    fprintf(f, "}}%s\n", i + 1 < cs.size() ? "," : "");
  }
  fprintf(f, "  ]\n}\n");
  fclose(f);
}

int usage() {
  fprintf(stderr, "usage: plant2_make_logs --out DIR [--quick] [--only SUBSTRING[,SUBSTRING...]] [--reading literal|rpm] [--list]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out, only;
  bool quick = false, list = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) out = argv[++i];
    else if (a == "--only" && i + 1 < argc) only = argv[++i];
    else if (a == "--reading" && i + 1 < argc) {
      const std::string r = argv[++i];
      if (r != "literal" && r != "rpm") {
        fprintf(stderr, "plant2_make_logs: --reading must be literal or rpm, not %s\n", r.c_str());
        return 2;
      }
      g_return_point_memory = r == "rpm";
    } else if (a == "--quick") quick = true;
    else if (a == "--list") list = true;
    else return usage();
  }
  // --only: comma-separated substrings, a case matching any of them is kept
  std::vector<std::string> pats;
  for (size_t a = 0; !only.empty() && a <= only.size();) {
    const size_t b = std::min(only.find(',', a), only.size());
    pats.push_back(only.substr(a, b - a));
    a = b + 1;
  }
  std::vector<Case> cs;
  for (const Case& c : cases()) {
    bool match = pats.empty();
    for (const std::string& p : pats) match = match || c.name.find(p) != std::string::npos;
    if ((!quick || c.quick) && match) cs.push_back(c);
  }
  if (list) {
    for (const Case& c : cs) printf("%s\n", c.name.c_str());
    return 0;
  }
  if (out.empty()) return usage();
  if (cs.empty()) {
    fprintf(stderr, "plant2_make_logs: no case matches --only %s\n", only.c_str());
    return 2;
  }
  if (system(("mkdir -p '" + out + "'").c_str()) != 0) {
    fprintf(stderr, "plant2_make_logs: cannot create %s\n", out.c_str());
    return 1;
  }
  for (const Case& c : cs)
    if (!write_log(c, out + "/" + c.name + ".csv")) return 1;
  write_manifest(cs, out + "/cases.json");
  printf("wrote %zu logs and cases.json to %s\n", cs.size(), out.c_str());
  return 0;
}
