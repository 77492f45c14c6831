// The models' derived constants, computed from the Params in double (float on the AVR) and
// converted to the model's scalar once, in their constructors (params.hpp: d0 = 5e-4 m is not
// even representable in Q16.16). The patterns that recur across the constructors are functions
// here, out of line on the AVR: one copy of the soft-float call sequence and the conversion
// instead of one per constant (the Uno's flash). The same operations in the same order as
// written inline, so the values are the same bits.
#ifndef SMA_DERIVED_HPP
#define SMA_DERIVED_HPP

#include "fixed.hpp"
#include "scalar.hpp"

#if defined(__AVR__)
#define SMA_DERIVED_OUT_OF_LINE __attribute__((noinline))
#else
#define SMA_DERIVED_OUT_OF_LINE
#endif

namespace sma {

// 1 / x as the model's scalar: the reciprocals that let the tick multiply instead of divide.
template <class T>
SMA_DERIVED_OUT_OF_LINE T reciprocal_as(double x) {
  return from_double<T>(1.0 / x);
}

// 1 - exp(-dt / tau) as the model's scalar: the gain of a first-order low-pass with time
// constant tau sampled every dt (y += gain (x - y)).
template <class T>
SMA_DERIVED_OUT_OF_LINE T low_pass_gain_as(double dt, double tau) {
  return from_double<T>(1.0 - decay_factor(dt / tau));
}

// A stored number (a Params, Effects or config field) as the model's scalar. Q16.16 on the
// AVR: out of line, by reference, so that a call site passes the field's address instead of
// loading its four bytes (the conversion is a call there anyway).
template <class T>
inline T from_field(const double& x) {
  return from_double<T>(x);
}
#if defined(__AVR__)
template <>
__attribute__((noinline)) inline Fixed from_field<Fixed>(const double& x) {
  return from_double<Fixed>(x);
}
#endif

// A decay factor a = exp(-dt / tau) as the scalar, and 1 - a of that scalar's a, exact (the
// thermal step's b is built from it: ThermalStep). In Q16.16 1 - a (~0.0024) is ~160 raw
// steps: a float's 1 - a, rounded apart from a, would differ from the scalar's by up to 0.3 %.
// (Q16.16: from the low-pass gain 1 - a, the helper the filters already call: flash on the Uno.)
template <class T>
inline T decay_as(double dt, double tau, double& one_minus_a) {
  const T a = from_double<T>(decay_factor(dt / tau));
  one_minus_a = 1.0 - to_double(a);  // exact: a in [0.5, 1] (Sterbenz)
  return a;
}
template <>
inline Fixed decay_as<Fixed>(double dt, double tau, double& one_minus_a) {
  const Fixed k = low_pass_gain_as<Fixed>(dt, tau);
  one_minus_a = static_cast<double>(k);
  return Fixed::from_raw(65536L - k.raw());
}

// a != 0 || b != 0 || c != 0 for floats (NaN is not 0), by one test of the three bit patterns
// without their signs: +-0 are the only floats equal to 0.
inline bool any_nonzero_float(float a, float b, float c) {
  return ((float_bits(a) | float_bits(b) | float_bits(c)) & 0x7FFFFFFFu) != 0;
}
// Which effects are on. AVR (double is float): the bit test instead of three soft-float compares.
inline bool any_nonzero(double a, double b, double c) {
#if defined(__AVR__)
  return any_nonzero_float(a, b, c);
#else
  return a != 0.0 || b != 0.0 || c != 0.0;
#endif
}

}  // namespace sma

#endif  // SMA_DERIVED_HPP
