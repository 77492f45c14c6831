// Effects the paper's model leaves out (model.md, "known to be incomplete"), with the names of
// the vocabulary in interfaces.md. All zero / identity by default = the paper's model.
//
// The thermal ones enter eq 1 and its inverse eq 17 (thermal.hpp); thermal expansion enters
// eq 12 and its inverse eq 14 (mechanics.hpp); the sensor ones act on the measured displacement
// (plant.hpp on the host; the firmware can compensate them). Defined once
// here so the plant, the model, the identification and the firmware agree on their meaning.
#ifndef SMA_EFFECTS_HPP
#define SMA_EFFECTS_HPP

// The Uno's flash is full (34 B free before thermal_expansion, +0.4 KB with it): firmware builds
// leave that effect out (the field stays, the model ignores it) unless SMA_THERMAL_EXPANSION=1;
// the host (plant, tools, tests) always has it.
#ifndef SMA_THERMAL_EXPANSION
#if defined(__AVR__)
#define SMA_THERMAL_EXPANSION 0
#else
#define SMA_THERMAL_EXPANSION 1
#endif
#endif

#include "derived.hpp"
#include "param_table.hpp"

namespace sma {

constexpr bool kThermalExpansion = SMA_THERMAL_EXPANSION != 0;

struct Effects {
  // sensor_delay: the measurement is the displacement delay_s seconds ago.
  double sensor_delay_s = 0.0;
  // sensor_lag: first-order low-pass of the measurement, time constant tau_s.
  double sensor_lag_s = 0.0;
  // sensor_calibration: measured = gain * D + offset_mm.
  double sensor_gain = 1.0;
  double sensor_offset_mm = 0.0;
  // ambient_offset: the true ambient is T_amb + offset_K.
  double ambient_offset_K = 0.0;
  // convection_nonlinear: loss = G (T - T_a) (1 + beta_per_K (T - T_a)).
  double convection_beta_per_K = 0.0;
  // resistance_phase: R(eps) = R (1 + k_R eps), eps the austenite fraction.
  double resistance_k = 0.0;
  // latent_heat: L_J joules absorbed by a full martensite -> austenite transformation
  // (released on the way back): C_th dT/dt gains the term - L_J d(eps)/dt.
  double latent_heat_J = 0.0;
  // thermal_expansion: the wire lengthens as it heats (linear expansion coefficient alpha,
  // 1/K): the displacement is D = g eps - 1000 alpha L0 (T - T_a) mm (eq 12 holds at ambient).
  double thermal_expansion_per_K = 0.0;

  // The wire's true ambient (ambient_offset: the air around it is T_a + offset, not the room's).
  double ambient_C(double T_amb) const { return T_amb + ambient_offset_K; }
  bool thermal_active() const { return ambient_offset_K != 0.0 || nonlinear_thermal(); }
  // Effects that make eq 1 non-linear (an ambient offset only shifts T_a).
  bool nonlinear_thermal() const {
    return any_nonzero(convection_beta_per_K, resistance_k, latent_heat_J);
  }
  // The first effect outside its range of the parameter table (param_table.hpp), or ok().
  param::Violation check() const;
};

}  // namespace sma

#include "param_table_access.hpp"  // Effects::check()

#endif  // SMA_EFFECTS_HPP
