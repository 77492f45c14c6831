// Scalar types and the little math the model needs, for float, double and sma::Fixed.
//
// Every model template is written against this header only: it calls sma::cos, sma::acos,
// sma::sqrt, sma::abs, sma::is_finite, sma::clamp, sma::min, sma::max and builds constants
// with an explicit conversion `T(0.5)`. A new scalar type becomes usable by providing those
// overloads in namespace sma (see fixed.hpp for the fixed-point one).
//
// No STL: avr-gcc 5.4 ships no C++ standard headers, so <math.h> and <stdint.h> only.
#ifndef SMA_SCALAR_HPP
#define SMA_SCALAR_HPP

#include <math.h>
#include <stdint.h>

namespace sma {

// pi to double precision; on AVR `double` is a 32-bit float and this rounds accordingly.
constexpr double kPi = 3.14159265358979323846;

// ---- float / double overloads -------------------------------------------------------------
// On AVR `double` is float, so the float overloads simply call the double functions.
inline float cos(float x) { return static_cast<float>(::cos(x)); }
inline float acos(float x) { return static_cast<float>(::acos(x)); }
inline float sqrt(float x) { return static_cast<float>(::sqrt(x)); }
inline float sin(float x) { return static_cast<float>(::sin(x)); }
inline float exp(float x) { return static_cast<float>(::exp(x)); }
// On the AVR the exponent test inline (avr-libc's isfinite is a call, ~50 cycles with its
// register moves, and the tick asks ~8 times); on the Uno one copy out of line (-28 B of its
// flash, a few cycles a call; the Mega's room is cycles, the preview's plan passes).
#if defined(__AVR_ATmega328P__)
__attribute__((noinline))
#endif
inline bool is_finite(float x) {
#if defined(__AVR__)
  uint32_t b;
  __builtin_memcpy(&b, &x, 4);
  return (static_cast<uint16_t>(b >> 16) & 0x7F80u) != 0x7F80u;
#else
  return isfinite(x) != 0;
#endif
}
#if !defined(__AVR__)
// Host: double is a distinct 64-bit type.
inline double cos(double x) { return ::cos(x); }
inline double acos(double x) { return ::acos(x); }
inline double sqrt(double x) { return ::sqrt(x); }
inline double sin(double x) { return ::sin(x); }
inline double exp(double x) { return ::exp(x); }
inline bool is_finite(double x) { return isfinite(x) != 0; }
#endif

// exp(-x) in float without avr-libc's exp (which pulls in modf, ldexp and a series: ~450 B of
// the Uno's flash), in ~100 B: halve x n times down to <= 1/32, exp(-x) there by its degree-4
// Taylor polynomial (truncation < 3e-10), then square n times. Squaring doubles the relative
// error each time: ~1e-6 at x = 1, plenty for the decay factors below (tested against double);
// a large x underflows to 0; NaN stays NaN; x < 0 gives 1 / exp(x).
inline float exp_neg_compact(float x) {
  if (x != x) return x;
  if (x < 0.0f) return 1.0f / exp_neg_compact(-x);
  uint8_t n = 0;
  while (x > 0.03125f && n < 60) {
    x *= 0.5f;
    ++n;
  }
  float y = 1.0f - x * (1.0f - x * (0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f))));
  while (n-- > 0) y *= y;
  return y;
}

// exp(-x) for the per-tick decay factors the constructors compute once (exp(-dt / tau): thermal
// discretisation, filters). Host: libm in double; AVR: exp_neg_compact, the flash it saves is what
// keeps every feature in one Uno image.
inline double decay_factor(double x) {
#if defined(__AVR__)
  return static_cast<double>(exp_neg_compact(static_cast<float>(x)));
#else
  return ::exp(-x);
#endif
}

