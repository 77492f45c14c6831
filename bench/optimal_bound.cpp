// The optimal-control bound: the best open-loop voltage profile on the model itself, with full
// knowledge of the plant and of the future reference, for the paper's sine and multi-step, ideal
// and rig-like (PWM-quantised voltage; noise does not reach an open-loop profile). Printed next
// to every controller of the tracking benchmark (its JSON, if present).
//
// Method: direct shooting. V(t) is piecewise-linear between knots every 0.5 s, clamped to
// 0..V_max, and the plant (plant.hpp: the library's own thermal and hysteresis boxes) is run
// forward at 100 Hz. Objective: the one every controller is tuned for (tune.hpp, WholeRun):
// whole-run RMS + 0.1x whole-run max, on the true position, the sine scored after its first
// period. The hysteresis makes the objective non-smooth (kinks where a loop opens, flat
// stages with zero gradient), so no gradients: a coordinate search with step sizes 0.4, 0.2,
// 0.1, 0.05, 0.02 V, far larger than the kinks' width in V, moving one knot (and, in a second
// pass, pairs of neighbours together) while the exact objective improves; at most 3 sweeps
// per step size and width. Starts: the knots sampled from the inverse + PID's and the preview's
// voltage profiles (the 0.5 s family alone), and the best controller's own 10 ms profile (of five:
// PID alone, feedforward alone, inverse + PID without and with the known future, the preview) with
// the knots as a correction on top (V(t) = V_ctl(t) + knots, clamped 0..V_max): the preview
// switches on the 10 ms tick, which 0.5 s knots cannot represent, and at zero correction the
// open-loop replay is the controller's run itself (rig-like too: the plant is deterministic
// and the noise reaches the wire only through the voltages, which are replayed). The best
// result is reported, so the bound is never above a controller on the same plant, condition
// and run (the sine's three periods, the tracking benchmark's): checked against the
// controllers' own runs and the tracking JSON's rows, a bound above one exits with status 3.
//
// Each bound's profile is also replayed on plant B (both re-heat readings): how much of the
// bound depends on the library's reading of a re-heat (docs/control.md). --plant searches on
// plant B instead (then nothing is checked: a controller's library-plant voltages replayed on
// plant B are not its run there); --only restricts the problems (e.g. --only sine-ideal).
//
//   bench_optimal_bound [--json FILE] [--tracking JSON] [--plant library|b-rpm|b-literal]
//                       [--only sine|multi-step|sine-ideal|...]
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "sma_host/plant_b_rig.hpp"
#include "sma_host/tune.hpp"

using sma_host::Metrics;
using sma_host::Sample;

