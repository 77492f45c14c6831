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
  struct One {
    const char* name;
    double sma::Effects::*f;
    double strong;
    double sma::Effects::*f2;
    double strong2;
  };
  const One ones[] = {
      {"sensor_delay", &sma::Effects::sensor_delay_s, 0.3, nullptr, 0},
      {"sensor_lag", &sma::Effects::sensor_lag_s, 0.8, nullptr, 0},
      {"sensor_calibration", &sma::Effects::sensor_gain, 0.2, &sma::Effects::sensor_offset_mm, -0.05},
      {"ambient_offset", &sma::Effects::ambient_offset_K, 6.0, nullptr, 0},
      {"convection_nonlinear", &sma::Effects::convection_beta_per_K, 0.01, nullptr, 0},
      {"resistance_phase", &sma::Effects::resistance_k, 0.2, nullptr, 0},
      {"latent_heat", &sma::Effects::latent_heat_J, 3.0, nullptr, 0},
      // NiTi austenite, ~1.1e-5/K: on the paper's 0.14 m wire 0.15 mm at 130 degC.
      {"thermal_expansion", &sma::Effects::thermal_expansion_per_K, 1.1e-5, nullptr, 0},
  };
  std::vector<HiddenCase> cases;
  for (int ramp = 0; ramp < 2; ++ramp) {
    const std::string ex = ramp ? "ramp" : "steps";
    cases.push_back({ex + " / none", {}, sma::Effects(), ramp != 0});
    for (const One& o : ones)
      for (int strong = 0; strong < 2; ++strong) {
        const double k = strong ? 1.0 : 1.0 / 3.0;
        sma::Effects fx;
        // sensor_gain is 1 + k * 0.2; every other parameter is k * its strong value
        fx.*(o.f) = (o.f == &sma::Effects::sensor_gain ? 1.0 : 0.0) + k * o.strong;
        if (o.f2) fx.*(o.f2) = k * o.strong2;
        cases.push_back({ex + " / " + o.name + (strong ? " strong" : " weak"), {o.name}, fx, ramp != 0});
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