template <class T> constexpr T abs(T x) { return x < T(0) ? -x : x; }
template <class T> constexpr T min(T a, T b) { return b < a ? b : a; }
template <class T> constexpr T max(T a, T b) { return a < b ? b : a; }
// clamp(x, lo, hi); a NaN x compares false everywhere and is mapped to lo, the safe side
// for every quantity the model clamps (voltage, fractions).
template <class T> constexpr T clamp(T x, T lo, T hi) {
  return (x > lo) ? ((x < hi) ? x : hi) : lo;
}

#if defined(__AVR_ATmega328P__)
// float on the Uno: one copy out of line (inline, each clamp is two soft-float compares with the
// moves of three floats around them): -94 B of its flash, the same result. Not on the Mega,
// whose room is cycles: the preview's plan passes between ticks.
__attribute__((noinline)) inline float clamp(float x, float lo, float hi) { return (x > lo) ? ((x < hi) ? x : hi) : lo; }
#endif

// clamp(x, 0, 1): the range of a fraction or a normalised argument (NaN -> 0, as clamp).
template <class T> inline T clamp01(T x) { return clamp(x, T(0), T(1)); }

// A float's bit pattern. Non-negative floats (not NaN) are ordered as their bits.
inline uint32_t float_bits(float x) {
  uint32_t b;
  __builtin_memcpy(&b, &x, 4);
  return b;
}
// float: clamp(x, 0.0f, 1.0f) on the bit pattern, the same result for every input (-0 and NaN
// give +0, +inf 1): integer compares instead of two soft-float compares (~100 AVR cycles; the
// tick clamps ~5 fractions). Out of line: one copy instead of six (Uno: -250 B of flash for
// ~150 cycles of the control section's worst tick).
__attribute__((noinline)) inline float clamp01(float x) {
  const int32_t b = static_cast<int32_t>(float_bits(x));
  if (b <= 0 || b > 0x7F800000L) return 0.0f;  // negative, zero or NaN
  if (b >= 0x3F800000L) return 1.0f;           // 1 or above (+inf)
  return x;
}

// Sign and magnitude tests of a number that is not NaN: x > 0, x < 0, |x| < limit (limit >= 0).
template <class T> inline bool positive(T x) { return x > T(0); }
template <class T> inline bool negative(T x) { return x < T(0); }
template <class T> inline bool abs_below(T x, T limit) { return abs(x) < limit; }
// float: on the bit pattern (the sign bit; magnitudes ordered as their bits), no soft-float
// compare (~45 AVR cycles each).
inline bool positive(float x) { return static_cast<int32_t>(float_bits(x)) > 0; }
inline bool negative(float x) { return float_bits(x) > 0x80000000u; }
inline bool abs_below(float x, float limit) { return (float_bits(x) & 0x7FFFFFFFu) < float_bits(limit); }
// a > b for two numbers that are not negative (nor NaN): positions on the stroke. float: on the
// bit patterns, no soft-float compare.
template <class T> inline bool above(T a, T b) { return a > b; }
inline bool above(float a, float b) { return float_bits(a) > float_bits(b); }

// Conversions at the boundary (parameters, telemetry). `T(x)` for built-in types.
template <class T> inline T from_double(double x) { return static_cast<T>(x); }
template <class T> inline double to_double(T x) { return static_cast<double>(x); }

