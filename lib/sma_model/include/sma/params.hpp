// Model parameters: the paper's Table II as defaults, stored as plain numbers (SI units,
// temperatures in deg C, g in mm), validated before any model is built from them.
//
// Parameters are not templated on the scalar type: d0 = 5e-4 m would not even be
// representable in Q16.16. Models convert the *derived* quantities (C_th, G, 1/width, ...)
// to their scalar type once, in their constructors.
#ifndef SMA_PARAMS_HPP
#define SMA_PARAMS_HPP

#include <stdint.h>
#include "param_table.hpp"
#include "scalar.hpp"

namespace sma {

// One identified minor loop (Table II): peak T_i, end of the rise T_ii, rise j.
struct LoopKnot {
  double T_i;
  double T_ii;
  double j;
};

constexpr uint8_t kMaxLoopKnots = 8;

// Which reading of a re-heat the loop memory runs (hysteresis.hpp; model.md marks the loop
// rules as choices). A model-structure choice the identification makes from a log on the host;
// the firmware runs return_point only (the field is compiled out on AVR: no RAM, no flash)
// unless built with SMA_REHEAT_READINGS=1.
#ifndef SMA_REHEAT_READINGS
#if defined(__AVR__)
#define SMA_REHEAT_READINGS 0
#else
#define SMA_REHEAT_READINGS 1
#endif
#endif
constexpr bool kReheatReadings = SMA_REHEAT_READINGS != 0;

enum class Reheat : uint8_t {
  return_point = 0,  // a re-heat that transformed nothing keeps the interrupted loop
  new_loop = 1,      // every heating -> cooling reversal opens a loop at its peak (eqs 7-10)
};

struct Params {
  // Thermal (eq 1) and wire geometry.
  double rho = 6500.0;   // kg/m^3
  double c = 836.8;      // J/(kg K)
  double h = 165.0;      // W/(m^2 K)
  double d0 = 0.5e-3;    // m
  double L0 = 0.140;     // m
  double R = 1.0;        // ohm
  double T_amb = 22.0;   // deg C
  // Major loop (eqs 2, 3).
  double T_AS = 50.2, T_AF = 80.1, T_MS = 28.0, T_MF = 22.0;
  // Minor loops (eqs 7-10).
  double T_s = 60.8, T_f = 75.9, T_MSs = 51.1, T_MSf = 28.9;
  double m[6] = {1.0000, -4.8334, 10.2425, -8.6475, 0.0, 2.2385};  // m0..m5 (eq 8)
  double q = -32.6936, e = 60.4657;                                 // eq 10
  // Mechanics (eq 12).
  double g = 0.958;  // mm
  // Identified loops between T_s and T_f (Table II, loops 2-4).
  LoopKnot loops[kMaxLoopKnots] = {{63.1, 61.2, 0.16}, {68.5, 59.1, 0.19}, {71.5, 65.2, 0.10}};
  uint8_t n_loops = 3;
#if SMA_REHEAT_READINGS
  Reheat reheat = Reheat::return_point;  // params JSON key "reheat"
#endif

  // Derived thermal constants (eq 1).
  double heat_capacity() const { return rho * c * kPi * d0 * d0 * L0 / 4.0; }  // C_th, J/K
  double conductance() const { return kPi * d0 * L0 * h; }                     // G, W/K

  // The first rule of the parameter table the set breaks (param_table.hpp; ok() when physical):
  // its flat key and the rule, param::put_violation() writes the message.
  param::Violation check() const;
};

}  // namespace sma

#include "param_table_access.hpp"  // Params::check()

#endif  // SMA_PARAMS_HPP
