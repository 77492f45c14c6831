// sma::Fixed: Q16.16 fixed point (int32_t raw value, 16 fractional bits), a drop-in for float
// in the model templates (see scalar.hpp for the contract), designed for the ATmega328P.
//
// Why a fixed-point type at all: the AVR has no FPU. A soft-float multiply costs ~134 cycles,
// cos ~1775 and acos ~2520; the Liang-Rogers model spends its time in cos/acos shapes. The
// naive Q16.16 multiply (64-bit product) costs ~250 cycles and is *slower* than float, so every
// routine here is built from 16x16->32 products, the widest product the AVR's 8x8 hardware
// multiplier gives cheaply (libgcc's __umulhisi3), and never touches 64-bit integers or floats
// on the hot path. The results are bit-identical on the host and the AVR (integer-only, all
// constants are integer literals), which is what makes host tests valid for the firmware.
//
// Range and resolution: [-32768, 32768 - 2^-16], LSB 2^-16 = 1.53e-5.
//
// Overflow policy: + - * / and the conversions SATURATE to [lowest(), max()]. Saturation is the
// safe failure mode for a controller: a wrapped result would flip the sign of a large value
// (e.g. turn a full heater command into a full negative one); a saturated one is merely
// clipped, and the controller's own clamps already expect clipping.
//
// Rounding: conversions round to nearest; * and / round to nearest with ties away from zero, so
// a*b == -((-a)*b) exactly (no sign bias in a control loop).
//
// Calling the math: cos, sin, acos, sqrt, exp, is_finite, cos_ramp and cos_ramp_inv below are
// overloads in namespace sma. The model templates must call them unqualified (ADL), or include
// this header before the template is defined; the non-template cos_ramp/cos_ramp_inv overloads
// then win over the generic templates of scalar.hpp.
//
// Header-only, C++14, no standard library (avr-gcc 5.4 has none).
#ifndef SMA_FIXED_HPP
#define SMA_FIXED_HPP

#include <stdint.h>

#include "scalar.hpp"

