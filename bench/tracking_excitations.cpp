// Tracking on references unlike the paper's two (issue 13): a user's trajectory as the board's
// `traj` takes it (random setpoints over the stroke, random holds, small steps and reversals),
// triangles, sines of other periods and amplitudes, a descending staircase, a ramp and hold.
// Every controller with the firmware's settings (console::default_gains, PreviewConfig()): PID
// alone, inverse + PID, inverse + PID with the known future ("lead", the board's lead for the
// reference: board_lead_s; double, and float as on the Uno), the preview as the host runs it
// (plans in its tick, double) and as the board runs it (plans between ticks, float), rig-like
// (model.md: noise, ADC, PWM, a tick of computation delay), on the library's plant and on plant
// B (plant_b.hpp, written apart, its literal re-heat reading). Whole-run metrics (metrics.hpp,
// reference_metrics: from t = 0, a sine after its first period). Prints a Markdown table and
// writes JSON; progress on stderr.
//
//   bench_tracking_excitations [--json FILE] [--only NAME] [--csv DIR] [--traj-lines]
//   --only NAME   the references whose name contains NAME
//   --csv DIR     every run's samples as DIR/<reference>-<plant>-<controller>.csv (t, ref, meas,
//                 truth, v, temp)
//   --traj-lines  print the console lines of the user trajectory (traj clear, traj t mm ...,
//                 traj run) and exit: the FIL test uploads the same trajectory
#include <stdint.h>

#include <algorithm>
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

// A trajectory from points (t s, mm); false if the board would refuse one.
sma::Reference trajectory(const std::vector<std::pair<double, double>>& pts) {
  sma::Reference r;
  r.kind = sma::RefKind::Trajectory;
  for (const auto& p : pts)
    if (!r.add_point(p.first, p.second)) std::fprintf(stderr, "trajectory: point (%g, %g) refused\n", p.first, p.second);
  return r;
}

// A 32-bit LCG (Numerical Recipes): the same trajectory on every platform and library.
struct Lcg {
  uint32_t s;
  double uniform(double lo, double hi) {
    s = s * 1664525u + 1013904223u;
    return lo + (hi - lo) * (static_cast<double>(s >> 8) / 16777216.0);
  }
};

// A user's trajectory: 8 setpoints in the board's 16 points (each held 2-15 s, reached by a jump
// or a 1-4 s ramp); about a third of the moves are small steps of 0.02-0.05 mm, the others go
// anywhere over 0.1-0.85 mm of the 0.958 mm stroke, up or down (reversals); fixed seed.
sma::Reference user_trajectory() {
  Lcg rng{13u};
  std::vector<std::pair<double, double>> pts;
  double t = 0.0, mm = rng.uniform(0.2, 0.8);
  for (int i = 0; i < 8; ++i) {
    if (i > 0) {
      double next;
      if (rng.uniform(0, 1) < 0.35) {
        const double d = rng.uniform(0.02, 0.05);
        next = mm + (rng.uniform(0, 1) < 0.5 && mm - d >= 0.1 ? -d : mm + d <= 0.85 ? d : -d);
      } else {
        do next = rng.uniform(0.1, 0.85); while (next - mm < 0.1 && mm - next < 0.1);
      }
      t += rng.uniform(0, 1) < 0.5 ? 0.01 : rng.uniform(1.0, 4.0);
      mm = next;
    }
    // Hundredths of a second and microns: what a user types.
    t = static_cast<double>(static_cast<long>(t * 100.0 + 0.5)) / 100.0;
    mm = static_cast<double>(static_cast<long>(mm * 1000.0 + 0.5)) / 1000.0;
    pts.push_back({t, mm});
    t += rng.uniform(2.0, 15.0);
    t = static_cast<double>(static_cast<long>(t * 100.0 + 0.5)) / 100.0;
    pts.push_back({t, mm});
  }
  return trajectory(pts);
}