namespace {
constexpr double kKnot = 0.5;
constexpr double kDt = 0.01;
constexpr double kVmax = 2.0;  // ControllerConfig's v_max
// The controllers whose runs the bound must not be above: PID, FF, inverse + PID, preview, lead.
constexpr size_t kControllers = 5, kLead = 4;

// The plant a profile runs on: the library's (the bound's own), or plant B (plant_b.hpp,
// written apart from the library) with the library's re-heat reading or model.md's literal one.
enum class PlantKind { Library, BRpm, BLiteral };
const char* plant_name(PlantKind k) {
  return k == PlantKind::Library ? "library" : k == PlantKind::BRpm ? "B (rpm)" : "B (literal)";
}

struct Problem {
  sma::Reference ref;
  bool rig_like;
  double duration;
  PlantKind plant = PlantKind::Library;
  // A controller's applied voltage at every 10 ms tick, the knots a correction on top of it;
  // empty: the knots are the profile itself.
  std::vector<double> base;
};

template <class PlantT>
std::vector<Sample> simulate_on(PlantT& plant, const Problem& p, const std::vector<double>& knots);

std::vector<Sample> simulate(const Problem& p, const std::vector<double>& knots) {
  sma::RigOptions rig = p.rig_like ? sma::RigOptions::rig_like() : sma::RigOptions();
  rig.noise_mm = 0.0;
  rig.adc_step_mm = 0.0;
  if (p.plant == PlantKind::Library) {
    sma::Plant plant{sma::Params(), sma::Effects(), rig};
    return simulate_on(plant, p, knots);
  }
  sma_host::plant_b::Wire w;
  w.return_point_memory = p.plant == PlantKind::BRpm;
  sma_host::plant_b::RigB plant(w, sma_host::plant_b::WireEffects(), rig, kDt);
  return simulate_on(plant, p, knots);
}

template <class PlantT>
std::vector<Sample> simulate_on(PlantT& plant, const Problem& p, const std::vector<double>& knots) {
  sma::ReferenceGen<double> gen(p.ref);
  const long n = static_cast<long>(p.duration / kDt + 0.5);
  std::vector<Sample> out;
  out.reserve(static_cast<size_t>(n));
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * kDt;
    const double x = t / kKnot;
    size_t i = static_cast<size_t>(x);
    if (i + 1 >= knots.size()) i = knots.size() - 2;
    const double w = x - static_cast<double>(i);
    const double u = knots[i] + w * (knots[i + 1] - knots[i]);
    // Zero correction replays the base exactly (its PWM-quantised levels may sit a hair above V_max).
    const double v = p.base.empty() ? sma::clamp(u, 0.0, kVmax)
                     : u == 0.0   ? p.base[static_cast<size_t>(k)]
                                  : sma::clamp(p.base[static_cast<size_t>(k)] + u, 0.0, kVmax);
    out.push_back({t, gen.at(t), plant.displacement(), plant.displacement(), plant.applied_voltage(v), 0, 0});
    plant.step(v, kDt);
  }
  return out;
}

Metrics score(const Problem& p, const std::vector<Sample>& r) {
  return p.ref.kind == sma::RefKind::Sine ? sma_host::sine_metrics(r, p.ref.sine_period_s)
                                          : sma_host::step_metrics(r, p.ref.step_s);
}
double cost(const Metrics& m) { return m.rms_mm + 0.1 * m.max_mm; }

// A controller as the tracking benchmark runs it (tuned for the same objective, this test and
// condition, closed loop, double): the voltage it applied at every tick. Rig-like: the
// PWM-quantised voltages of its noisy run; the noise reaches the wire only through them, so
// their open-loop replay on the noise-free plant reproduces the run's true position exactly.
std::vector<double> controller_profile(const Problem& p, sma::Mode mode, bool lead) {
  sma_host::RunSetup s;
  s.reference = p.ref;
  s.condition = p.rig_like ? sma_host::Condition::rig_like() : sma_host::Condition::ideal();
  std::vector<double> v;
  for (const Sample& x : sma_host::run_closed_loop<double>(sma_host::tuned(s, mode, lead, sma_host::Objective::WholeRun)))
    v.push_back(x.v);
  return v;
}

// A profile sampled at the knots: the mean over each knot's half-interval either side.
std::vector<double> at_knots(const std::vector<double>& v, size_t n_knots) {
  std::vector<double> k(n_knots, 0.0);
  for (size_t i = 0; i < n_knots; ++i) {
    double sum = 0;
    int n = 0;
    for (size_t j = 0; j < v.size(); ++j) {
      const double t = static_cast<double>(j) * kDt;
      if (t >= (static_cast<double>(i) - 0.5) * kKnot && t < (static_cast<double>(i) + 0.5) * kKnot) {
        sum += v[j];
        ++n;
      }
    }
    k[i] = n ? sum / n : 0.0;
  }
  return k;
}

