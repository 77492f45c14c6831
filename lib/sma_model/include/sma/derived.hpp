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
