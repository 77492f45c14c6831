// Mechanics (eq 12) and its inverse (eq 14): displacement D = g eps, with g in mm, plus the
// thermal expansion of the wire (effects.hpp): a hot wire is longer by alpha L0 (T - T_a), so
//
//   D = g eps - k (T - T_a),   k = 1000 alpha L0 mm/K,   T_a the true ambient.
//
// A 1 m NiTi wire (alpha ~ 1e-5/K) moves ~0.01 mm per kelvin: 0.6 mm for 60 K of heating past
// the end of the transformation, visible on a 16 mm stroke. With alpha = 0 this is eq 12.
#ifndef SMA_MECHANICS_HPP
#define SMA_MECHANICS_HPP

#include "derived.hpp"
#include "effects.hpp"
#include "params.hpp"
#include "scalar.hpp"

namespace sma {

// The temperature term of eq 12: how much longer the wire is than at ambient, in mm. Compiled
// out on the firmware unless SMA_THERMAL_EXPANSION=1 (effects.hpp): an empty base then, so the
// mechanics of the controller and the inverse keep their size.
template <class T, bool kOn = kThermalExpansion>
struct Expansion {
  T k;           // mm per kelvin of the wire above ambient: 1000 alpha L0
  T T_a;         // true ambient, deg C
  bool expands;  // alpha != 0: lets the tick skip the term

  Expansion(const Params& p, const Effects& fx)
      : k(from_double<T>(1000.0 * fx.thermal_expansion_per_K * p.L0)),
        T_a(from_double<T>(fx.ambient_C(p.T_amb))),
        expands(fx.thermal_expansion_per_K != 0.0) {}
  T lengthening(T Tw) const { return k * (Tw - T_a); }
};

template <class T>
struct Expansion<T, false> {
  static constexpr bool expands = false;
  Expansion(const Params&, const Effects&) {}
  T lengthening(T) const { return T(0); }
};

template <class T>
struct Mechanics : Expansion<T> {
  T g;      // stroke of a full transformation, mm
  T inv_g;  // 1 / g

  explicit Mechanics(const Params& p, const Effects& fx = Effects())
      : Expansion<T>(p, fx), g(from_field<T>(p.g)), inv_g(reciprocal_as<T>(p.g)) {}

  T displacement(T eps) const { return g * eps; }  // eq 12, wire at ambient
  // Eq 12 for a wire at temperature Tw.
  T displacement(T eps, T Tw) const { return this->expands ? g * eps - this->lengthening(Tw) : g * eps; }
  // Eq 14, clamped to the physical range 0..1 (a NaN displacement maps to 0).
  T fraction(T D) const { return clamp01(D * inv_g); }
  // Eq 14 for a wire at temperature Tw: the lengthening added back before dividing by g.
  T fraction(T D, T Tw) const { return this->expands ? fraction(D + this->lengthening(Tw)) : fraction(D); }
};

}  // namespace sma

#endif  // SMA_MECHANICS_HPP