// Ramps between lo and hi, ramp_s each way, from lo at t = 0 (no jump: the first ramp starts
// from the cold wire's side), n_ramps ramps.
sma::Reference triangle(double lo, double hi, double ramp_s, int n_ramps) {
  std::vector<std::pair<double, double>> pts;
  for (int i = 0; i <= n_ramps; ++i) pts.push_back({i * ramp_s, i % 2 ? hi : lo});
  return trajectory(pts);
}

sma::Reference sine(double lo, double hi, double period_s, double cycles) {
  sma::Reference r = sma::Reference::sine();
  r.sine_lo_mm = lo;
  r.sine_hi_mm = hi;
  r.sine_period_s = period_s;
  r.sine_cycles = cycles;
  return r;
}

sma::Reference staircase_down() {
  sma::Reference r = sma::Reference::multi_step();
  const double mm[] = {0.8, 0.7, 0.6, 0.5, 0.4, 0.3, 0.2};
  r.n_steps = 7;
  for (int k = 0; k < 7; ++k) r.step_mm[k] = mm[k];
  r.step_s = 20.0;
  return r;
}

struct Excitation {
  const char* name;
  const char* what;
  sma::Reference ref;
  double from_s;  // scored from (a sine: after its first period)
};

std::vector<Excitation> excitations() {
  return {
      {"traj-random", "user traj: 8 random setpoints, holds 2-15 s, jumps and ramps, small steps", user_trajectory(), 0},
      {"triangle-slow", "0.2-0.7 mm, 40 s ramps (0.0125 mm/s), 4 ramps", triangle(0.2, 0.7, 40, 4), 0},
      {"triangle-fast", "0.2-0.7 mm, 8 s ramps (0.0625 mm/s), 10 ramps", triangle(0.2, 0.7, 8, 10), 0},
      {"sine-20s", "0.2-0.7 mm, period 20 s, 5 periods", sine(0.2, 0.7, 20, 5), 20},
      {"sine-100s", "0.2-0.7 mm, period 100 s, 2 periods", sine(0.2, 0.7, 100, 2), 100},
      {"sine-small", "0.45-0.55 mm, period 50 s, 3 periods", sine(0.45, 0.55, 50, 3), 50},
      {"sine-ends", "0.03-0.93 mm (the stroke 0-0.958), period 50 s, 3 periods", sine(0.03, 0.93, 50, 3), 50},
      {"stairs-down", "0.8 mm, then down 0.1 mm every 20 s to 0.2", staircase_down(), 0},
      {"ramp-hold", "0.2 mm 10 s, ramp to 0.7 in 20 s, hold 20 s, ramp to 0.3 in 10 s, hold 20 s",
       trajectory({{0, 0.2}, {10, 0.2}, {30, 0.7}, {50, 0.7}, {60, 0.3}, {80, 0.3}}), 0},
  };
}

struct Ctl {
  const char* name;
  sma::Mode mode;
  bool board;  // float, the board's scalar (the preview: plans between ticks too)
  bool lead;   // inverse + PID with the known future, the board's lead (board_lead_s)
};
const Ctl kControllers[] = {{"PID", sma::Mode::Pid, false, false},
                            {"inverse+PID", sma::Mode::FeedforwardPid, false, false},
                            {"lead", sma::Mode::FeedforwardPid, false, true},
                            {"lead (float)", sma::Mode::FeedforwardPid, true, true},
                            {"preview", sma::Mode::Preview, false, false},
                            {"preview (board)", sma::Mode::Preview, true, false}};
const size_t kNumCtl = sizeof kControllers / sizeof kControllers[0];
const char* kPlants[] = {"library", "B (literal)"};