namespace sma {

// ---- integer helpers ------------------------------------------------------------------------
namespace fixed_detail {

constexpr int32_t kRawMax = INT32_MAX;
constexpr int32_t kRawMin = INT32_MIN;
constexpr int32_t kRawOne = INT32_C(65536);
constexpr uint32_t kHalfQ32 = UINT32_C(0x80000000);  // 0.5 in Q0.32, also |kRawMin|

constexpr int32_t saturated(bool negative) { return negative ? kRawMin : kRawMax; }

// 16x16->32 unsigned product. On the AVR this is one call to libgcc's __umulhisi3 (four MUL
// instructions, ~20 cycles); every wider product below is assembled from these.
inline uint32_t mul16(uint16_t a, uint16_t b) { return static_cast<uint32_t>(a) * b; }
constexpr uint16_t hi16(uint32_t x) { return static_cast<uint16_t>(x >> 16); }
constexpr uint16_t lo16(uint32_t x) { return static_cast<uint16_t>(x & 0xFFFFu); }

// floor(a * b / 2^16): a 32x16 product keeping the top 32 bits, exact, two partial products.
inline uint32_t mul32x16(uint32_t a, uint16_t b) {
  return mul16(hi16(a), b) + (mul16(lo16(a), b) >> 16);
}

// (a * b) >> 32 from three partial products; the lo*lo term is dropped, so the result is at most
// 2 units of 2^-32 low. Used where 32 bits of headroom are worth more than the last bit.
inline uint32_t mulhi32(uint32_t a, uint32_t b) {
  return mul16(hi16(a), hi16(b)) + (mul16(hi16(a), lo16(b)) >> 16) +
         (mul16(lo16(a), hi16(b)) >> 16);
}

// |x| as unsigned; |INT32_MIN| = 2^31 is representable.
constexpr uint32_t magnitude(int32_t x) {
  return x < 0 ? UINT32_C(0) - static_cast<uint32_t>(x) : static_cast<uint32_t>(x);
}

// Applies a sign to a magnitude and saturates: m <= 2^31 - 1 when positive, m <= 2^31 when
// negative (INT32_MIN).
inline int32_t signed_saturated(uint32_t m, bool negative) {
  if (negative) {
    return m >= kHalfQ32 ? kRawMin : -static_cast<int32_t>(m);
  }
  return m > static_cast<uint32_t>(kRawMax) ? kRawMax : static_cast<int32_t>(m);
}

// ---- conversions (constexpr so that `T(0.5)` in a template costs nothing at run time) --------
constexpr int32_t raw_from_scaled(double s) {
  // s = x * 2^16; round half away from zero, saturate, NaN -> 0.
  return (s != s) ? 0
         : (s >= 2147483647.5)  ? kRawMax
         : (s <= -2147483648.5) ? kRawMin
         : (s >= 0.0)           ? static_cast<int32_t>(s + 0.5)
                                : static_cast<int32_t>(s - 0.5);
}
constexpr int32_t raw_from_double(double x) { return raw_from_scaled(x * 65536.0); }

// Integers: saturate outside [-32768, 32767], then scale (multiply, not <<: shifting a negative
// value left is undefined in C++14).
constexpr int32_t raw_from_int32(int32_t v) {
  return v > INT32_C(32767) ? kRawMax : v < INT32_C(-32768) ? kRawMin : v * kRawOne;
}
constexpr int32_t raw_from_long(long v) {
  return v > 32767L ? kRawMax : v < -32768L ? kRawMin : raw_from_int32(static_cast<int32_t>(v));
}
constexpr int32_t raw_from_ulong(unsigned long v) {
  return v > 32767UL ? kRawMax : raw_from_int32(static_cast<int32_t>(v));
}

// ---- saturating arithmetic on raw values -----------------------------------------------------
inline int32_t add_raw(int32_t a, int32_t b) {
  int32_t s;
  // Overflow is only possible when a and b have the same sign, which is then the sign of the
  // true result.
  return __builtin_add_overflow(a, b, &s) ? saturated(a < 0) : s;
}

inline int32_t sub_raw(int32_t a, int32_t b) {
  int32_t s;
  // Overflow only when a and b have opposite signs; the true result has the sign of a.
  return __builtin_sub_overflow(a, b, &s) ? saturated(a < 0) : s;
}

// Q16.16 product without a 64-bit intermediate. On magnitudes split into 16-bit halves,
//   |a||b| / 2^16 = (ah*bh << 16) + ah*bl + al*bh + (al*bl >> 16),
// four 16x16->32 products (the AVR's cheapest wide multiply) instead of one 32x32->64 (which
// libgcc builds from sixteen 8x8 products plus 64-bit shifts). Working on magnitudes keeps every
// partial product unsigned, makes overflow a simple carry/limit test, and gives sign-symmetric
// rounding (half away from zero).
inline int32_t mul_raw(int32_t a, int32_t b) {
  const bool negative = (a < 0) != (b < 0);
  const uint32_t ua = magnitude(a);
  const uint32_t ub = magnitude(b);
  const uint16_t ah = hi16(ua), al = lo16(ua), bh = hi16(ub), bl = lo16(ub);

  const uint32_t hh = mul16(ah, bh);
  if (hh >= 0x8000u) return saturated(negative);  // |product| >= 2^15 already
  // hh << 16 <= 0x7FFF0000 and the rounded lo term <= 0xFFFF: this sum cannot carry.
  // al*bl <= 0xFFFE0001, so adding the rounding half cannot carry either.
  uint32_t acc = (hh << 16) + ((mul16(al, bl) + 0x8000u) >> 16);
  const uint32_t mid1 = mul16(ah, bl);
  const uint32_t mid2 = mul16(al, bh);
  acc += mid1;
  if (acc < mid1) return saturated(negative);  // carry out of 32 bits
  acc += mid2;
  if (acc < mid2) return saturated(negative);
  return signed_saturated(acc, negative);
}

// Q16.16 quotient (a << 16) / b without a 64-bit dividend: one 32-bit division for the integer
// part, then 17 steps of restoring long division for 16 fraction bits plus a rounding bit.
// Slower than the multiply (the model precomputes reciprocals, so division is rare) but exact.
// Division by zero saturates: +max for a >= 0, lowest for a < 0.
inline int32_t div_raw(int32_t a, int32_t b) {
  if (b == 0) return saturated(a < 0);
  const bool negative = (a < 0) != (b < 0);
  const uint32_t ua = magnitude(a);
  const uint32_t ub = magnitude(b);
  uint32_t q = ua / ub;
  uint32_t r = ua % ub;  // same libgcc call as the quotient (__udivmodsi4 returns both)
  if (q >= 0x8000u) return saturated(negative);  // |quotient| >= 2^15
  // r < ub <= 2^31, so r << 1 never overflows; q < 2^15 leaves room for 17 more bits.
  for (uint8_t i = 0; i < 17; ++i) {
    r <<= 1;
    q <<= 1;
    if (r >= ub) {
      r -= ub;
      q |= 1u;
    }
  }
  q = (q >> 1) + (q & 1u);  // round half away from zero on the magnitude
  return signed_saturated(q, negative);
}

}  // namespace fixed_detail

// ---- the type ---------------------------------------------------------------------------------
class Fixed {
 public:
  static constexpr int kFracBits = 16;

