// Mechanics (eq 12) and its inverse (eq 14): displacement D = g eps, with g in mm.
#ifndef SMA_MECHANICS_HPP
#define SMA_MECHANICS_HPP

#include "params.hpp"
#include "scalar.hpp"

namespace sma {

template <class T>
struct Mechanics {
  T g;      // stroke of a full transformation, mm
  T inv_g;  // 1 / g

  explicit Mechanics(const Params& p)
      : g(from_double<T>(p.g)), inv_g(from_double<T>(1.0 / p.g)) {}

  T displacement(T eps) const { return g * eps; }  // eq 12
  // Eq 14, clamped to the physical range 0..1 (a NaN displacement maps to 0).
  T fraction(T D) const { return clamp(D * inv_g, T(0), T(1)); }
};

}  // namespace sma

#endif  // SMA_MECHANICS_HPP
