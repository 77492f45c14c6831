// The hidden-effect cases that prove the discrepancy workflow (issue 6): every effect of the
// vocabulary at a weak and a strong magnitude, on the two excitations (voltage steps and the
// paper's decaying ramp), with 2 um of sensor noise; plus logs with nothing hidden and logs
// with two effects at once. Shared by test_discrepancy.cpp (assertions) and
// bench/discrepancy.cpp (confusion matrix, gap shrink).
// Strong magnitudes are ordinary for a real rig; weak ones are a third of that, where the
// excess gap over the noise is still 1-20x the noise (below that nothing can be claimed).
#ifndef SMA_HOST_HIDDEN_EFFECTS_HPP
#define SMA_HOST_HIDDEN_EFFECTS_HPP

#include <string>
#include <vector>
#include "discrepancy.hpp"
#include "signals.hpp"

namespace sma_host {

struct HiddenCase {
  std::string label;
  std::vector<std::string> hidden;  // names, in no particular order
  sma::Effects effects;
  bool ramp;  // excitation: the decaying ramp, else voltage steps
};

inline std::vector<HiddenCase> hidden_effect_cases() {
  // A strong value of each parameter of the vocabulary (above its identity value: gain 1, else 0).
  using R = sma::param::Row;
  const struct {
    R row;
    double strong;
  } strong[] = {
      {R::delay_s, 0.3}, {R::tau_s, 0.8}, {R::gain, 0.2}, {R::offset_mm, -0.05}, {R::offset_K, 6.0},
      {R::beta_per_K, 0.01}, {R::k_R, 0.2}, {R::L_J, 3.0},
      {R::alpha_per_K, 1.1e-5},  // NiTi austenite, ~1.1e-5/K: on the paper's 0.14 m wire 0.15 mm at 130 degC
  };
  auto strong_of = [&strong](R r) {
    for (const auto& s : strong)
      if (s.row == r) return s.strong;
    throw Error("hidden_effect_cases: no strong value for a parameter of the vocabulary");
  };
  std::vector<HiddenCase> cases;
  for (int ramp = 0; ramp < 2; ++ramp) {
    const std::string ex = ramp ? "ramp" : "steps";
    cases.push_back({ex + " / none", {}, sma::Effects(), ramp != 0});
    for (const EffectSpec& e : vocabulary())
      for (int is_strong = 0; is_strong < 2; ++is_strong) {
        const double k = is_strong ? 1.0 : 1.0 / 3.0;
        sma::Effects fx;
        for (int i = 0; i < e.n; ++i) e.at(fx, i) += k * strong_of(e.row[i]);
        cases.push_back({ex + " / " + e.name + (is_strong ? " strong" : " weak"), {e.name}, fx, ramp != 0});
      }
    sma::Effects a;
    a.sensor_delay_s = 0.3;
    a.ambient_offset_K = 4.0;
    cases.push_back({ex + " / sensor_delay + ambient_offset", {"sensor_delay", "ambient_offset"}, a, ramp != 0});
    sma::Effects b;
    b.latent_heat_J = 2.0;
    b.convection_beta_per_K = 0.005;
    cases.push_back({ex + " / latent_heat + convection_nonlinear", {"latent_heat", "convection_nonlinear"}, b,
                     ramp != 0});
  }
  return cases;
}

// The log of a case: the plant with the hidden effects, 2 um noise, a fixed seed per case.
inline RigLog hidden_effect_log(const HiddenCase& c, const sma::Params& p, uint64_t seed) {
  TrainingSignal tr;  // the paper's shape, shortened to ~5 min: 8.5x its slope, 5 peaks, no probe
  tr.plan.slope = 0.05;
  tr.peaks = {1.60, 1.42, 1.36, 1.31, 1.26};
  tr.plan.hold_s = 5.0;
  tr.probes.clear();
  return simulate_log(p, c.effects, c.ramp ? tr.sample() : default_steps(), 0.002, seed);
}

// Excess of an RMS over white noise of level sigma: what a model could still explain.
inline double excess_gap(double rms, double sigma) { return sqrt(fmax(rms * rms - sigma * sigma, 0.0)); }

}  // namespace sma_host

#endif  // SMA_HOST_HIDDEN_EFFECTS_HPP