std::vector<double> coordinate_search(const Problem& p, std::vector<double> k, double* best, int* evals) {
  const double lo = p.base.empty() ? 0.0 : -kVmax;  // a correction may lower the base to 0 V
  *best = cost(score(p, simulate(p, k)));
  for (double h : {0.4, 0.2, 0.1, 0.05, 0.02}) {
    for (int width = 1; width <= 2; ++width) {
      bool improved = true;
      for (int sweep = 0; sweep < 3 && improved; ++sweep) {
        improved = false;
        for (size_t i = 0; i + static_cast<size_t>(width) <= k.size(); ++i) {
          for (double d : {h, -h}) {
            std::vector<double> trial = k;
            for (int j = 0; j < width; ++j) trial[i + static_cast<size_t>(j)] = sma::clamp(trial[i + static_cast<size_t>(j)] + d, lo, kVmax);
            const double c = cost(score(p, simulate(p, trial)));
            ++*evals;
            if (c < *best - 1e-9) {
              *best = c;
              k = trial;
              improved = true;
              break;
            }
          }
        }
      }
    }
  }
  return k;
}
}  // namespace

int main(int argc, char** argv) {
  const char* json_path = "optimal_bound.json";
  const char* tracking = "build/bench-results/tracking.json";
  std::string only;
  PlantKind search_plant = PlantKind::Library;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else if (!std::strcmp(argv[i], "--tracking") && i + 1 < argc) tracking = argv[++i];
    else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
    else if (!std::strcmp(argv[i], "--plant") && i + 1 < argc) {
      const std::string a = argv[++i];
      if (a == "library") search_plant = PlantKind::Library;
      else if (a == "b-rpm") search_plant = PlantKind::BRpm;
      else if (a == "b-literal") search_plant = PlantKind::BLiteral;
      else {
        std::fprintf(stderr, "--plant: unknown plant '%s' (library, b-rpm, b-literal)\n", a.c_str());
        return 2;
      }
    } else {
      std::fprintf(stderr, "usage: %s [--json FILE] [--tracking JSON] [--plant library|b-rpm|b-literal] "
                   "[--only TEST[-CONDITION]]\n", argv[0]);
      return 2;
    }
  }
  struct Ctl {
    std::string name;
    std::vector<double> v;  // its applied voltage, 10 ms
    double cost;            // its objective (its own run, replayed on the library plant)
  };
  struct Out {
    std::string test, condition;
    Metrics m;
    double cost, wall;
    int evals;
    Metrics on[3];  // the profile replayed on each PlantKind
    std::string start;  // "knots", or the controller whose profile the knots correct
    Ctl ctl[kControllers];
  };
  std::vector<Out> outs;
  for (int sine = 1; sine >= 0; --sine)
    for (int rig = 0; rig < 2; ++rig) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::string name = std::string(sine ? "sine" : "multi-step") + (rig ? "-rig-like" : "-ideal");
      if (!only.empty() && name.compare(0, only.size(), only) != 0) continue;
      Problem p{sine ? sma::Reference::sine() : sma::Reference::multi_step(), rig == 1, 0, search_plant, {}};
      p.duration = p.ref.duration();  // the tracking benchmark's run: the sine's three periods
      const size_t n_knots = static_cast<size_t>(p.duration / kKnot) + 2;
      double best = INFINITY;
      std::vector<double> best_k, best_base;
      int evals = 0;
      // The controllers' own runs, replayed: the bound starts at or below the best of them.
      Ctl ctl[kControllers];
      // Inverse + PID twice: the paper's, then with the known future (the lead; the tracking
      // benchmark's rows, tuned the same way): the bound is a bound on every one of them.
      const sma::Mode modes[] = {sma::Mode::Pid, sma::Mode::Feedforward, sma::Mode::FeedforwardPid,
                                 sma::Mode::Preview, sma::Mode::FeedforwardPid};
      size_t best_ctl = 0;
      for (size_t c = 0; c < kControllers; ++c) {
        Problem q = p;
        q.plant = PlantKind::Library;
        const bool lead = c == kLead;
        q.base = controller_profile(p, modes[c], lead);
        ctl[c] = {lead ? "lead" : sma::mode_name(modes[c]), q.base, cost(score(q, simulate(q, std::vector<double>(n_knots, 0.0))))};
        if (ctl[c].cost < ctl[best_ctl].cost) best_ctl = c;
      }
      // Starts: the knots sampled from inverse + PID's and the preview's profiles (the 0.5 s
      // family alone), and a correction on the best controller's full 10 ms profile.
      for (int start = 0; start < 3; ++start) {
        Problem q = p;
        if (start == 2) q.base = ctl[best_ctl].v;
        const std::vector<double> k0 = start == 2 ? std::vector<double>(n_knots, 0.0)
                                                  : at_knots(ctl[start == 0 ? 2 : 3].v, n_knots);
        double c;
        std::vector<double> k = coordinate_search(q, k0, &c, &evals);
        if (c < best) {
          best = c;
          best_k = k;
          best_base = q.base;
        }
      }
      p.base = best_base;
      const Metrics m = score(p, simulate(p, best_k));
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      outs.push_back({sine ? "sine" : "multi-step", rig ? "rig-like" : "ideal", m, best, wall, evals, {},
                      p.base.empty() ? "knots" : ctl[best_ctl].name, {}});
      for (size_t c = 0; c < kControllers; ++c) outs.back().ctl[c] = ctl[c];
      for (int k = 0; k < 3; ++k) {
        Problem q = p;
        q.plant = static_cast<PlantKind>(k);
        outs.back().on[k] = score(q, simulate(q, best_k));
      }
      std::fprintf(stderr, "%s %s: cost %.4f from %s (%d evaluations, %.0f s)\n", outs.back().test.c_str(),
                   outs.back().condition.c_str(), best, outs.back().start.c_str(), evals, wall);
      for (const Ctl& c : ctl)
        std::fprintf(stderr, "  %s's own run, replayed: objective %.6f\n", c.name.c_str(), c.cost);
    }

  // The controllers' rows (double) from the tracking benchmark, if it ran.
  std::ifstream tj(tracking);
  std::stringstream buf;
  buf << tj.rdbuf();
  const std::string js = buf.str();
  auto field = [](const std::string& obj, const char* key) {
    const std::string k = std::string("\"") + key + "\": ";
    const size_t at = obj.find(k);
    return at == std::string::npos ? std::string() : obj.substr(at + k.size(), obj.find_first_of(",}", at + k.size()) - at - k.size());
  };
  std::printf("Bounds searched on the %s plant. The bound's voltage profile replayed open loop on each plant:\n\n"
              "| test | condition | plant | max mm | RMS mm | max rise mm | max fall mm |\n|---|---|---|---|---|---|---|\n",
              plant_name(search_plant));
  for (const Out& o : outs)
    for (int k = 0; k < 3; ++k)
      std::printf("| %s | %s | %s | %.4f | %.4f | %.4f | %.4f |\n", o.test.c_str(), o.condition.c_str(),
                  plant_name(static_cast<PlantKind>(k)), o.on[k].max_mm, o.on[k].rms_mm, o.on[k].max_rise_mm,
                  o.on[k].max_fall_mm);
  std::printf("\n");
  std::printf("Optimal open-loop bound (0.5 s knots, alone or on a controller's 10 ms profile; objective "
              "whole-run RMS + 0.1 max, true position) "
              "next to the controllers (double, tuned for the same objective):\n\n");
  std::printf("| test | condition | controller | max mm | RMS mm | max rise mm | max fall mm | wrong-way mm |\n"
              "|---|---|---|---|---|---|---|---|\n");
  // A bound above what a controller achieved on the same plant and condition is no bound: the
  // controllers' own runs (and the tracking benchmark's rows) are checked, the run fails.
  std::vector<std::string> defects;
  for (const Out& o : outs)
    for (const Ctl& c : o.ctl)
      if (search_plant == PlantKind::Library && o.cost > c.cost + 1e-9)
        defects.push_back(o.test + " " + o.condition + ": bound above " + c.name + "'s own run");
  for (const Out& o : outs) {
    std::printf("| %s | %s | **optimal bound** (from %s) | %.4f | %.4f | %.4f | %.4f | %.4f |\n", o.test.c_str(),
                o.condition.c_str(), o.start.c_str(), o.m.max_mm, o.m.rms_mm, o.m.max_rise_mm, o.m.max_fall_mm, o.m.wrong_way_mm);
    size_t pos = 0;
    while ((pos = js.find("{\"test\"", pos)) != std::string::npos) {
      const std::string obj = js.substr(pos, js.find('}', pos) - pos + 1);
      pos += obj.size();
      if (field(obj, "test") != "\"" + o.test + "\"" || field(obj, "condition") != "\"" + o.condition + "\"" ||
          field(obj, "scalar") != "\"double\"")
        continue;
      auto num = [&](const char* key) { return std::atof(field(obj, key).c_str()); };
      std::string name = field(obj, "controller");
      if (name.size() >= 2) name = name.substr(1, name.size() - 2);
      // The JSON's figures carry 6 decimals.
      if (search_plant == PlantKind::Library && o.cost > num("rms_mm") + 0.1 * num("max_mm") + 2e-6)
        defects.push_back(o.test + " " + o.condition + ": bound above " + name + " of " + tracking);
      std::printf("| %s | %s | %s | %.4f | %.4f | %.4f | %.4f | %.4f |\n", o.test.c_str(), o.condition.c_str(),
                  name.c_str(), num("max_mm"), num("rms_mm"), num("max_rise_mm"), num("max_fall_mm"),
                  num("wrong_way_mm"));
    }
  }
  FILE* f = std::fopen(json_path, "w");
  if (!f) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(f, "{\n  \"knot_s\": %g,\n  \"objective\": \"whole-run RMS + 0.1 max\",\n  \"plant\": \"%s\",\n  \"bounds\": [\n",
               kKnot, plant_name(search_plant));
  for (size_t i = 0; i < outs.size(); ++i) {
    const Out& o = outs[i];
    std::fprintf(f,
                 "    {\"test\": \"%s\", \"condition\": \"%s\", \"max_mm\": %.6f, \"rms_mm\": %.6f, "
                 "\"max_rise_mm\": %.6f, \"max_fall_mm\": %.6f, \"wrong_way_mm\": %.6f, \"cost\": %.6f, "
                 "\"evaluations\": %d, \"wall_s\": %.1f, \"start\": \"%s\", \"replayed\": {",
                 o.test.c_str(), o.condition.c_str(), o.m.max_mm, o.m.rms_mm, o.m.max_rise_mm, o.m.max_fall_mm,
                 o.m.wrong_way_mm, o.cost, o.evals, o.wall, o.start.c_str());
    for (int k = 0; k < 3; ++k)
      std::fprintf(f, "\"%s\": {\"max_mm\": %.6f, \"rms_mm\": %.6f, \"max_rise_mm\": %.6f, \"max_fall_mm\": %.6f}%s",
                   plant_name(static_cast<PlantKind>(k)), o.on[k].max_mm, o.on[k].rms_mm, o.on[k].max_rise_mm,
                   o.on[k].max_fall_mm, k < 2 ? ", " : "");
    std::fprintf(f, "}}%s\n", i + 1 < outs.size() ? "," : "");
  }
  std::fprintf(f, "  ]\n}\n");
  std::fclose(f);
  std::printf("\nwrote %s\n", json_path);
  double wall = 0;
  for (const Out& o : outs) wall += o.wall;
  std::printf("runtime: %.0f s, the problems' wall times summed (%zu problems)\n", wall, outs.size());
  for (const std::string& d : defects) std::fprintf(stderr, "DEFECT: %s\n", d.c_str());
  return defects.empty() ? 0 : 3;
}