// The board's integers into the control path's scalar (fixed.hpp has the Q16.16 versions, all
// integer): the tick's numbers start and end as integers (ADC counts, ticks, PWM counts).
// n / d, d > 0: the mean of a tick's ADC samples (sum n of d samples).
template <class T> inline T ratio(uint32_t n, uint8_t d) { return static_cast<T>(n) / static_cast<T>(d); }
// sqrt(x) for x > 0 where a constant must fold at compile time (Newton's iteration from 1).
constexpr double sqrt_constexpr(double x, double r = 1.0, int n = 0) {
  return n == 40 ? r : sqrt_constexpr(x, 0.5 * (r + x / r), n + 1);
}
// The mean of d 10-bit ADC samples (sum n) in volts: n / d volts_per_count, volts_per_count =
// vref / 1024 (fixed.hpp's Q16.16 divides by 1024 d instead and scales by vref).
template <class T> inline T adc_volts(uint32_t n, uint8_t d, T volts_per_count, T /*vref*/) {
  return ratio<T>(n, d) * volts_per_count;
}
// x / 2^31 for x <= 2^31: a phase in Q1.31 (ReferenceGen's sine).
template <class T> inline T from_q31(uint32_t x) { return static_cast<T>(static_cast<double>(x) * (1.0 / 2147483648.0)); }
// floor(x) for 0 <= x < 65536 (PWM counts).
inline uint16_t floor_u16(float x) { return static_cast<uint16_t>(x); }
#if !defined(__AVR__)
inline uint16_t floor_u16(double x) { return static_cast<uint16_t>(x); }
#endif

// ---- the two shapes of the Liang-Rogers model, on a normalised argument ---------------------
// cos_ramp(x) = 0.5 [1 - cos(pi x)], x clamped to [0, 1]: the shape of eqs 2, 3 and 11.
template <class T> inline T cos_ramp(T x) {
  x = clamp01(x);
  return T(0.5) * (T(1) - cos(x * T(kPi)));
}
// cos_ramp_inv(y) = acos(1 - 2y) / pi, y clamped to [0, 1]: the shape of eqs 15 and 16.
template <class T> inline T cos_ramp_inv(T y) {
  y = clamp01(y);
  return acos(T(1) - T(2) * y) * T(1.0 / kPi);
}

// float: cos_ramp(h) = (1 - cos(pi h)) / 2 = u p(u), u = h^2, on h <= 1/2 with p a cubic
// (least-squares minimax fit): |error| <= 3e-8, below float's rounding of the result (6e-8);
// the symmetry cos_ramp(1 - h) = 1 - cos_ramp(h) covers the other half. ~1000 AVR cycles
// instead of ~2300 for avr-libc's cos (range reduction, its own series).
inline float cos_ramp(float x) {
  x = clamp01(x);
  const bool upper = float_bits(x) > 0x3F000000u;  // x > 1/2 (x in 0..1: ordered as its bits)
  const float h = upper ? 1.0f - x : x;  // 0..1/2
  const float u = h * h;
  const float r = (((-0.1100413364f * u + 0.6660473648f) * u - 2.0292257255f) * u + 2.4673977610f) * u;
  return upper ? 1.0f - r : r;
}

// float: cos_ramp_inv(h) = acos(1 - 2h) / pi = sqrt(h) q(h) on h <= 1/2, q a degree-5 polynomial
// (a minimax fit of acos(1 - 2h) / (pi sqrt(h)), weighted for the absolute error of the result):
// |error| <= 3e-7 against double (test_hysteresis), i.e. 5 uK on a 18 K transformation band,
// about the float rounding of a temperature near 60 degC (4 uK). The odd symmetry
// cos_ramp_inv(1 - y) = 1 - cos_ramp_inv(y) covers the other half. Polynomial in h itself: no
// x = 1 - 2h to form (the A&S 4.4.45 form in x costs a multiply and a subtraction more);
// avr-libc's acos (range reduction, its own sqrt and series) costs ~1300 cycles more.
inline float cos_ramp_inv(float y) {
  y = clamp01(y);
  const bool upper = float_bits(y) > 0x3F000000u;  // y > 1/2 (y in 0..1: ordered as its bits)
  const float h = upper ? 1.0f - y : y;  // 0..1/2
  const float q = ((((0.070745249150f * h - 0.028347137647f) * h + 0.045227005299f) * h +
                    0.045012260736f) * h + 0.10628955834f) * h + 0.63661618129f;
  const float r = sqrt(h) * q;
  return upper ? 1.0f - r : r;
}

}  // namespace sma

#endif  // SMA_SCALAR_HPP