// The lead the board gives a reference (sma::lead_for the kind it runs as). The board's `step` and
// `sine` are the paper's only (board_commands refuses others), so every reference here but a
// constant is uploaded as `traj`: the stairs down too, though it is steps like the paper's
// multi-step.
double board_lead_s(const sma::Reference& r) {
  const sma::Reference paper = sma::Reference::multi_step();
  bool paper_steps = r.kind == sma::RefKind::MultiStep && r.n_steps == paper.n_steps && r.step_s == paper.step_s;
  for (uint8_t k = 0; paper_steps && k < r.n_steps; ++k) paper_steps = r.step_mm[k] == paper.step_mm[k];
  const sma::RefKind as = paper_steps || r.kind == sma::RefKind::Constant ? r.kind : sma::RefKind::Trajectory;
  return sma::lead_for(as).lead_s;
}

RunSetup setup(const Excitation& x, const Ctl& c) {
  RunSetup s;
  s.mode = c.mode;
  s.condition = Condition::rig_like();
  s.reference = x.ref;
  if (c.mode != sma::Mode::Preview) s.config.gains = sma::console::default_gains(c.mode);
  if (c.lead) s.lead.lead_s = board_lead_s(x.ref);
  s.preview.plan_in_step = !c.board;  // the board: PreviewConfig::plan_passes() after each tick
  return s;
}

template <class T>
std::vector<sma_host::Sample> run(int plant, const RunSetup& s) {
  // (Plant B's default wire: model.md's literal re-heat reading, a new loop at every reversal.)
  return plant == 0 ? sma_host::run_closed_loop<T>(s) : sma_host::plant_b::run_closed_loop_b<T>(s);
}

struct Row {
  std::string ref, plant, controller;
  double lead_s;
  Metrics m;
  double v_min, v_max;         // the heater's command over the run, V
  std::vector<double> rms_seeds;  // whole-run RMS with noise seeds 1..kSeeds (m is seed 1's)
  double median() const {
    std::vector<double> v = rms_seeds;
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  }
};

// Noise seeds per run: on a hysteretic wire a controller can be chaotic (a PID's reversals open
// loops where the noise decides), and one run of it can land anywhere in a wide range; the
// comparisons below use the median over these seeds, the tables show the range.
const int kSeeds = 8;

void write_csv(const char* dir, const Row& row, const std::vector<sma_host::Sample>& r) {
  std::string path = std::string(dir) + "/" + row.ref + "-" + row.plant + "-" + row.controller + ".csv";
  for (char& ch : path)
    if (ch == ' ' || ch == '(' || ch == ')') ch = '_';
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::perror(path.c_str());
    return;
  }
  std::fprintf(f, "t,ref,meas,truth,v,temp\n");
  for (const sma_host::Sample& p : r)
    std::fprintf(f, "%.2f,%.6f,%.6f,%.6f,%.5f,%.4f\n", p.t, p.ref, p.meas, p.truth, p.v, p.temp);
  std::fclose(f);
}