  constexpr Fixed() : raw_(0) {}
  // Rounds to nearest, saturates out of range, maps NaN to 0. On the AVR `double` is a 32-bit
  // float, so values beyond +-256 carry the float's own rounding; constants fold at compile time.
  constexpr explicit Fixed(double x) : raw_(fixed_detail::raw_from_double(x)) {}
  // Integers saturate outside [-32768, 32767]. The extra integer overloads keep `Fixed(n)`
  // unambiguous for int32_t (long on AVR), uint16_t (unsigned on AVR) and size_t.
  constexpr explicit Fixed(int v) : raw_(fixed_detail::raw_from_long(static_cast<long>(v))) {}
  constexpr explicit Fixed(long v) : raw_(fixed_detail::raw_from_long(v)) {}
  constexpr explicit Fixed(unsigned v)
      : raw_(fixed_detail::raw_from_ulong(static_cast<unsigned long>(v))) {}
  constexpr explicit Fixed(unsigned long v) : raw_(fixed_detail::raw_from_ulong(v)) {}

  static constexpr Fixed from_raw(int32_t r) { return Fixed(RawTag(), r); }
  constexpr int32_t raw() const { return raw_; }

  constexpr explicit operator double() const {
    return static_cast<double>(raw_) * (1.0 / 65536.0);
  }
  constexpr explicit operator float() const {
    return static_cast<float>(raw_) * (1.0f / 65536.0f);
  }

  static constexpr Fixed max() { return from_raw(fixed_detail::kRawMax); }
  static constexpr Fixed lowest() { return from_raw(fixed_detail::kRawMin); }
  static constexpr Fixed epsilon() { return from_raw(1); }  // one LSB, 2^-16

  Fixed& operator+=(Fixed b) {
    raw_ = fixed_detail::add_raw(raw_, b.raw_);
    return *this;
  }
  Fixed& operator-=(Fixed b) {
    raw_ = fixed_detail::sub_raw(raw_, b.raw_);
    return *this;
  }
  Fixed& operator*=(Fixed b) {
    raw_ = fixed_detail::mul_raw(raw_, b.raw_);
    return *this;
  }
  Fixed& operator/=(Fixed b) {
    raw_ = fixed_detail::div_raw(raw_, b.raw_);
    return *this;
  }

 private:
  struct RawTag {};
  constexpr Fixed(RawTag, int32_t r) : raw_(r) {}

