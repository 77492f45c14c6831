// The paper's training signal (section III.B, Fig. 4), one definition for the firmware's
// built-in training run and the host tools: a slow voltage ramp up and down at +-slope whose
// peaks decay from cycle to cycle, so that the wire runs the major loop and then minor loops of
// decreasing peak temperature, each cooled back to martensite; then an optional step probe.
//
// Default peaks: 2.0 V first (a full transformation even for a wire that loses 50 % more heat
// than the paper's: eq 10 with eps_h ~ 1), then a dense decaying series 1.6 .. 1.2 V whose peak
// temperatures cover T_s..T_f of wires around the paper's (minor loops, eqs 5-9) and fall just
// below T_s (eq 10 with a small eps_h, which separates q from e). Each descent goes down to
// `floor_V` and holds there so the wire is martensite again. Measured on a simulated wire
// (tools/tests/test_fit.py): 12 peaks leave the minor-loop parameters well enough fixed that a
// closed-loop sine the fit never saw is predicted to the noise level; 7 peaks (one hour less)
// leave ~4x the noise. The probe, a staircase of voltage holds after the ramps (each probe_s
// long, then off), excites the thermal time constant at several temperatures, which a
// quasi-static ramp barely shows: without any step h and the transformation temperatures slide
// together (errors up to 0.6 K / 0.9 % instead of 0.1 K / 0.2 %), and with a single step a heat
// loss that is not linear in the temperature rise (convection_nonlinear) is absorbed into h,
// T_AS and T_AF. Holds up and down at several levels inside the band give the steady states and
// the time constants at several temperatures that separate them (tools/vrig/e2e_flow.py).
// No STL, no heap: evaluated point by point (AVR) or sampled (host, sma_host/signals.hpp).
#ifndef SMA_TRAINING_HPP
#define SMA_TRAINING_HPP

#include <stdint.h>
#include "scalar.hpp"
#include "trunc_u32.hpp"

namespace sma {

constexpr uint8_t kMaxTrainingPeaks = 12;
constexpr uint8_t kMaxTrainingProbes = 8;

struct TrainingPlan {
  // (Spelled out: avr-gcc 5.4 cannot evaluate the implicit one in a constant expression.)
  constexpr TrainingPlan() {}
  double slope = 5.88e-3;  // V/s, both directions (paper)
  double peaks[kMaxTrainingPeaks] = {2.0, 1.6, 1.55, 1.5, 1.46, 1.42, 1.39, 1.36, 1.33, 1.3, 1.25, 1.2};
  uint8_t n_peaks = 12;
  double floor_V = 0.0;
  double hold_s = 20.0;   // at the floor after each descent (and at the start)
  // The probe: holds at these voltages in turn, probe_s each, then probe_s off. Up and down
  // through the band (1.0..1.5 V for wires near the paper's) and once above it (1.7 V).
  double probes[kMaxTrainingProbes] = {1.2, 1.35, 1.5, 1.3, 1.7, 1.0, 0.6, 1.4};
  uint8_t n_probes = 8;   // 0: no probe
  double probe_s = 20.0;

  // nullptr if the plan can be played, else the problem.
  const char* check() const {
    if (!(slope > 0.0 && slope < 10.0)) return "slope must be in 0..10 V/s";
    if (n_peaks > kMaxTrainingPeaks) return "too many peaks";
    if (n_probes > kMaxTrainingProbes) return "too many probe levels";
    if (!(floor_V >= 0.0 && hold_s >= 0.0 && probe_s >= 0.0)) return "negative time or voltage";
    for (uint8_t k = 0; k < n_peaks; ++k)
      if (!(peaks[k] > floor_V && peaks[k] <= 5.0)) return "every peak must be above the floor, at most 5 V";
    for (uint8_t k = 0; k < n_probes; ++k)
      if (!(probes[k] >= 0.0 && probes[k] <= 5.0)) return "every probe level must be in 0..5 V";
    return nullptr;
  }

  // Length of the rise to peak k (the descent is as long), given 1 / slope.
  double rise_s(uint8_t k, double inv_slope) const { return (peaks[k] - floor_V) * inv_slope; }
  // Length of one ramp cycle for peak k (up, down, hold).
  double cycle_s(uint8_t k) const { return 2.0 * rise_s(k, 1.0 / slope) + hold_s; }

  // The ramps' total is hold + sum over the peaks of (2 (peak - floor) / slope + hold): one
  // division, not one per peak. In two parts that do not depend on the slope, so that a board
  // playing its built-in plan at another slope folds both at compile time (Board::start_training).
  double duration() const { return holds_s() + 2.0 * ramp_V() / slope; }
  // The volts the ramps climb (the sum of peak - floor): 2 ramp_V() / slope seconds of ramps.
  constexpr double ramp_V() const {
    double rise = 0.0;
    for (uint8_t k = 0; k < n_peaks; ++k) rise += peaks[k] - floor_V;
    return rise;
  }
  // The seconds that do not ramp: the holds at the floor and the probe (its holds, then off).
  constexpr double holds_s() const {
    return (n_peaks + 1) * hold_s + (n_probes > 0 ? (n_probes + 1) * probe_s : 0.0);
  }

  // Where a player of the plan is: cycle k (peak k's rise, descent and hold) starts t0 seconds
  // after the first hold.
  struct Cursor {
    uint8_t k = 0;
    double t0 = 0.0;
  };
  // The voltage at t seconds from the start (0 after the end).
  double voltage_at(double t) const {
    Cursor c;
    return voltage_at(t, c);
  }
  // The same, starting from the cycle `c` names and moving it to the cycle that holds t: a
  // caller that keeps it while t only grows (the firmware, a tick at a time) walks each cycle
  // once instead of every cycle before t at every call (~1 k AVR cycles a cycle). A t before
  // the cursor's cycle walks again from the first.
  double voltage_at(double t, Cursor& c) const {
    if (!(t >= hold_s)) return floor_V;  // the first hold (and t < 0, NaN: hold_s >= 0)
    const double ramps = t - hold_s;
    t = ramps - c.t0;
    uint8_t k = c.k;
    if (t < 0.0) {
      k = 0;
      t = ramps;
    }
    // One division per call, not two per peak (~500 AVR cycles a division).
    const double inv_slope = 1.0 / slope;
    for (; k < n_peaks; ++k) {
      const double rise = rise_s(k, inv_slope);
      if (t < rise) return floor_V + slope * t;
      t -= rise;  // now from the peak
      if (t < rise) return peaks[k] - slope * t;
      t -= rise + hold_s;  // the rest of cycle_s(k)
      if (t < 0.0) return floor_V;
      c.k = static_cast<uint8_t>(k + 1);
      c.t0 = ramps - t;
    }
    // (t >= 0 here.)
    if (t < n_probes * probe_s) {
      const uint8_t i = static_cast<uint8_t>(trunc_u32(t / probe_s));
      return probes[i < n_probes ? i : n_probes - 1];  // (i == n_probes only by rounding)
    }
    return 0.0;
  }
};

}  // namespace sma

#endif  // SMA_TRAINING_HPP