std::string seeds_list(const Row& r) {
  std::string out;
  char buf[32];
  for (size_t k = 0; k < r.rms_seeds.size(); ++k) {
    std::snprintf(buf, sizeof buf, "%s%.6f", k ? ", " : "", r.rms_seeds[k]);
    out += buf;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const char* json_path = "tracking_excitations.json";
  const char* only = "";
  const char* csv_dir = nullptr;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json") && i + 1 < argc) json_path = argv[++i];
    else if (!std::strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
    else if (!std::strcmp(argv[i], "--csv") && i + 1 < argc) csv_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--traj-lines")) {
      RunSetup s;
      s.reference = user_trajectory();
      const std::vector<std::string> lines = sma_host::board_commands(s);
      for (const std::string& l : lines)
        if (l.compare(0, 4, "traj") == 0) std::printf("%s\n", l.c_str());
      return 0;
    } else {
      std::fprintf(stderr, "usage: %s [--json FILE] [--only NAME] [--csv DIR] [--traj-lines]\n", argv[0]);
      return 2;
    }
  }
  std::vector<Excitation> xs;
  for (const Excitation& x : excitations())
    if (std::strstr(x.name, only)) xs.push_back(x);
  std::vector<Row> rows;
  sma_host::CaseLine progress;
  int done = 0;
  const int total = static_cast<int>(xs.size() * 2 * kNumCtl);
  for (const Excitation& x : xs)
    for (int plant = 0; plant < 2; ++plant)
      for (const Ctl& c : kControllers) {
        progress("[%2d/%d] %-13s %-11s %s", ++done, total, x.name, kPlants[plant], c.name);
        RunSetup s = setup(x, c);
        const std::vector<sma_host::Sample> r = c.board ? run<float>(plant, s) : run<double>(plant, s);
        Row row{x.name, kPlants[plant], c.name, s.lead.lead_s, sma_host::reference_metrics(r, x.from_s), 1e9, -1e9, {}};
        row.rms_seeds.push_back(row.m.rms_mm);
        for (int seed = 2; seed <= kSeeds; ++seed) {
          s.condition.rig.seed = static_cast<uint64_t>(seed);
          const std::vector<sma_host::Sample> q = c.board ? run<float>(plant, s) : run<double>(plant, s);
          row.rms_seeds.push_back(sma_host::reference_metrics(q, x.from_s).rms_mm);
        }
        for (const sma_host::Sample& p : r) {
          row.v_min = p.v < row.v_min ? p.v : row.v_min;
          row.v_max = p.v > row.v_max ? p.v : row.v_max;
        }
        rows.push_back(row);
        if (csv_dir) write_csv(csv_dir, row, r);
      }
  progress.finish();

  std::printf("References unlike the paper's, rig-like, the firmware's settings; true position, whole run "
              "(from t = 0; a sine after its first period). Time to 5 %%: worst over the holds, from when the "
              "reference arrives.\n\n| reference | what |\n|---|---|\n");
  for (const Excitation& x : xs) std::printf("| %s | %s |\n", x.name, x.what);
  std::printf("\n| reference | plant | controller | max mm | RMS mm | max rise mm | RMS rise mm | max fall mm | "
              "RMS fall mm | wrong-way after / before mm | SSE mm | time to 5 %% s (mean / worst) |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %s | %s | %s | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f / %.4f | %.4f | %.1f / %.1f |\n",
                r.ref.c_str(), r.plant.c_str(), r.controller.c_str(), r.m.max_mm, r.m.rms_mm, r.m.max_rise_mm,
                r.m.rms_rise_mm, r.m.max_fall_mm, r.m.rms_fall_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm,
                r.m.sse_mm, r.m.settle_s, r.m.settle_max_s);

  // The spread over the noise seeds: median (min..max) of the whole-run RMS.
  std::printf("\nWhole-run RMS over %d noise seeds (1 above), median (min..max) mm: a controller that the "
              "hysteresis makes chaotic lands anywhere in its range from one run to the next:\n\n| reference | plant |",
              kSeeds);
  for (const Ctl& c : kControllers) std::printf(" %s |", c.name);
  std::printf("\n|---|---|");
  for (size_t j = 0; j < kNumCtl; ++j) std::printf("---|");
  std::printf("\n");
  for (size_t i = 0; i + kNumCtl <= rows.size(); i += kNumCtl) {
    std::printf("| %s | %s |", rows[i].ref.c_str(), rows[i].plant.c_str());
    for (size_t j = 0; j < kNumCtl; ++j) {
      const std::vector<double>& v = rows[i + j].rms_seeds;
      std::printf(" %.4f (%.4f..%.4f) |", rows[i + j].median(), *std::min_element(v.begin(), v.end()),
                  *std::max_element(v.begin(), v.end()));
    }
    std::printf("\n");
  }

  // Where the preview loses: its whole-run RMS against the better of PID alone and inverse + PID.
  std::printf("\nThe preview's whole-run RMS against the better of PID alone and inverse + PID (ratio > 1: "
              "the preview loses):\n\n| reference | plant | preview | preview (board) | best other | ratio |\n"
              "|---|---|---|---|---|---|\n");
  for (size_t i = 0; i + kNumCtl <= rows.size(); i += kNumCtl) {
    const double other = rows[i].m.rms_mm < rows[i + 1].m.rms_mm ? rows[i].m.rms_mm : rows[i + 1].m.rms_mm;
    const char* who = rows[i].m.rms_mm < rows[i + 1].m.rms_mm ? "PID" : "inverse+PID";
    std::printf("| %s | %s | %.4f | %.4f | %.4f (%s) | %.2f |\n", rows[i].ref.c_str(), rows[i].plant.c_str(),
                rows[i + 4].m.rms_mm, rows[i + 5].m.rms_mm, other, who, rows[i + 4].m.rms_mm / other);
  }

  // The lead against the same two (the Uno's candidate default for step, sine and traj), RMS and max.
  std::printf("\nThe lead's whole-run RMS / max against PID alone and inverse + PID (ratio: the lead's RMS over "
              "the better RMS of the two; > 1: the lead loses; seed 1, then the medians over the seeds):\n\n"
              "| reference | plant | lead s | PID | inverse+PID | lead | lead (float) | preview | ratio | ratio (float) | "
              "ratio of medians |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (size_t i = 0; i + kNumCtl <= rows.size(); i += kNumCtl) {
    const double other = rows[i].m.rms_mm < rows[i + 1].m.rms_mm ? rows[i].m.rms_mm : rows[i + 1].m.rms_mm;
    std::printf("| %s | %s | %g |", rows[i].ref.c_str(), rows[i].plant.c_str(), rows[i + 2].lead_s);
    for (size_t j = 0; j < 5; ++j) std::printf(" %.4f / %.4f |", rows[i + j].m.rms_mm, rows[i + j].m.max_mm);
    const double other_med = std::min(rows[i].median(), rows[i + 1].median());
    std::printf(" %.2f | %.2f | %.2f |\n", rows[i + 2].m.rms_mm / other, rows[i + 3].m.rms_mm / other,
                rows[i + 2].median() / other_med);
  }

  FILE* f = std::fopen(json_path, "w");
  if (!f) {
    std::perror(json_path);
    return 1;
  }
  std::fprintf(f, "{\n  \"condition\": \"rig-like\",\n  \"references\": [\n");
  for (size_t i = 0; i < xs.size(); ++i)
    std::fprintf(f, "    {\"name\": \"%s\", \"what\": \"%s\", \"duration_s\": %g, \"scored_from_s\": %g}%s\n", xs[i].name,
                 xs[i].what, xs[i].ref.duration(), xs[i].from_s, i + 1 < xs.size() ? "," : "");
  std::fprintf(f, "  ],\n  \"runs\": [\n");
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    std::fprintf(f,
                 "    {\"reference\": \"%s\", \"plant\": \"%s\", \"controller\": \"%s\", \"lead_s\": %g, \"max_mm\": %.6f, "
                 "\"rms_mm\": %.6f, \"max_rise_mm\": %.6f, \"rms_rise_mm\": %.6f, \"max_fall_mm\": %.6f, "
                 "\"rms_fall_mm\": %.6f, \"wrong_way_mm\": %.6f, \"wrong_way_before_mm\": %.6f, \"sse_mm\": %.6f, "
                 "\"settle_s\": %.3f, \"settle_max_s\": %.3f, \"v_min\": %.4f, \"v_max\": %.4f, "
                 "\"rms_seeds_median_mm\": %.6f, \"rms_seeds_mm\": [%s]}%s\n",
                 r.ref.c_str(), r.plant.c_str(), r.controller.c_str(), r.lead_s, r.m.max_mm, r.m.rms_mm, r.m.max_rise_mm,
                 r.m.rms_rise_mm, r.m.max_fall_mm, r.m.rms_fall_mm, r.m.wrong_way_mm, r.m.wrong_way_before_mm,
                 r.m.sse_mm, r.m.settle_s, r.m.settle_max_s, r.v_min, r.v_max, r.median(), seeds_list(r).c_str(),
                 i + 1 < rows.size() ? "," : "");
  }
  std::fprintf(f, "  ]\n}\n");
  std::fclose(f);
  std::printf("wrote %s\n", json_path);
  return 0;
}