  int32_t raw_;
};

inline Fixed operator+(Fixed a, Fixed b) { return a += b; }
inline Fixed operator-(Fixed a, Fixed b) { return a -= b; }
inline Fixed operator*(Fixed a, Fixed b) { return a *= b; }
inline Fixed operator/(Fixed a, Fixed b) { return a /= b; }
constexpr Fixed operator+(Fixed a) { return a; }
// -lowest() saturates to max(): the range is asymmetric by one LSB.
constexpr Fixed operator-(Fixed a) {
  return Fixed::from_raw(a.raw() == fixed_detail::kRawMin ? fixed_detail::kRawMax : -a.raw());
}

constexpr bool operator==(Fixed a, Fixed b) { return a.raw() == b.raw(); }
constexpr bool operator!=(Fixed a, Fixed b) { return a.raw() != b.raw(); }
constexpr bool operator<(Fixed a, Fixed b) { return a.raw() < b.raw(); }
constexpr bool operator<=(Fixed a, Fixed b) { return a.raw() <= b.raw(); }
constexpr bool operator>(Fixed a, Fixed b) { return a.raw() > b.raw(); }
constexpr bool operator>=(Fixed a, Fixed b) { return a.raw() >= b.raw(); }

template <>
inline Fixed from_double<Fixed>(double x) {
  return Fixed(x);
}

// Every Fixed is a number; overflow saturates instead of producing inf/NaN.
constexpr bool is_finite(Fixed) { return true; }

// ---- math kernels (integer-only; formats noted as Qm.n) -----------------------------------------
namespace fixed_detail {

// Haversine kernel: h = (1 - cos(pi x)) / 2 for x in [0, 0.5], given w = (2x)^2 in Q0.30
// (w30 <= 2^30). h = w * B(w) with B a degree-2 minimax fit on w in [0, 1]
// (|error of h| <= 3.9e-6). The small inner term is evaluated on 16 bits, the last two products
// use all of w30, so rounding adds ~1e-8 and h is non-decreasing in w. Returns h in Q0.30.
inline uint32_t haversine_q30(uint32_t w30) {
  // B(w) = b0 - w (b1 - w b2), b0 = 0.61677086209, b1 = 0.12634892434, b2 = 0.00958198370.
  constexpr uint32_t kB0 = UINT32_C(2649010682);  // b0 in Q0.32
  constexpr uint16_t kB1 = 33122;                 // b1 in Q0.18
  constexpr uint16_t kB2 = 40190;                 // b2 in Q0.22
  const uint16_t w15 = static_cast<uint16_t>(w30 >> 15);                       // Q1.15
  // Q15*Q22 >> 19 = Q18, rounded (truncating here would bias h by up to 3.8e-6).
  const uint16_t q18 =
      static_cast<uint16_t>(kB1 - ((mul16(w15, kB2) + (UINT32_C(1) << 18)) >> 19));
  const uint32_t b32 = kB0 - mul32x16(w30, q18);                               // Q30*Q18 >> 16
  const uint32_t h = mulhi32(w30, b32);                                        // Q30*Q32 >> 32
  constexpr uint32_t kHalf = UINT32_C(1) << 29;
  return h < kHalf ? h : kHalf;  // h <= 0.5 keeps the mirrored upper half monotone
}

// cos(2 pi p) for a phase p in turns, Q0.32 (the full circle wraps naturally in uint32).
// Folds to x in [0, 0.5] with cos(pi x) = 1 - 2 h(x); returns Q16.16 raw.
inline int32_t cos_turns_raw(uint32_t p) {
  if (p > kHalfQ32) p = UINT32_C(0) - p;      // cos(-t) = cos(t): p in [0, 1/2] turn
  const bool upper = p > (UINT32_C(1) << 30);  // past a quarter turn: cos(pi - a) = -cos(a)
  const uint32_t x31 = upper ? kHalfQ32 - p : p;         // x = p*2 in Q0.31, x31 <= 2^30
  const uint32_t x32 = x31 << 1;                          // Q0.32, <= 2^31
  const uint32_t w30 = mulhi32(x32, x32);                 // x^2 in Q0.32 = (2x)^2 in Q0.30
  const uint32_t c30 = (UINT32_C(1) << 30) - 2u * haversine_q30(w30);  // cos(pi x), Q0.30
  const int32_t c = static_cast<int32_t>((c30 + (UINT32_C(1) << 13)) >> 14);
  return upper ? -c : c;
}

// frac(|theta| / 2 pi) in turns, Q0.32, for |theta| given as a Q16.16 magnitude m:
// m * K / 2^16 mod 2^32 with K = 2^32 / 2 pi = 683565275 + 37777 / 2^16 (the fraction matters:
// without it large angles drift by up to 2.4e-5 rad). Five 16x16 products; the wrap-around of the
// uint32 sum drops exactly the whole turns. Error <= 2 units of 2^-32 turn.
inline uint32_t turns_q32(uint32_t m) {
  constexpr uint32_t kTurnsPerRad = UINT32_C(683565275);  // integer part of 2^32 / (2 pi)
  constexpr uint16_t kTurnsPerRadFrac = 37777;            // its fraction, Q0.16
  constexpr uint16_t kh = hi16(kTurnsPerRad), kl = lo16(kTurnsPerRad);
  const uint16_t mh = hi16(m), ml = lo16(m);
  return (mul16(mh, kh) << 16) + mul16(mh, kl) + mul16(ml, kh) +
         ((mul16(ml, kl) + 0x8000u) >> 16) + (mul16(mh, kTurnsPerRadFrac) >> 16);
}

// Digit-by-digit square root, rounded to nearest: returns round(sqrt(src * 4^(pairs - 16))),
// i.e. pairs = 16 gives sqrt of a 32-bit integer, pairs = 24 appends 16 zero bits (Q16.16 sqrt).
// One result bit per iteration, shifts and subtractions only; the remainder stays < 2^26.
inline uint32_t sqrt_rounded(uint32_t src, uint8_t pairs) {
  if (src == 0) return 0;
  // Skip leading zero bit pairs a byte at a time: they only cost iterations.
  if ((src >> 16) == 0) {
    src <<= 16;
    pairs = static_cast<uint8_t>(pairs - 8);
  }
  if ((src >> 24) == 0) {
    src <<= 8;
    pairs = static_cast<uint8_t>(pairs - 4);
  }
  uint32_t root = 0;
  uint32_t rem = 0;
  for (; pairs != 0; --pairs) {
    rem = (rem << 2) | static_cast<uint8_t>(static_cast<uint8_t>(src >> 24) >> 6);
    src <<= 2;
    root <<= 1;
    const uint32_t trial = (root << 1) | 1u;  // (2 root + 1): the next odd number to subtract
    if (rem >= trial) {
      rem -= trial;
      root |= 1u;
    }
  }
  // (root + 1/2)^2 < n  <=>  n - root^2 > root  (integers)
  return rem > root ? root + 1u : root;
}

// Inverse-ramp kernel: g = acos(1 - 2y) / pi = (2/pi) asin(sqrt(y)) for y in [0, 0.5], y in Q0.32
// (y32 <= 2^31). g = sqrt(y) R(y), R a minimax fit on powers {0, 1, 2, 4} of y
// (|error of g| <= 1.9e-6). All coefficients are positive and every product rounds down, so g is
// non-decreasing in y by construction (the model needs monotone inverse ramps). Returns Q0.32.
inline uint32_t ramp_inv_q32(uint32_t y32) {
  // R(y) = r0 + y (r1 + y (r2 + y^2 r4)), r0 = 0.63662460556, r1 = 0.10561080269,
  // r2 = 0.05413052369, r4 = 0.06626434138.
  constexpr uint32_t kR0 = UINT32_C(2734281861);  // r0 in Q0.32
  constexpr uint16_t kR1 = 27685;                 // r1 in Q0.18
  constexpr uint16_t kR2 = 28380;                 // r2 in Q0.19
  constexpr uint16_t kR4 = 34742;                 // r4 in Q0.19
  const uint16_t s16 = static_cast<uint16_t>(sqrt_rounded(y32, 16));  // sqrt(y), Q0.16
  const uint16_t y16 = hi16(y32);                                      // Q0.16, <= 0.5
  const uint16_t yy16 = hi16(mul16(y16, y16));                         // y^2, Q0.16
  const uint16_t t19 = static_cast<uint16_t>(kR2 + hi16(mul16(yy16, kR4)));          // Q0.19
  const uint16_t t18 = static_cast<uint16_t>(kR1 + (mul16(y16, t19) >> 17));         // Q0.18
  const uint32_t r32 = kR0 + (mul16(y16, t18) >> 2);                                 // Q0.32
  const uint32_t g = mul32x16(r32, s16);                                             // Q0.32
  return g < kHalfQ32 ? g : kHalfQ32;  // g <= 0.5 keeps the mirrored upper half monotone
}

// 2^f for f in [0, 1) given in Q0.16; returns Q2.30 (in [2^30, 2^31)). Degree-5 minimax fit,
// |error| <= 1.1e-7; inner Horner steps on 16 bits with per-step scaling, the last two on 32.
inline uint32_t exp2_frac_q30(uint16_t f16) {
  constexpr uint32_t kC0 = UINT32_C(1073741709);  // 0.99999989312 in Q2.30
  constexpr uint32_t kC1 = UINT32_C(1488538496);  // 0.69315475236 in Q1.31
  constexpr uint16_t kC2 = 31476;                 // 0.24013971157 in Q0.17
  constexpr uint16_t kC3 = 29290;                 // 0.05586624560 in Q0.19
  constexpr uint16_t kC4 = 37509;                 // 0.00894282930 in Q0.22
  constexpr uint16_t kC5 = 31817;                 // 0.00189646117 in Q0.24
  const uint16_t a4 = static_cast<uint16_t>(kC4 + (mul16(f16, kC5) >> 18));  // Q0.22
  const uint16_t a3 = static_cast<uint16_t>(kC3 + (mul16(f16, a4) >> 19));   // Q0.19
  const uint16_t a2 = static_cast<uint16_t>(kC2 + (mul16(f16, a3) >> 18));   // Q0.17
  const uint32_t a1 = kC1 + (mul16(f16, a2) >> 2);                           // Q1.31
  return kC0 + (mul32x16(a1, f16) >> 1);                                     // Q2.30
}

}  // namespace fixed_detail

// ---- math overloads found by ADL ------------------------------------------------------------

// cos(x), |error| <= 5e-5 (see test_fixed.cpp for the measured bound). Any x: the phase is
// reduced exactly in turns, so large angles only lose what the Q16.16 input already lost.
inline Fixed cos(Fixed x) {
  return Fixed::from_raw(
      fixed_detail::cos_turns_raw(fixed_detail::turns_q32(fixed_detail::magnitude(x.raw()))));
}

// sin(x) = cos(x - pi/2), computed as a quarter-turn phase shift (exact in Q0.32 turns).
inline Fixed sin(Fixed x) {
  const uint32_t p = fixed_detail::turns_q32(fixed_detail::magnitude(x.raw()));
  const int32_t s = fixed_detail::cos_turns_raw(p - (UINT32_C(1) << 30));
  return Fixed::from_raw(x.raw() < 0 ? -s : s);
}

// cos_ramp(x) = 0.5 [1 - cos(pi x)] for x clamped to [0, 1] (eqs 2, 3 and 11). Hot path: one
// haversine kernel, no range reduction. Uses the symmetry f(1 - x) = 1 - f(x) so the kernel only
// sees x <= 0.5. Non-decreasing in x (checked exhaustively by the tests).
inline Fixed cos_ramp(Fixed x) {
  using namespace fixed_detail;
  const int32_t r = x.raw();
  if (r <= 0) return Fixed(0);
  if (r >= kRawOne) return Fixed(1);
  const bool upper = r > kRawOne / 2;
  const uint16_t xm = static_cast<uint16_t>(upper ? kRawOne - r : r);  // Q0.16, <= 0.5
  // (2x)^2 in Q0.30 equals x^2 in Q0.32: the product of the Q0.16 raw values, exactly.
  const uint32_t h30 = haversine_q30(mul16(xm, xm));
  const int32_t h = static_cast<int32_t>((h30 + (UINT32_C(1) << 13)) >> 14);
  return Fixed::from_raw(upper ? kRawOne - h : h);
}

// cos_ramp_inv(y) = acos(1 - 2y) / pi for y clamped to [0, 1] (eqs 15 and 16): the inverse of
// cos_ramp. Same mirror symmetry; the kernel needs one 16-bit integer square root.
inline Fixed cos_ramp_inv(Fixed y) {
  using namespace fixed_detail;
  const int32_t r = y.raw();
  if (r <= 0) return Fixed(0);
  if (r >= kRawOne) return Fixed(1);
  const bool upper = r > kRawOne / 2;
  const uint32_t ym = static_cast<uint32_t>(upper ? kRawOne - r : r);  // Q0.16, <= 0.5
  const uint32_t g32 = ramp_inv_q32(ym << 16);
  const int32_t g = static_cast<int32_t>((g32 + 0x8000u) >> 16);
  return Fixed::from_raw(upper ? kRawOne - g : g);
}

// acos(x) for x clamped to [-1, 1], in [0, pi]: acos(x) = pi * cos_ramp_inv((1 - x) / 2), with
// (1 - |x|) / 2 formed in Q0.32 so the halving loses no bit.
inline Fixed acos(Fixed x) {
  using namespace fixed_detail;
  const int32_t r = clamp(x.raw(), -kRawOne, kRawOne);
  const uint32_t y32 = static_cast<uint32_t>(kRawOne - static_cast<int32_t>(magnitude(r))) << 15;
  const uint32_t g31 = ramp_inv_q32(y32) >> 1;         // acos(|x|) / pi, Q1.31, <= 1/2
  const uint32_t t31 = r < 0 ? kHalfQ32 - g31 : g31;  // acos(-a) = pi - acos(a)
  constexpr uint32_t kPiQ30 = UINT32_C(3373259426);    // pi in Q2.30
  const uint32_t a29 = mulhi32(t31, kPiQ30);          // Q1.31 * Q2.30 >> 32 = Q3.29
  return Fixed::from_raw(static_cast<int32_t>((a29 + (UINT32_C(1) << 12)) >> 13));
}

// sqrt(x), rounded to nearest (|error| <= 0.5 LSB); x <= 0 gives 0 (no NaN in fixed point).
inline Fixed sqrt(Fixed x) {
  if (x.raw() <= 0) return Fixed(0);
  // sqrt(r / 2^16) * 2^16 = sqrt(r * 2^16): 8 extra digit pairs past the 16 of r.
  return Fixed::from_raw(
      static_cast<int32_t>(fixed_detail::sqrt_rounded(static_cast<uint32_t>(x.raw()), 24)));
}

// exp(x) = 2^(x log2 e) = 2^k * 2^f. Accurate to a few LSB (absolute) for x <= 0, which is what
// the model uses (exp(-dt / tau)); relative error ~1e-5 above. Saturates for x > ln 32768
// (about 10.397) and returns 0 below -12 (the result is under half an LSB there).
inline Fixed exp(Fixed x) {
  using namespace fixed_detail;
  if (x.raw() < -12 * kRawOne) return Fixed(0);
  if (x.raw() > 11 * kRawOne) return Fixed::max();
  constexpr int32_t kLog2eQ16 = 94548;  // log2(e) in Q16.16
  const int32_t t = mul_raw(x.raw(), kLog2eQ16);  // |t| < 18, exact in int32
  // k = floor(t) without shifting a negative value: bias t to be non-negative first.
  const int32_t k = static_cast<int32_t>((static_cast<uint32_t>(t + 32 * kRawOne) >> 16)) - 32;
  const uint32_t p30 = exp2_frac_q30(lo16(static_cast<uint32_t>(t)));  // 2^f, Q2.30
  if (k >= 15) return Fixed::max();
  const int32_t shift = 14 - k;  // Q2.30 * 2^k -> Q16.16
  if (shift <= 0) return Fixed::from_raw(static_cast<int32_t>(p30));
  if (shift >= 32) return Fixed(0);
  const uint32_t half = UINT32_C(1) << (shift - 1);
  return Fixed::from_raw(static_cast<int32_t>((p30 + half) >> shift));
}

}  // namespace sma

#endif  // SMA_FIXED_HPP
