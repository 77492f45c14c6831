// Model parameters: the paper's Table II as defaults, stored as plain numbers (SI units,
// temperatures in deg C, g in mm), validated before any model is built from them.
//
// Parameters are not templated on the scalar type: d0 = 5e-4 m would not even be
// representable in Q16.16. Models convert the *derived* quantities (C_th, G, 1/width, ...)
// to their scalar type once, in their constructors.
#ifndef SMA_PARAMS_HPP
#define SMA_PARAMS_HPP

#include <stdint.h>
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

  // nullptr when the set is physical, else a message that starts with the offending key.
  // Written as a chain of plain checks so the firmware can report it over serial as is.
  const char* check() const;
};

// True for a finite number strictly greater than zero.
inline bool positive(double x) { return is_finite(x) && x > 0.0; }

inline const char* Params::check() const {
  if (!positive(rho)) return "rho must be > 0";
  if (!positive(c)) return "c must be > 0";
  if (!positive(h)) return "h must be > 0";
  if (!positive(d0)) return "d0 must be > 0";
  if (!positive(L0)) return "L0 must be > 0";
  if (!positive(R)) return "R must be > 0";
  if (!is_finite(T_amb) || T_amb < -50.0 || T_amb > 100.0) return "T_amb must be in -50..100";
  if (!is_finite(T_AS) || !is_finite(T_AF) || !(T_AF > T_AS)) return "T_AF must be > T_AS";
  if (!is_finite(T_MS) || !is_finite(T_MF) || !(T_MS > T_MF)) return "T_MS must be > T_MF";
  if (!is_finite(T_s) || !is_finite(T_f) || !(T_f > T_s)) return "T_f must be > T_s";
  if (!is_finite(T_MSs) || !is_finite(T_MSf)) return "T_MSs must be finite";
  for (uint8_t k = 0; k < 6; ++k)
    if (!is_finite(m[k])) return "m must be finite";
  if (!is_finite(q) || !is_finite(e)) return "q must be finite";
  if (!positive(g)) return "g must be > 0";
  if (n_loops > kMaxLoopKnots) return "loops: too many";
  double prev = T_s;
  for (uint8_t k = 0; k < n_loops; ++k) {
    const LoopKnot& L = loops[k];
    if (!is_finite(L.T_i) || !(L.T_i > prev) || !(L.T_i < T_f))
      return "loops: T_i must increase strictly inside (T_s, T_f)";
    if (!is_finite(L.T_ii) || L.T_ii > L.T_i) return "loops: T_ii must be <= T_i";
    if (!is_finite(L.j) || L.j < 0.0 || L.j > 1.0) return "loops: j must be in 0..1";
    prev = L.T_i;
  }
  return nullptr;
}

}  // namespace sma

#endif  // SMA_PARAMS_HPP
