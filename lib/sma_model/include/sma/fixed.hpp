// sma::Fixed: Q16.16 fixed point (int32_t raw value, 16 fractional bits), a drop-in for float
// in the model templates (see scalar.hpp for the contract), designed for the ATmega328P.
//
// Why a fixed-point type at all: the AVR has no FPU. A soft-float multiply costs ~130 cycles,
// cos ~1780 and acos ~2300; the Liang-Rogers model spends its time in cos/acos shapes. The
// naive Q16.16 multiply (64-bit product, then a 64-bit shift) costs ~250 cycles and is *slower*
// than float, so everything here is built from 16x16->32 products (the widest product the AVR's
// 8x8 hardware multiplier gives cheaply), 16-bit-aligned shifts, and polynomials; no float, no
// 64-bit integer and no division on any hot path. The results are bit-identical on the host and
// the AVR (integer-only, all constants are integer literals), which is what makes host tests
// valid for the firmware; bench/avr_math checks it (results hash) and the AVR assembly paths.
//
// Measured in simavr (bench/avr_math, avr-g++ 5.4 -Os, cycles per call, float in brackets):
// add 52 (112), mul 124 (130; magnitudes below 256 take the short path, see mul_raw), div ~700
// (467), cos_ramp ~380 (~1300), cos_ramp_inv ~680 (~2120), cos ~710 (~1780), acos ~960 (~2470),
// sqrt ~610 (473), exp ~730 (~2110).
//
// Range and resolution: [-32768, 32768 - 2^-16], LSB 2^-16 = 1.53e-5.
//
// Overflow policy: + - * / and the conversions SATURATE to [lowest(), max()]. Saturation is the
// safe failure mode for a controller: a wrapped result would flip the sign of a large value
// (e.g. turn a full heater command into a full negative one); a saturated one is merely
// clipped, and the controller's own clamps already expect clipping.
//
// Rounding: conversions round to nearest; * and / round to nearest with ties away from zero, so
// (-a)*b == -(a*b) exactly (no sign bias in a control loop).
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

// Small routines that must be inlined for speed regardless of -Os heuristics: the AVR multiply
// primitives (their callers' register allocation depends on it) and the constructors (so that
// `T(0.5)` in a model template folds to a constant instead of running soft-float code).
#if defined(__GNUC__)
#define SMA_FIXED_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define SMA_FIXED_ALWAYS_INLINE inline
#endif

#if defined(__AVR__) && defined(SMA_FIRMWARE_FIXED)
// raw 2^-16 as a float: sma/float_from_int.hpp's assembly, defined in the Q16.16 image's main.cpp.
extern "C" float sma_float_from_q16(int32_t raw);
#endif

namespace sma {

// ---- integer helpers ------------------------------------------------------------------------
namespace fixed_detail {

constexpr int32_t kRawMax = INT32_MAX;
constexpr int32_t kRawMin = INT32_MIN;
constexpr int32_t kRawOne = INT32_C(65536);
constexpr uint32_t kHalfQ32 = UINT32_C(0x80000000);  // 0.5 in Q0.32, also |kRawMin|

constexpr int32_t saturated(bool negative) { return negative ? kRawMin : kRawMax; }

constexpr uint16_t hi16(uint32_t x) { return static_cast<uint16_t>(x >> 16); }
constexpr uint16_t lo16(uint32_t x) { return static_cast<uint16_t>(x & 0xFFFFu); }
// uint32 -> int32 keeping the bit pattern (modular; GCC documents it for out-of-range values).
constexpr int32_t as_signed(uint32_t x) { return static_cast<int32_t>(x); }

// 16x16->32 unsigned product; every wider product below is assembled from these.
// On the AVR it is written out as four 8x8 MUL instructions (the same sequence as libgcc's
// __umulhisi3, ~20 cycles, but inline): in plain C, once inlined next to the hi16/lo16 splits,
// avr-gcc 5.4 stops recognising a widening multiply and calls the 32x32 __mulsi3 instead.
SMA_FIXED_ALWAYS_INLINE uint32_t mul16(uint16_t a, uint16_t b) {
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
  uint32_t p;
  __asm__(
      "mul  %A1, %A2  \n\t"  // a0*b0 -> bytes 0-1
      "movw %A0, r0   \n\t"
      "mul  %B1, %B2  \n\t"  // a1*b1 -> bytes 2-3
      "movw %C0, r0   \n\t"
      "mul  %A1, %B2  \n\t"  // a0*b1 -> bytes 1-3
      "add  %B0, r0   \n\t"
      "adc  %C0, r1   \n\t"
      "clr  r1        \n\t"  // restore __zero_reg__ (clr leaves the carry alone)
      "adc  %D0, r1   \n\t"
      "mul  %B1, %A2  \n\t"  // a1*b0 -> bytes 1-3
      "add  %B0, r0   \n\t"
      "adc  %C0, r1   \n\t"
      "clr  r1        \n\t"
      "adc  %D0, r1   \n\t"
      : "=&r"(p)
      : "r"(a), "r"(b)
      : "r0");
  return p;
#else
  return static_cast<uint32_t>(a) * b;
#endif
}

// Full 32x32->64 unsigned product as two halves, from the four 16x16 partial products
//   a*b = ah*bh << 32 + (ah*bl + al*bh) << 16 + al*bl.
// Portable version; on the AVR, the reference the benchmark checks the assembly against.
inline void umul32_wide_portable(uint32_t a, uint32_t b, uint32_t& hi, uint32_t& lo) {
  const uint32_t ll = mul16(lo16(a), lo16(b));
  const uint32_t lh = mul16(lo16(a), hi16(b));
  const uint32_t hl = mul16(hi16(a), lo16(b));
  const uint32_t mid = lh + hl;  // 33 bits: keep the carry
  const uint32_t mid_carry = mid < lh ? UINT32_C(0x10000) : 0u;
  lo = ll + (mid << 16);
  hi = mul16(hi16(a), hi16(b)) + hi16(mid) + mid_carry + (lo < ll ? 1u : 0u);
}

inline uint32_t mul32x16_portable(uint32_t a, uint16_t b) {
  return mul16(hi16(a), b) + hi16(mul16(lo16(a), b));
}

// On the AVR the wider products are written as their 8x8 MULs accumulating straight into the
// result bytes. In C, built from mul16, avr-gcc keeps every 32-bit partial product in its own
// registers and spills (the Q16.16 multiply came out at ~240 cycles, slower than the int64 one).
// Byte grid of a 32x32 product: a_i*b_j lands at byte i+j. Used by mulhi32 and mul_raw, whose
// asm statements name their operands a, b (inputs), p1 (byte 1), r (bytes 2..5), x (bytes 6..7)
// and z (a zero byte). Byte 0 only ever receives the low byte of a0*b0, so it never carries and
// is not kept. The nine products of the low three bytes come first; the seven that involve a
// top byte are skipped when both top bytes are zero (the model's magnitudes are below 256, i.e.
// 2^24 raw: the Q16.16 multiply then takes ~70 cycles instead of ~130).
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
#define SMA_FIXED_AVR_PRODUCT_GRID                                                            \
  /* The diagonal of the low bytes lands in disjoint bytes: plain moves. */                  \
  "mul  %A[a], %A[b]  \n\t" /* a0b0 @0 */                                                     \
  "mov  %[p1], r1     \n\t"                                                                   \
  "mul  %B[a], %B[b]  \n\t" /* a1b1 @2 */                                                     \
  "movw %A[r], r0     \n\t"                                                                   \
  "mul  %C[a], %C[b]  \n\t" /* a2b2 @4 */                                                     \
  "movw %C[r], r0     \n\t"                                                                   \
  "clr  %A[x]         \n\t"                                                                   \
  "clr  %B[x]         \n\t"                                                                   \
  /* Low bytes: their product is < 2^48, nothing carries out of byte 5; bytes 0-3 alone     \
     hold a01*b01 < 2^32, nothing carries out of byte 3 for the first two. */               \
  "mul  %A[a], %B[b]  \n\t" /* a0b1 @1 */                                                     \
  "add  %[p1], r0     \n\t"                                                                   \
  "adc  %A[r], r1     \n\t"                                                                   \
  "adc  %B[r], %[z]   \n\t"                                                                   \
  "mul  %B[a], %A[b]  \n\t" /* a1b0 @1 */                                                     \
  "add  %[p1], r0     \n\t"                                                                   \
  "adc  %A[r], r1     \n\t"                                                                   \
  "adc  %B[r], %[z]   \n\t"                                                                   \
  "mul  %A[a], %C[b]  \n\t" /* a0b2 @2 */                                                     \
  "add  %A[r], r0     \n\t"                                                                   \
  "adc  %B[r], r1     \n\t"                                                                   \
  "adc  %C[r], %[z]   \n\t"                                                                   \
  "adc  %D[r], %[z]   \n\t"                                                                   \
  "mul  %C[a], %A[b]  \n\t" /* a2b0 @2 */                                                     \
  "add  %A[r], r0     \n\t"                                                                   \
  "adc  %B[r], r1     \n\t"                                                                   \
  "adc  %C[r], %[z]   \n\t"                                                                   \
  "adc  %D[r], %[z]   \n\t"                                                                   \
  "mul  %B[a], %C[b]  \n\t" /* a1b2 @3 */                                                     \
  "add  %B[r], r0     \n\t"                                                                   \
  "adc  %C[r], r1     \n\t"                                                                   \
  "adc  %D[r], %[z]   \n\t"                                                                   \
  "mul  %C[a], %B[b]  \n\t" /* a2b1 @3 */                                                     \
  "add  %B[r], r0     \n\t"                                                                   \
  "adc  %C[r], r1     \n\t"                                                                   \
  "adc  %D[r], %[z]   \n\t"                                                                   \
  /* The top bytes: nothing to add when both are zero. */                                   \
  "mov  r0, %D[a]     \n\t"                                                                   \
  "or   r0, %D[b]     \n\t"                                                                   \
  "breq 8f            \n\t"                                                                   \
  "mul  %D[a], %D[b]  \n\t" /* a3b3 @6: the whole product < 2^64, nothing carries out */     \
  "add  %A[x], r0     \n\t"                                                                   \
  "adc  %B[x], r1     \n\t"                                                                   \
  "mul  %A[a], %D[b]  \n\t" /* a0b3 @3 */                                                     \
  "add  %B[r], r0     \n\t"                                                                   \
  "adc  %C[r], r1     \n\t"                                                                   \
  "adc  %D[r], %[z]   \n\t"                                                                   \
  "adc  %A[x], %[z]   \n\t"                                                                   \
  "adc  %B[x], %[z]   \n\t"                                                                   \
  "mul  %D[a], %A[b]  \n\t" /* a3b0 @3 */                                                     \
  "add  %B[r], r0     \n\t"                                                                   \
  "adc  %C[r], r1     \n\t"                                                                   \
  "adc  %D[r], %[z]   \n\t"                                                                   \
  "adc  %A[x], %[z]   \n\t"                                                                   \
  "adc  %B[x], %[z]   \n\t"                                                                   \
  "mul  %B[a], %D[b]  \n\t" /* a1b3 @4 */                                                     \
  "add  %C[r], r0     \n\t"                                                                   \
  "adc  %D[r], r1     \n\t"                                                                   \
  "adc  %A[x], %[z]   \n\t"                                                                   \
  "adc  %B[x], %[z]   \n\t"                                                                   \
  "mul  %D[a], %B[b]  \n\t" /* a3b1 @4 */                                                     \
  "add  %C[r], r0     \n\t"                                                                   \
  "adc  %D[r], r1     \n\t"                                                                   \
  "adc  %A[x], %[z]   \n\t"                                                                   \
  "adc  %B[x], %[z]   \n\t"                                                                   \
  "mul  %C[a], %D[b]  \n\t" /* a2b3 @5 */                                                     \
  "add  %D[r], r0     \n\t"                                                                   \
  "adc  %A[x], r1     \n\t"                                                                   \
  "adc  %B[x], %[z]   \n\t"                                                                   \
  "mul  %D[a], %C[b]  \n\t" /* a3b2 @5 */                                                     \
  "add  %D[r], r0     \n\t"                                                                   \
  "adc  %A[x], r1     \n\t"                                                                   \
  "adc  %B[x], %[z]   \n\t"                                                                   \
  "8:                 \n\t"
#endif

// floor(a * b / 2^16): a 32x16 product keeping the top 32 bits, exact.
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
SMA_FIXED_ALWAYS_INLINE uint32_t mul32x16(uint32_t a, uint16_t b) {
  uint32_t r;  // bytes 2..5 of the 48-bit product
  uint8_t p1;  // byte 1, for its carries
  uint8_t zero;
  __asm__(
      "clr  %[z]          \n\t"
      "mul  %A[a], %A[b]  \n\t"  // a0b0 @0
      "mov  %[p1], r1     \n\t"
      "mul  %B[a], %B[b]  \n\t"  // a1b1 @2
      "movw %A[r], r0     \n\t"
      "mul  %D[a], %B[b]  \n\t"  // a3b1 @4
      "movw %C[r], r0     \n\t"
      // bytes 0-3 hold al*b < 2^32: nothing carries out of byte 3
      "mul  %A[a], %B[b]  \n\t"  // a0b1 @1
      "add  %[p1], r0     \n\t"
      "adc  %A[r], r1     \n\t"
      "adc  %B[r], %[z]   \n\t"
      "mul  %B[a], %A[b]  \n\t"  // a1b0 @1
      "add  %[p1], r0     \n\t"
      "adc  %A[r], r1     \n\t"
      "adc  %B[r], %[z]   \n\t"
      "mul  %C[a], %A[b]  \n\t"  // a2b0 @2
      "add  %A[r], r0     \n\t"
      "adc  %B[r], r1     \n\t"
      "adc  %C[r], %[z]   \n\t"
      "adc  %D[r], %[z]   \n\t"
      "mul  %C[a], %B[b]  \n\t"  // a2b1 @3
      "add  %B[r], r0     \n\t"
      "adc  %C[r], r1     \n\t"
      "adc  %D[r], %[z]   \n\t"
      "mul  %D[a], %A[b]  \n\t"  // a3b0 @3
      "add  %B[r], r0     \n\t"
      "adc  %C[r], r1     \n\t"
      "adc  %D[r], %[z]   \n\t"
      "clr  r1            \n\t"  // restore __zero_reg__
      : [r] "=&r"(r), [p1] "=&r"(p1), [z] "=&r"(zero)
      : [a] "r"(a), [b] "r"(b)
      : "r0");
  return r;
}
#else
inline uint32_t mul32x16(uint32_t a, uint16_t b) { return mul32x16_portable(a, b); }
#endif

// floor(a * b / 2^32), exact.
inline uint32_t mulhi32_portable(uint32_t a, uint32_t b) {
  uint32_t hi;
  uint32_t lo;
  umul32_wide_portable(a, b, hi, lo);
  return hi;
}

SMA_FIXED_ALWAYS_INLINE uint32_t mulhi32(uint32_t a, uint32_t b) {
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
  uint32_t r;  // product bytes 2..5
  uint16_t x;  // product bytes 6..7
  uint8_t p1;
  uint8_t zero;
  __asm__("clr  %[z]          \n\t" SMA_FIXED_AVR_PRODUCT_GRID "clr  r1            \n\t"
          : [r] "=&r"(r), [x] "=&r"(x), [p1] "=&r"(p1), [z] "=&r"(zero)
          : [a] "r"(a), [b] "r"(b)
          : "r0");
  return (static_cast<uint32_t>(x) << 16) | hi16(r);
#else
  return mulhi32_portable(a, b);
#endif
}

// |x| as unsigned; |INT32_MIN| = 2^31 is representable.
constexpr uint32_t magnitude(int32_t x) {
  return x < 0 ? UINT32_C(0) - static_cast<uint32_t>(x) : static_cast<uint32_t>(x);
}

// Applies a sign to a magnitude and saturates: m <= 2^31 - 1 when positive, m <= 2^31 when
// negative (INT32_MIN).
inline int32_t signed_saturated(uint32_t m, bool negative) {
  if (negative) return m >= kHalfQ32 ? kRawMin : as_signed(UINT32_C(0) - m);
  return m >= kHalfQ32 ? kRawMax : as_signed(m);
}

// ---- conversions (constexpr so that `T(0.5)` in a template costs nothing at run time) --------
// (Always inline: called with a constant, it folds; out of line it would run soft-float code.)
SMA_FIXED_ALWAYS_INLINE constexpr int32_t raw_from_scaled(double s) {
  // s = x * 2^16; round half away from zero, saturate, NaN -> 0.
  return (s != s) ? 0
         : (s >= 2147483647.5)  ? kRawMax
         : (s <= -2147483648.5) ? kRawMin
         : (s >= 0.0)           ? static_cast<int32_t>(s + 0.5)
                                : static_cast<int32_t>(s - 0.5);
}
SMA_FIXED_ALWAYS_INLINE constexpr int32_t raw_from_double(double x) { return raw_from_scaled(x * 65536.0); }

// Integers: saturate outside [-32768, 32767], then scale (multiply, not <<: shifting a negative
// value left is undefined in C++14).
constexpr int32_t raw_from_long(long v) {
  return v > 32767L ? kRawMax : v < -32768L ? kRawMin : static_cast<int32_t>(v) * kRawOne;
}
constexpr int32_t raw_from_ulong(unsigned long v) {
  return v > 32767UL ? kRawMax : static_cast<int32_t>(v) * kRawOne;
}

// Q16.16 from a float's bits, exactly as raw_from_double(double(x)): round half away from zero,
// saturate, NaN -> 0. Integer shifts only: on the AVR (where double is float) the soft-float
// route (a multiply, an add, three compares and a conversion, ~400 cycles) runs several times a
// tick (the measured position, the reference); this is ~60-150. Bytes are shifted whole first
// (a byte move) and the rest bit by bit.
inline int32_t raw_from_float_bits_portable(uint32_t bits) {
  const bool negative = (bits & kHalfQ32) != 0;
  const uint8_t e = static_cast<uint8_t>(hi16(bits) >> 7);  // biased exponent
  if (e == 0xFFu) return (bits & 0x7FFFFFu) != 0 ? 0 : saturated(negative);  // NaN, inf
  // |x| = m 2^(e - 150), so |x| 2^16 = m 2^(e - 134); e = 0 (zero, denormals) rounds to 0.
  if (e < 110u) return 0;  // |x| 2^16 < 2^-1 (m < 2^24, e - 134 <= -25)
  uint32_t m = (bits & 0x7FFFFFu) | 0x800000u;
  if (e >= 142u) return saturated(negative);  // |x| 2^16 >= 2^31
  uint8_t down = static_cast<uint8_t>(134u - e);  // e >= 134 instead shifts up by e - 134 <= 7
  if (e >= 134u) {
    for (uint8_t up = static_cast<uint8_t>(e - 134u); up != 0; --up) m <<= 1;
  } else {
    --down;  // keep the rounding bit: m 2^-down, then round on its lowest bit
    if (down >= 16u) {
      m = hi16(m);
      down = static_cast<uint8_t>(down - 16u);
    }
    if (down >= 8u) {
      m >>= 8;
      down = static_cast<uint8_t>(down - 8u);
    }
    for (; down != 0; --down) m >>= 1;
    m = (m >> 1) + (m & 1u);  // round half away from zero on the magnitude
  }
  return negative ? as_signed(UINT32_C(0) - m) : as_signed(m);
}

#if defined(__AVR__)
// The float conversions' shifts of the 32-bit operand %[x]: left by one bit; down by a byte (its
// top byte known to be 0).
#define SMA_ASM_X_LEFT1 "lsl  %A[x]\n\trol  %B[x]\n\trol  %C[x]\n\trol  %D[x]\n\t"
#define SMA_ASM_X_DOWN8 "mov  %A[x], %B[x]\n\tmov  %B[x], %C[x]\n\tclr  %C[x]\n\t"
// The ends: 8 -> %[x] = 0, then 9, the exit.
#define SMA_ASM_X_ZERO_END "8:\n\tclr  %A[x]\n\tclr  %B[x]\n\tclr  %C[x]\n\tclr  %D[x]\n\t9:\n\t"
// Up by %[e] bits (the flags of its last change: Z when 0), then to `done`.
#define SMA_ASM_X_UP_LOOP(done) "2:\n\tbreq " done "\n\t" SMA_ASM_X_LEFT1 "dec  %[e]\n\trjmp 2b\n\t"
#endif

#if defined(__AVR__)
// The same on the AVR in ~60 instructions (the C version: ~125, eight registers saved). The
// right shift keeps the last bit it shifts out in the carry, which rounds; a byte move first
// when at least 9 bits go.
__attribute__((noinline)) inline int32_t raw_from_float_bits(uint32_t bits) {
  uint8_t e;
  __asm__(
      "bst  %D[x], 7      \n\t"  // T = the sign
      "mov  %[e], %C[x]   \n\t"
      "lsl  %[e]          \n\t"
      "mov  %[e], %D[x]   \n\t"
      "rol  %[e]          \n\t"  // e = the biased exponent
      "andi %C[x], 0x7F   \n\t"  // the mantissa's 23 bits
      "cpi  %[e], 0xFF    \n\t"
      "brne 1f            \n\t"
      "or   %A[x], %B[x]  \n\t"  // NaN -> 0, inf -> saturated
      "or   %A[x], %C[x]  \n\t"
      "brne 8f            \n\t"
      "rjmp 7f            \n\t"
      "1:                 \n\t"
      "cpi  %[e], 110     \n\t"  // |x| 2^16 < 1/2 -> 0
      "brlo 8f            \n\t"
      "cpi  %[e], 142     \n\t"  // |x| 2^16 >= 2^31 -> saturated
      "brsh 7f            \n\t"
      "ori  %C[x], 0x80   \n\t"  // m: the implicit bit
      "clr  %D[x]         \n\t"
      "subi %[e], 134     \n\t"  // |x| 2^16 = m 2^(e - 134)
      "brcs 3f            \n\t"
      SMA_ASM_X_UP_LOOP("6f")  // up by e - 134 <= 7
      "3:                 \n\t"  // down by 134 - e <= 24
      "cpi  %[e], 0xF8    \n\t"  // 9 or more: a byte first
      "brsh 4f            \n\t"
      SMA_ASM_X_DOWN8
      "subi %[e], 0xF8    \n\t"  // e += 8
      "rjmp 3b            \n\t"
      "4:                 \n\t"
      "lsr  %D[x]         \n\t"
      "ror  %C[x]         \n\t"
      "ror  %B[x]         \n\t"
      "ror  %A[x]         \n\t"
      "inc  %[e]          \n\t"  // leaves the carry: the last bit out
      "brne 4b            \n\t"
      "adc  %A[x], __zero_reg__ \n\t"  // round half away from zero on the magnitude
      "adc  %B[x], __zero_reg__ \n\t"
      "adc  %C[x], __zero_reg__ \n\t"
      "adc  %D[x], __zero_reg__ \n\t"
      "6:                 \n\t"  // the sign
      "brtc 9f            \n\t"
      "com  %D[x]         \n\t"
      "com  %C[x]         \n\t"
      "com  %B[x]         \n\t"
      "neg  %A[x]         \n\t"
      "sbci %B[x], 0xFF   \n\t"
      "sbci %C[x], 0xFF   \n\t"
      "sbci %D[x], 0xFF   \n\t"
      "rjmp 9f            \n\t"
      "7:                 \n\t"  // saturated: 0x7FFFFFFF, + 1 when negative
      "ldi  %A[x], 0xFF   \n\t"
      "ldi  %B[x], 0xFF   \n\t"
      "ldi  %C[x], 0xFF   \n\t"
      "ldi  %D[x], 0x7F   \n\t"
      "brtc 9f            \n\t"
      "subi %A[x], 0xFF   \n\t"
      "sbci %B[x], 0xFF   \n\t"
      "sbci %C[x], 0xFF   \n\t"
      "sbci %D[x], 0xFF   \n\t"
      "rjmp 9f            \n\t"
      SMA_ASM_X_ZERO_END
      : [x] "+d"(bits), [e] "=&d"(e));
  return as_signed(bits);
}
#else
inline int32_t raw_from_float_bits(uint32_t bits) { return raw_from_float_bits_portable(bits); }
#endif

// floor(y) of a float's bits, exactly as static_cast<uint32_t>(y) for 0 <= y < 2^32, and 0 for
// y < 1 (negative and NaN included): the mantissa m with its implicit bit, y = m 2^(e - 150),
// shifted by e - 150. Integer shifts only: the Q16.16 image then links no __fixunssfsi.
inline uint32_t trunc_u32_from_float_bits_portable(uint32_t bits) {
  const uint8_t e = static_cast<uint8_t>(hi16(bits) >> 7);  // biased exponent
  if ((bits & kHalfQ32) != 0 || e < 127u) return 0;
  uint32_t m = (bits & 0x7FFFFFu) | 0x800000u;
  if (e < 150u) return m >> (150u - e);
  for (uint8_t up = static_cast<uint8_t>(e - 150u); up != 0; --up) m <<= 1;  // y >= 2^32: undefined for the cast
  return m;
}

#if defined(__AVR__)
// The same on the AVR in ~35 instructions (the C version: ~80); bytes whole first when 8 or more
// bits go down.
__attribute__((noinline)) inline uint32_t trunc_u32_from_float_bits(uint32_t x) {
  uint8_t e;
  __asm__(
      "mov  %[e], %C[x]   \n\t"
      "lsl  %[e]          \n\t"
      "mov  %[e], %D[x]   \n\t"
      "rol  %[e]          \n\t"  // e = the biased exponent, C = the sign
      "brcs 8f            \n\t"  // negative -> 0
      "cpi  %[e], 127     \n\t"  // y < 1 -> 0
      "brlo 8f            \n\t"
      "ori  %C[x], 0x80   \n\t"  // m: the implicit bit
      "clr  %D[x]         \n\t"
      "subi %[e], 150     \n\t"  // y = m 2^(e - 150)
      "brcs 3f            \n\t"
      SMA_ASM_X_UP_LOOP("9f")  // up by e - 150
      "3:                 \n\t"  // down by 150 - e <= 23
      "cpi  %[e], 0xF9    \n\t"  // 8 or more: a byte first
      "brsh 4f            \n\t"
      SMA_ASM_X_DOWN8
      "subi %[e], 0xF8    \n\t"  // e += 8
      "brne 3b            \n\t"
      "rjmp 9f            \n\t"
      "4:                 \n\t"
      "lsr  %C[x]         \n\t"  // (the top byte is 0 here)
      "ror  %B[x]         \n\t"
      "ror  %A[x]         \n\t"
      "inc  %[e]          \n\t"
      "brne 4b            \n\t"
      "rjmp 9f            \n\t"
      SMA_ASM_X_ZERO_END
      : [x] "+d"(x), [e] "=&d"(e));
  return x;
}
#else
inline uint32_t trunc_u32_from_float_bits(uint32_t bits) { return trunc_u32_from_float_bits_portable(bits); }
#endif
#if defined(__AVR__)
#undef SMA_ASM_X_LEFT1
#undef SMA_ASM_X_DOWN8
#undef SMA_ASM_X_UP_LOOP
#undef SMA_ASM_X_ZERO_END
#endif

// raw / 2^16 as a float, exactly as static_cast<float>(raw) * 2^-16: the power-of-two scaling
// is a change of the exponent (|raw| >= 1 keeps it far from underflow), not a soft-float multiply.
inline uint32_t float_bits_from_raw(int32_t raw, uint32_t bits_of_float_raw) {
  return raw == 0 ? 0u : bits_of_float_raw - (UINT32_C(16) << 23);
}

// ---- saturating arithmetic on raw values -----------------------------------------------------
// Portable versions; on the AVR they are the reference the benchmark checks the assembly against.
inline int32_t add_raw_portable(int32_t a, int32_t b) {
  const uint32_t s = static_cast<uint32_t>(a) + static_cast<uint32_t>(b);
  // Overflow iff a and b share a sign that s does not; the true result has that sign.
  const uint32_t flips = (static_cast<uint32_t>(a) ^ s) & (static_cast<uint32_t>(b) ^ s);
  return (flips & kHalfQ32) != 0 ? saturated(a < 0) : as_signed(s);
}

inline int32_t sub_raw_portable(int32_t a, int32_t b) {
  const uint32_t d = static_cast<uint32_t>(a) - static_cast<uint32_t>(b);
  // Overflow iff a and b differ in sign and d does not have the sign of a.
  const uint32_t flips = (static_cast<uint32_t>(a) ^ static_cast<uint32_t>(b)) &
                         (static_cast<uint32_t>(a) ^ d);
  return (flips & kHalfQ32) != 0 ? saturated(a < 0) : as_signed(d);
}

#if defined(__AVR__)
// AVR: the V flag of the last ADC/SBC is the signed overflow. The C version above makes avr-gcc
// save ten registers to build the sign test (~55 cycles a call); this is ~20. On overflow the
// wrapped sign is the opposite of the true one: saturate towards the true sign.
#define SMA_FIXED_AVR_SATURATE                                                    \
  "brvc 1f         \n\t"                                                        \
  "lsl  %D[r]      \n\t" /* C = 1: the true result is positive */               \
  "sbc  %A[r], %A[r] \n\t" /* 0xFF / 0x00 */                                    \
  "mov  %B[r], %A[r] \n\t"                                                      \
  "mov  %C[r], %A[r] \n\t"                                                      \
  "mov  %D[r], %A[r] \n\t"                                                      \
  "com  %D[r]      \n\t"                                                        \
  "bst  %D[r], 7   \n\t" /* T = 1: the true result is negative */               \
  "mov  %D[r], %A[r] \n\t"                                                      \
  "lsr  %D[r]      \n\t" /* 0x7F / 0x00 */                                      \
  "bld  %D[r], 7   \n\t" /* 0x7F / 0x80 */                                      \
  "1:              \n\t"
inline int32_t add_raw(int32_t a, int32_t b) {
  __asm__("add  %A[r], %A[b] \n\t"
          "adc  %B[r], %B[b] \n\t"
          "adc  %C[r], %C[b] \n\t"
          "adc  %D[r], %D[b] \n\t" SMA_FIXED_AVR_SATURATE
          : [r] "+r"(a)
          : [b] "r"(b));
  return a;
}
inline int32_t sub_raw(int32_t a, int32_t b) {
  __asm__("sub  %A[r], %A[b] \n\t"
          "sbc  %B[r], %B[b] \n\t"
          "sbc  %C[r], %C[b] \n\t"
          "sbc  %D[r], %D[b] \n\t" SMA_FIXED_AVR_SATURATE
          : [r] "+r"(a)
          : [b] "r"(b));
  return a;
}
#undef SMA_FIXED_AVR_SATURATE
#else
inline int32_t add_raw(int32_t a, int32_t b) { return add_raw_portable(a, b); }
inline int32_t sub_raw(int32_t a, int32_t b) { return sub_raw_portable(a, b); }
#endif

#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
// Assembly shared by the multiply and the division: x = -x (4 bytes in r16..r31), and
// x = T ? 0x80000000 : 0x7FFFFFFF, branching to `done` when T is set.
#define SMA_FIXED_AVR_NEGATE(x)                              \
  "com  %D[" x "]  \n\t"                                     \
  "com  %C[" x "]  \n\t"                                     \
  "com  %B[" x "]  \n\t"                                     \
  "neg  %A[" x "]  \n\t"                                     \
  "sbci %B[" x "], 0xFF  \n\t"                               \
  "sbci %C[" x "], 0xFF  \n\t"                               \
  "sbci %D[" x "], 0xFF  \n\t"
#define SMA_FIXED_AVR_SATURATED(x, done)                     \
  "clr  %A[" x "]  \n\t"                                     \
  "clr  %B[" x "]  \n\t"                                     \
  "clr  %C[" x "]  \n\t"                                     \
  "clr  %D[" x "]  \n\t"                                     \
  "bld  %D[" x "], 7  \n\t"                                  \
  "brts " done "  \n\t"                                      \
  "dec  %A[" x "]  \n\t"                                     \
  "dec  %B[" x "]  \n\t"                                     \
  "dec  %C[" x "]  \n\t"                                     \
  "dec  %D[" x "]  \n\t"                                     \
  "lsr  %D[" x "]  \n\t"
#endif

// Q16.16 product without a 64-bit integer type: the magnitudes' 64-bit product comes from the
// four 16x16->32 partial products (umul32_wide_portable), the result is its bits 16..47 rounded
// on bit 15. Working on magnitudes keeps every partial product unsigned, makes overflow a test on
// the top bits, and gives sign-symmetric rounding (half away from zero). Portable version; on
// the AVR it is the reference the benchmark checks the assembly version against.
inline int32_t mul_raw_portable(int32_t a, int32_t b) {
  const bool negative = (a ^ b) < 0;
  uint32_t hi;
  uint32_t lo;
  umul32_wide_portable(magnitude(a), magnitude(b), hi, lo);
  if (hi16(hi) != 0) return saturated(negative);  // |product| >= 2^32 in Q16.16 units
  uint32_t m = (hi << 16) | hi16(lo);
  if ((lo & 0x8000u) != 0) {  // round half up on the magnitude
    ++m;
    if (m == 0) return saturated(negative);
  }
  return signed_saturated(m, negative);
}

#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
// The general case of mul_raw below (an operand of 256 or more), which forms |a|, |b| and the
// sign (bit 7 of mul_general_sign()). The sign's byte is in RAM: as a third argument it would sit
// in r16, which mul_raw would then save on every multiply (+4 cycles each, ~95 a tick).
inline uint8_t& mul_general_sign() {
  static uint8_t sign;
  return sign;
}
inline int32_t mul_raw(int32_t a, int32_t b);
// No byte grid of its own: two magnitudes of 2^24 or more give a product of 2^32 or more
// (saturated); otherwise, with |a| = a3 2^24 + a' the larger one (a' < 2^24) and |b| < 2^24,
//   |a b| / 2^16 = a3 |b| 2^8 + a' |b| / 2^16,
// an exact integer (three MULs; 2^31 or more saturates) plus mul_raw's short path (both factors
// below 2^24: it rounds the same bits the full product would, and if it saturates, so does the
// sum, a3 |b| 2^8 being at least 2^8). The magnitude's sum is below 2^32 (no carry). ~60 cycles
// more than a grid, on a path the model's magnitudes (below 256) do not take.
__attribute__((noinline)) inline int32_t mul_raw_general(uint32_t ua, uint32_t ub) {
  register uint32_t ra __asm__("r22") = ua;  // the arguments' registers: no moves
  register uint32_t rb __asm__("r18") = ub;
  __asm__ volatile(
      "cp   r22, r18      \n\t"  // |a| >= |b|: swap if not
      "cpc  r23, r19      \n\t"
      "cpc  r24, r20      \n\t"
      "cpc  r25, r21      \n\t"
      "brcc 1f            \n\t"
      "movw r26, r22      \n\t"
      "movw r22, r18      \n\t"
      "movw r18, r26      \n\t"
      "movw r26, r24      \n\t"
      "movw r24, r20      \n\t"
      "movw r20, r26      \n\t"
      "1:                 \n\t"
      "tst  r21           \n\t"  // |b| >= 2^24 too: saturate
      "brne 8f            \n\t"
      "mul  r25, r18      \n\t"  // a3 |b| in r30, r31, r26, r27
      "movw r30, r0       \n\t"
      "mul  r25, r20      \n\t"
      "movw r26, r0       \n\t"
      "mul  r25, r19      \n\t"
      "add  r31, r0       \n\t"
      "adc  r26, r1       \n\t"
      "clr  r1            \n\t"  // restore __zero_reg__ (clr leaves the carry alone)
      "adc  r27, r1       \n\t"
      "tst  r27           \n\t"  // a3 |b| 2^8 >= 2^31: saturate
      "brne 8f            \n\t"
      "sbrc r26, 7        \n\t"
      "rjmp 8f            \n\t"
      "push r30           \n\t"
      "push r31           \n\t"
      "push r26           \n\t"
      "clr  r25           \n\t"  // a'
      "call %x[mul]       \n\t"  // r22..r25 = a' |b| / 2^16, rounded
      "pop  r26           \n\t"
      "pop  r31           \n\t"
      "pop  r30           \n\t"
      "add  r23, r30      \n\t"
      "adc  r24, r31      \n\t"
      "adc  r25, r26      \n\t"
      "rjmp 9f            \n\t"
      "8:                 \n\t"  // a magnitude signed_saturated saturates in both signs
      "ldi  r22, 0xFF     \n\t"
      "ldi  r23, 0xFF     \n\t"
      "movw r24, r22      \n\t"
      "9:                 \n\t"
      : "+r"(ra), "+r"(rb)
      : [mul] "i"(&mul_raw)
      : "r0", "r26", "r27", "r30", "r31", "memory");
  return signed_saturated(ra, (mul_general_sign() & 0x80u) != 0);
}

// The Q16.16 multiply of the model's magnitudes (both below 256, i.e. 2^24 raw: temperatures,
// volts, millimetres, the curves' fractions), in the registers the call brings them in: the
// general version needs 16 registers for operands, product and carries, so it saves six and
// moves both operands (~30 of its cycles). Here |a| and |b| are formed in place (r22..r25,
// r18..r21); when both top bytes are zero, those two bytes serve as the zero and the byte-1
// register, the nine products of the low bytes go to r26, r27, r30, r31 (all call-clobbered),
// and nothing needs saving: ~75 cycles with the call. A product of bytes below 2^24 is below
// 2^48 - 2^25, so the rounding cannot carry out of byte 5 and only the sign's range is tested.
// Otherwise mul_raw_general does the whole grid of |a| and |b|.
__attribute__((noinline)) inline int32_t mul_raw(int32_t a, int32_t b) {
  register uint32_t ra __asm__("r22") = static_cast<uint32_t>(a);
  register uint32_t rb __asm__("r18") = static_cast<uint32_t>(b);
  register uint8_t general __asm__("r26");  // not 0: out of range, bit 7 the result's sign
  __asm__(
      "mov  r26, %D[a]    \n\t"  // the signs, to undo the magnitudes on the general path
      "mov  r27, %D[b]    \n\t"
      "mov  r30, r26      \n\t"
      "eor  r30, r27      \n\t"
      "bst  r30, 7        \n\t"  // T = the result's sign
      "sbrs %D[a], 7      \n\t"
      "rjmp 1f            \n\t"
      "com  %D[a]         \n\t"
      "com  %C[a]         \n\t"
      "com  %B[a]         \n\t"
      "neg  %A[a]         \n\t"
      "sbci %B[a], 0xFF   \n\t"
      "sbci %C[a], 0xFF   \n\t"
      "sbci %D[a], 0xFF   \n\t"
      "1:                 \n\t"
      "sbrs %D[b], 7      \n\t"
      "rjmp 2f            \n\t"
      "com  %D[b]         \n\t"
      "com  %C[b]         \n\t"
      "com  %B[b]         \n\t"
      "neg  %A[b]         \n\t"
      "sbci %B[b], 0xFF   \n\t"
      "sbci %C[b], 0xFF   \n\t"
      "sbci %D[b], 0xFF   \n\t"
      "2:                 \n\t"
      "mov  r30, %D[a]    \n\t"
      "or   r30, %D[b]    \n\t"
      "breq 11f           \n\t"
      // Out of range: |a|, |b| and the sign (bit 7) for the general version.
      "ldi  r26, 1        \n\t"
      "bld  r26, 7        \n\t"
      "rjmp 9f            \n\t"
      "11:                \n\t"
      // Top bytes zero: %D[a] is the zero byte, %D[b] byte 1; bytes 2..5 in r26, r27, r30, r31.
      "mul  %A[a], %A[b]  \n\t"  // a0b0 @0
      "mov  %D[b], r1     \n\t"
      "mul  %B[a], %B[b]  \n\t"  // a1b1 @2
      "movw r26, r0       \n\t"
      "mul  %C[a], %C[b]  \n\t"  // a2b2 @4
      "movw r30, r0       \n\t"
      "mul  %A[a], %B[b]  \n\t"  // a0b1 @1 (bytes 0-3 hold a01*b01 < 2^32)
      "add  %D[b], r0     \n\t"
      "adc  r26, r1       \n\t"
      "adc  r27, %D[a]    \n\t"
      "mul  %B[a], %A[b]  \n\t"  // a1b0 @1
      "add  %D[b], r0     \n\t"
      "adc  r26, r1       \n\t"
      "adc  r27, %D[a]    \n\t"
      "mul  %A[a], %C[b]  \n\t"  // a0b2 @2
      "add  r26, r0       \n\t"
      "adc  r27, r1       \n\t"
      "adc  r30, %D[a]    \n\t"
      "adc  r31, %D[a]    \n\t"
      "mul  %C[a], %A[b]  \n\t"  // a2b0 @2
      "add  r26, r0       \n\t"
      "adc  r27, r1       \n\t"
      "adc  r30, %D[a]    \n\t"
      "adc  r31, %D[a]    \n\t"
      "mul  %B[a], %C[b]  \n\t"  // a1b2 @3
      "add  r27, r0       \n\t"
      "adc  r30, r1       \n\t"
      "adc  r31, %D[a]    \n\t"
      "mul  %C[a], %B[b]  \n\t"  // a2b1 @3
      "add  r27, r0       \n\t"
      "adc  r30, r1       \n\t"
      "adc  r31, %D[a]    \n\t"
      "clr  r1            \n\t"  // restore __zero_reg__
      "lsl  %D[b]         \n\t"  // round on bit 15
      "adc  r26, %D[a]    \n\t"
      "adc  r27, %D[a]    \n\t"
      "adc  r30, %D[a]    \n\t"
      "adc  r31, %D[a]    \n\t"
      "brts 3f            \n\t"
      "sbrc r31, 7        \n\t"  // positive: the magnitude must be < 2^31
      "rjmp 5f            \n\t"
      "rjmp 4f            \n\t"
      "3:                 \n\t"  // negative: -m, in range for m <= 2^31
      "com  r31           \n\t"
      "com  r30           \n\t"
      "com  r27           \n\t"
      "neg  r26           \n\t"
      "sbci r27, 0xFF     \n\t"
      "sbci r30, 0xFF     \n\t"
      "sbci r31, 0xFF     \n\t"
      "sbrc r31, 7        \n\t"
      "rjmp 4f            \n\t"
      "mov  %D[b], r26    \n\t"  // not negative: m == 0 (fine) or m > 2^31 (saturate)
      "or   %D[b], r27    \n\t"
      "or   %D[b], r30    \n\t"
      "or   %D[b], r31    \n\t"
      "breq 4f            \n\t"
      "5:                 \n\t"  // saturate: T ? 0x80000000 : 0x7FFFFFFF
      SMA_FIXED_AVR_SATURATED("a", "6f")
      "rjmp 6f            \n\t"
      "4:                 \n\t"
      "movw %A[a], r26    \n\t"
      "movw %C[a], r30    \n\t"
      "6:                 \n\t"
      "clr  r26           \n\t"
      "9:                 \n\t"
      : [a] "+r"(ra), [b] "+r"(rb), "=r"(general)
      :
      : "r0", "r27", "r30", "r31");
  if (general != 0) {
    mul_general_sign() = general;
    return mul_raw_general(ra, rb);
  }
  return as_signed(ra);
}
#else
inline int32_t mul_raw(int32_t a, int32_t b) { return mul_raw_portable(a, b); }
#endif

// Q16.16 quotient (a << 16) / b without a 64-bit dividend: restoring long division of
// |a| * 2^17 (49 bits) by |b|, one quotient bit per step, 16 fraction bits plus a rounding bit.
// The top 17 dividend bits go straight into the remainder (they must be < |b|, else the quotient
// overflows), so only 32 steps remain and the quotient fits 32 bits. Slower than the multiply
// (the model precomputes reciprocals, so division is rare) but exact.
// Division by zero saturates: max() for a >= 0, lowest() for a < 0.
inline int32_t div_raw_portable(int32_t a, int32_t b) {
  if (b == 0) return saturated(a < 0);
  const bool negative = (a ^ b) < 0;
  const uint32_t ua = magnitude(a);
  const uint32_t ub = magnitude(b);
  uint32_t r = (static_cast<uint32_t>(hi16(ua)) << 1) | (lo16(ua) >> 15);  // ua >> 15
  if (r >= ub) return saturated(negative);  // |quotient| >= 2^15
  uint32_t q = static_cast<uint32_t>(lo16(ua)) << 17;  // remaining dividend bits, then quotient
  // r < ub <= 2^31, so 2 r + 1 never overflows; the quotient bits shift in as the dividend's
  // bits shift out of q.
  for (uint8_t i = 0; i < 32; ++i) {
    const bool top = (q & kHalfQ32) != 0;
    r <<= 1;
    if (top) r |= 1u;
    q <<= 1;
    if (r >= ub) {
      r -= ub;
      q |= 1u;
    }
  }
  q = (q >> 1) + (q & 1u);  // round half away from zero on the magnitude
  return signed_saturated(q, negative);
}

#if defined(__AVR__)
// The same on the AVR in one block (~65 instructions; the C version: ~160, fourteen registers
// saved). The quotient's magnitude is at most 2^31 after rounding (the remainder starts below
// |b|): negated it is in range, positive it saturates only at 2^31. b = 0 needs no test of its
// own: |a| >> 15 >= 0 = |b| takes the saturation, signed as a (the quotient's sign bit is a's).
__attribute__((noinline)) inline int32_t div_raw(int32_t a, int32_t b) {
  // Twelve registers, the call-clobbered ones: a and b where the call brings them (the quotient
  // returns in a's), the remainder in X and Z, the step count in r0. None saved.
  register uint32_t ua __asm__("r22") = static_cast<uint32_t>(a);  // |a|, the dividend bits, the quotient
  register uint32_t ub __asm__("r18") = static_cast<uint32_t>(b);  // |b|
  register uint16_t rl __asm__("r26");  // the remainder, low half
  register uint16_t rh __asm__("r30");  // the remainder, high half
  __asm__(
      "mov  r0, %D[a]     \n\t"
      "eor  r0, %D[b]     \n\t"
      "bst  r0, 7         \n\t"  // T = the quotient's sign
      "sbrs %D[a], 7      \n\t"
      "rjmp 1f            \n\t"
      SMA_FIXED_AVR_NEGATE("a")
      "1:                 \n\t"
      "sbrs %D[b], 7      \n\t"
      "rjmp 2f            \n\t"
      SMA_FIXED_AVR_NEGATE("b")
      "2:                 \n\t"  // r = |a| >> 15, the dividend bits left = |a| << 17
      "mov  %A[rl], %C[a]  \n\t"
      "mov  %B[rl], %D[a]  \n\t"
      "clr  %A[rh]         \n\t"
      "clr  %B[rh]         \n\t"
      "lsl  %A[a]         \n\t"
      "rol  %B[a]         \n\t"
      "rol  %A[rl]         \n\t"
      "rol  %B[rl]         \n\t"
      "rol  %A[rh]         \n\t"
      "mov  %D[a], %B[a]  \n\t"
      "mov  %C[a], %A[a]  \n\t"
      "clr  %B[a]         \n\t"
      "clr  %A[a]         \n\t"
      "cp   %A[rl], %A[b]  \n\t"  // |quotient| >= 2^15: saturate
      "cpc  %B[rl], %B[b]  \n\t"
      "cpc  %A[rh], %C[b]  \n\t"
      "cpc  %B[rh], %D[b]  \n\t"
      "brsh 7f            \n\t"
      "clr  r0            \n\t"  // 32 steps
      "inc  r0            \n\t"
      "swap r0            \n\t"
      "lsl  r0            \n\t"
      "3:                 \n\t"  // a step: r < |b| <= 2^31, so 2 r + 1 fits
      "lsl  %A[a]         \n\t"
      "rol  %B[a]         \n\t"
      "rol  %C[a]         \n\t"
      "rol  %D[a]         \n\t"
      "rol  %A[rl]         \n\t"
      "rol  %B[rl]         \n\t"
      "rol  %A[rh]         \n\t"
      "rol  %B[rh]         \n\t"
      "cp   %A[rl], %A[b]  \n\t"
      "cpc  %B[rl], %B[b]  \n\t"
      "cpc  %A[rh], %C[b]  \n\t"
      "cpc  %B[rh], %D[b]  \n\t"
      "brlo 4f            \n\t"
      "sub  %A[rl], %A[b]  \n\t"
      "sbc  %B[rl], %B[b]  \n\t"
      "sbc  %A[rh], %C[b]  \n\t"
      "sbc  %B[rh], %D[b]  \n\t"
      "inc  %A[a]         \n\t"  // the quotient bit (bit 0 is clear after the shift)
      "4:                 \n\t"
      "dec  r0            \n\t"
      "brne 3b            \n\t"
      "lsr  %D[a]         \n\t"  // round half away from zero on the magnitude
      "ror  %C[a]         \n\t"
      "ror  %B[a]         \n\t"
      "ror  %A[a]         \n\t"
      "adc  %A[a], __zero_reg__ \n\t"
      "adc  %B[a], __zero_reg__ \n\t"
      "adc  %C[a], __zero_reg__ \n\t"
      "adc  %D[a], __zero_reg__ \n\t"
      "brts 5f            \n\t"
      "sbrs %D[a], 7      \n\t"  // positive: 2^31 saturates
      "rjmp 9f            \n\t"
      "rjmp 7f            \n\t"
      "5:                 \n\t"  // negative: -m, -2^31 included
      SMA_FIXED_AVR_NEGATE("a")
      "rjmp 9f            \n\t"
      "7:                 \n\t"  // saturate: T ? 0x80000000 : 0x7FFFFFFF
      SMA_FIXED_AVR_SATURATED("a", "9f")
      "9:                 \n\t"
      : [a] "+d"(ua), [b] "+d"(ub), [rl] "=&r"(rl), [rh] "=&r"(rh));
  return as_signed(ua);
}
#else
inline int32_t div_raw(int32_t a, int32_t b) { return div_raw_portable(a, b); }
#endif
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
#undef SMA_FIXED_AVR_NEGATE
#undef SMA_FIXED_AVR_SATURATED
#endif

}  // namespace fixed_detail

// ---- the type ---------------------------------------------------------------------------------
class Fixed {
 public:
  static constexpr int kFracBits = 16;

  // Trivial, as float's: `Fixed x;` and a member left out of a constructor's list are
  // indeterminate, `Fixed()` and `T()` (value-initialized) are 0. A zeroing constructor stored 4
  // bytes for every such member the constructors then overwrite (Hysteresis's loop, PhaseCurves'
  // knot arrays: ~440 B of the Q16.16 Uno image).
  Fixed() = default;
  // Rounds to nearest, saturates out of range, maps NaN to 0. On the AVR `double` is a 32-bit
  // float, so values beyond +-256 carry the float's own rounding; constants fold at compile time.
  SMA_FIXED_ALWAYS_INLINE constexpr explicit Fixed(double x)
      : raw_(fixed_detail::raw_from_double(x)) {}
  // Integers saturate outside [-32768, 32767]. The extra integer overloads keep `Fixed(n)`
  // unambiguous for int32_t (long on AVR), uint16_t (unsigned on AVR) and size_t.
  SMA_FIXED_ALWAYS_INLINE constexpr explicit Fixed(int v)
      : raw_(fixed_detail::raw_from_long(static_cast<long>(v))) {}
  SMA_FIXED_ALWAYS_INLINE constexpr explicit Fixed(long v)
      : raw_(fixed_detail::raw_from_long(v)) {}
  SMA_FIXED_ALWAYS_INLINE constexpr explicit Fixed(unsigned v)
      : raw_(fixed_detail::raw_from_ulong(static_cast<unsigned long>(v))) {}
  SMA_FIXED_ALWAYS_INLINE constexpr explicit Fixed(unsigned long v)
      : raw_(fixed_detail::raw_from_ulong(v)) {}

  static constexpr Fixed from_raw(int32_t r) { return Fixed(RawTag(), r); }
  constexpr int32_t raw() const { return raw_; }

#if defined(__AVR__) && defined(SMA_FIRMWARE_FIXED)
  // The Q16.16 image: the conversion's own entry (sma/float_from_int.hpp, defined by main.cpp).
  SMA_FIXED_ALWAYS_INLINE explicit operator float() const { return sma_float_from_q16(raw_); }
  explicit operator double() const { return static_cast<double>(static_cast<float>(*this)); }
#elif defined(__AVR__)
  // double is float on the AVR: one integer conversion and an exponent change. Out of line:
  // one copy for the telemetry's and the console's conversions.
  __attribute__((noinline)) explicit operator float() const {
    const float f = static_cast<float>(raw_);
    uint32_t bits;
    __builtin_memcpy(&bits, &f, 4);
    bits = fixed_detail::float_bits_from_raw(raw_, bits);
    float r;
    __builtin_memcpy(&r, &bits, 4);
    return r;
  }
  explicit operator double() const { return static_cast<double>(static_cast<float>(*this)); }
#else
  constexpr explicit operator double() const {
    return static_cast<double>(raw_) * (1.0 / 65536.0);
  }
  constexpr explicit operator float() const {
    return static_cast<float>(raw_) * (1.0f / 65536.0f);
  }
#endif

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
// -lowest() saturates to max(): the range is asymmetric by one LSB. Out of line on the AVR: one
// copy instead of one per use (-60 B of the Q16.16 image, +3 cycles of its control section).
#if defined(__AVR__)
__attribute__((noinline)) inline
#else
constexpr
#endif
Fixed operator-(Fixed a) {
  return Fixed::from_raw(a.raw() == fixed_detail::kRawMin ? fixed_detail::kRawMax : -a.raw());
}

constexpr bool operator==(Fixed a, Fixed b) { return a.raw() == b.raw(); }
constexpr bool operator!=(Fixed a, Fixed b) { return a.raw() != b.raw(); }
constexpr bool operator<(Fixed a, Fixed b) { return a.raw() < b.raw(); }
constexpr bool operator<=(Fixed a, Fixed b) { return a.raw() <= b.raw(); }
constexpr bool operator>(Fixed a, Fixed b) { return a.raw() > b.raw(); }
constexpr bool operator>=(Fixed a, Fixed b) { return a.raw() >= b.raw(); }

// min, max and clamp on the raw values: the generic templates' `?:` on the class made
// avr-gcc select the address of a stack copy of each operand (Controller::set_voltage, a clamp:
// 108 B of AVR flash). Out of line on the AVR: one copy each instead of one per use (the tick
// clamps ~6 times; -150 B of the Q16.16 image for +134 cycles of its control section).
#if defined(__AVR__)
#define SMA_FIXED_ORDER_FN __attribute__((noinline)) inline
#else
#define SMA_FIXED_ORDER_FN constexpr
#endif
SMA_FIXED_ORDER_FN Fixed min(Fixed a, Fixed b) { return Fixed::from_raw(b.raw() < a.raw() ? b.raw() : a.raw()); }
SMA_FIXED_ORDER_FN Fixed max(Fixed a, Fixed b) { return Fixed::from_raw(a.raw() < b.raw() ? b.raw() : a.raw()); }
SMA_FIXED_ORDER_FN Fixed clamp(Fixed x, Fixed lo, Fixed hi) {
  return Fixed::from_raw(x.raw() > lo.raw() ? (x.raw() < hi.raw() ? x.raw() : hi.raw()) : lo.raw());
}
#undef SMA_FIXED_ORDER_FN

// clamp(x, 0, 1) on the raw value: two integer compares (the generic template's out-of-line call
// cost ~100 AVR cycles). Out of line on the AVR, one copy for its two callers (Mechanics::fraction
// in the tick, Hysteresis::reset): -18 B for ~+29 cycles.
#if defined(__AVR__)
__attribute__((noinline))
#else
__attribute__((always_inline))
#endif
inline Fixed clamp01(Fixed x) {
  return x.raw() <= 0 ? Fixed::from_raw(0) : x.raw() >= fixed_detail::kRawOne ? Fixed::from_raw(fixed_detail::kRawOne) : x;
}

// A float at run time (the measured position, a reference, the constructors' parameters):
// exactly Fixed(double(x)), by integer shifts (raw_from_float_bits).
inline Fixed fixed_from_float(float x) {
  uint32_t bits;
  __builtin_memcpy(&bits, &x, 4);
  return Fixed::from_raw(fixed_detail::raw_from_float_bits(bits));
}

template <>
inline Fixed from_double<Fixed>(double x) {
#if defined(__AVR__)
  return fixed_from_float(x);  // double is float on the AVR
#else
  return Fixed(x);
#endif
}

namespace fixed_detail {
// n / 2^15, by 16-bit halves (a 32-bit shift by 15 is a 15-step loop on the AVR): the remainder
// the division starts from.
inline uint16_t ratio_top(uint32_t n) {
  return static_cast<uint16_t>((hi16(n) << 1) | ((lo16(n) & 0x8000u) != 0 ? 1u : 0u));
}
// n's low 15 bits at the top of a word (the dividend bits still to shift in), by a 16-bit shift
// and a byte move.
inline uint32_t ratio_rest(uint32_t n) { return static_cast<uint32_t>(static_cast<uint16_t>(lo16(n) << 1)) << 16; }
// The restoring division by an 8-bit d: r < d the remainder so far, q the dividend bits still
// to shift in (at its top); each of the `steps` steps shifts one of them into r and the quotient
// bit into q's bottom. The loop in C. Portable version; on the AVR the reference bench/avr_math
// checks the assembly against (CTest avr_math_bench).
inline uint32_t divide_steps_portable(uint8_t r, uint32_t q, uint8_t d, uint8_t steps) {
  for (uint8_t i = 0; i < steps; ++i) {
    const uint16_t r2 = static_cast<uint16_t>((r << 1) | ((q & kHalfQ32) != 0 ? 1u : 0u));
    q <<= 1;
    if (r2 >= d) {
      r = static_cast<uint8_t>(r2 - d);
      q |= 1u;
    } else {
      r = static_cast<uint8_t>(r2);
    }
  }
  return q;
}
inline uint32_t divide_steps(uint8_t r, uint32_t q, uint8_t d, uint8_t steps) {
#if defined(__AVR__)
  __asm__(
      "1:                 \n\t"
      "lsl  %A[q]         \n\t"
      "rol  %B[q]         \n\t"
      "rol  %C[q]         \n\t"
      "rol  %D[q]         \n\t"
      "rol  %[r]          \n\t"  // carry: the remainder reached 256 > d
      "brcs 2f            \n\t"
      "cp   %[r], %[d]    \n\t"
      "brcs 3f            \n\t"
      "2:                 \n\t"
      "sub  %[r], %[d]    \n\t"  // (2 r + bit - d) < d: exact modulo 256
      "inc  %A[q]         \n\t"  // the quotient bit (bit 0 is 0 after the shift)
      "3:                 \n\t"
      "dec  %[c]          \n\t"
      "brne 1b            \n\t"
      : [q] "+r"(q), [r] "+r"(r), [c] "+r"(steps)
      : [d] "r"(d));
  return q;
#else
  return divide_steps_portable(r, q, d, steps);
#endif
}
// floor(n 2^17 / d) for n / 2^15 < d: n's top bits start the remainder, 32 steps.
inline uint32_t ratio_q17_portable(uint32_t n, uint8_t d) {
  return divide_steps_portable(static_cast<uint8_t>(ratio_top(n)), ratio_rest(n), d, 32);
}
inline uint32_t ratio_q17(uint32_t n, uint8_t d) {
  return divide_steps(static_cast<uint8_t>(ratio_top(n)), ratio_rest(n), d, 32);
}
// floor(n 2^7 / d) for n / 2^10 < d (a mean below 1024): n / 2^10 starts the remainder, n's low
// 10 bits and 7 zeros follow: 17 steps. The shifts by 16-bit halves (see ratio_top).
inline uint32_t fraction_q7_portable(uint32_t n, uint8_t d) {
  const uint16_t n_over_2_8 = static_cast<uint16_t>((hi16(n) << 8) | (lo16(n) >> 8));
  const uint32_t rest = static_cast<uint32_t>(static_cast<uint16_t>(lo16(n) << 6)) << 16;
  return divide_steps_portable(static_cast<uint8_t>(n_over_2_8 >> 2), rest, d, 17);
}
inline uint32_t fraction_q7(uint32_t n, uint8_t d) {
  const uint16_t n_over_2_8 = static_cast<uint16_t>((hi16(n) << 8) | (lo16(n) >> 8));
  const uint32_t rest = static_cast<uint32_t>(static_cast<uint16_t>(lo16(n) << 6)) << 16;
  return divide_steps(static_cast<uint8_t>(n_over_2_8 >> 2), rest, d, 17);
}
}  // namespace fixed_detail

// n / d in Q16.16, rounded half up, saturated (the mean of a tick's ADC samples, scalar.hpp):
// restoring division of n 2^17 by an 8-bit d. The top bits of n start the remainder (n / 2^15 < d,
// else the quotient overflows), which then stays below d: 32 steps of one shifted-in bit each.
// On the AVR the steps are ~12 cycles of assembly (the remainder in one register, its ninth bit in
// the carry), ~400 in all; a float division and the conversions around it cost ~800, the same
// loop in C ~1200.
template <>
inline Fixed ratio<Fixed>(uint32_t n, uint8_t d) {
  if (fixed_detail::hi16(n) >= 0x8000u || fixed_detail::ratio_top(n) >= d) return Fixed::max();  // also d == 0
  const uint32_t q = fixed_detail::ratio_q17(n, d);
  return Fixed::from_raw(static_cast<int32_t>((q >> 1) + (q & 1u)));
}
// n / (1024 d) in Q16.16, rounded half up: the mean of d 10-bit ADC samples as a fraction of full
// scale. The quotient n 2^7 / d has 17 bits (a mean below 1024), so the division takes 17 steps
// instead of ratio's 32, and the fraction is below 1: the multiply by vref that follows takes
// mul_raw's short path (the mean in counts times vref / 1024 would take the long one). A mean of
// 1024 or more (not a 10-bit ADC's): ratio, scaled.
inline Fixed adc_fraction(uint32_t n, uint8_t d) {
  using namespace fixed_detail;
  if (d == 0 || hi16(n) >= 4u || static_cast<uint8_t>(static_cast<uint16_t>((hi16(n) << 8) | (lo16(n) >> 8)) >> 2) >= d)
    return ratio<Fixed>(n, d) * Fixed::from_raw(64);  // 2^-10
  const uint32_t q = fraction_q7(n, d);
  return Fixed::from_raw(static_cast<int32_t>((q >> 1) + (q & 1u)));
}
template <>
inline Fixed adc_volts<Fixed>(uint32_t n, uint8_t d, Fixed /*volts_per_count*/, Fixed vref) {
  return adc_fraction(n, d) * vref;
}
// x / 2^31 for x <= 2^31 in Q16.16, rounded: x / 2^15 as (x / 2^16) 2 + bit 15, plus bit 14.
template <>
inline Fixed from_q31<Fixed>(uint32_t x) {
  using namespace fixed_detail;
  const uint16_t lo = lo16(x);
  return Fixed::from_raw(static_cast<int32_t>((static_cast<uint32_t>(hi16(x)) << 1) + ((lo & 0x8000u) != 0 ? 1u : 0u) +
                                              ((lo & 0x4000u) != 0 ? 1u : 0u)));
}
// floor(x) for x >= 0; 0 for x < 0.
inline uint16_t floor_u16(Fixed x) { return x.raw() <= 0 ? 0u : fixed_detail::hi16(static_cast<uint32_t>(x.raw())); }

// Every Fixed is a number; overflow saturates instead of producing inf/NaN.
constexpr bool is_finite(Fixed) { return true; }

// ---- math kernels (integer-only; formats noted as Qm.n) -----------------------------------------
// Shift amounts are kept to 16 (a byte move on the AVR) or to 1-3 bits: avr-gcc -Os compiles
// other 32-bit shifts into a bit-per-iteration loop of ~5 cycles per bit.
namespace fixed_detail {

// Haversine kernel: h = (1 - cos(pi x)) / 2 for x in [0, 0.5], h = w * B(w) with w = (2x)^2 and
// B a degree-2 minimax fit on w in [0, 1] (|error of h| <= 3.9e-6). This is B(w) in Q0.32 for w
// given in Q0.30 (w30 <= 2^30); the small inner term is evaluated on 16 bits, the outer product
// uses all of w30.
// The constant and the inner term: B(w) = kHaversineB0 - w q18 (q18 in Q0.18), w given in Q2.14.
constexpr uint32_t kHaversineB0 = UINT32_C(2649010682);  // b0 in Q0.32
// B(w) = b0 - w (b1 - w b2), b0 = 0.61677086209, b1 = 0.12634892434, b2 = 0.00958198370.
constexpr uint16_t kHaversineB1 = 33122;  // b1 in Q0.18
constexpr uint16_t kHaversineB2 = 10047;  // b2 in Q0.20
inline uint16_t haversine_q18(uint16_t w14) {
  // Q14 * Q20 >> 16 = Q18, rounded (truncating here would bias h by up to 3.8e-6).
  return static_cast<uint16_t>(kHaversineB1 - hi16(mul16(w14, kHaversineB2) + 0x8000u));
}
inline uint32_t haversine_b32(uint32_t w30) {
  return kHaversineB0 - mul32x16(w30, haversine_q18(hi16(w30)));  // Q30 * Q18 >> 16 = Q32
}

// h <= 0.5 (Q0.30) keeps the mirrored upper half monotone.
inline uint32_t half_at_most_q30(uint32_t h) {
  constexpr uint32_t kHalf = UINT32_C(1) << 29;
  return h < kHalf ? h : kHalf;
}

// h in Q0.30 from w in Q0.30: the last product uses all of w30, so rounding adds ~3e-6 and h is
// non-decreasing in w.
inline uint32_t haversine_q30(uint32_t w30) {
  return half_at_most_q30(mulhi32(w30, haversine_b32(w30)));  // Q30 * Q32 >> 32 = Q30
}

// cos(2 pi p) for a phase p in turns, Q0.32 (the full circle wraps naturally in uint32).
// Folds to x in [0, 0.5] with cos(pi x) = 1 - 2 h(x); returns Q16.16 raw.
inline int32_t cos_turns_raw(uint32_t p) {
  if (p > kHalfQ32) p = UINT32_C(0) - p;      // cos(-t) = cos(t): p in [0, 1/2] turn
  const bool upper = p > (UINT32_C(1) << 30);  // past a quarter turn: cos(pi - a) = -cos(a)
  const uint32_t x32 = (upper ? kHalfQ32 - p : p) << 1;  // x in Q0.32, <= 0.5
  const uint32_t w30 = mulhi32(x32, x32);                 // x^2 in Q0.32 = (2x)^2 in Q0.30
  // 2h in Q16.16, rounded: h32 / 2^15 with h32 = h in Q0.32 <= 2^31, without a 15-bit shift.
  const uint32_t t = (haversine_q30(w30) << 2) + (UINT32_C(1) << 14);
  const int32_t two_h =
      static_cast<int32_t>(2u * static_cast<uint32_t>(hi16(t)) + (lo16(t) >> 15));
  const int32_t c = kRawOne - two_h;
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
         hi16(mul16(ml, kl) + 0x8000u) + hi16(mul16(mh, kTurnsPerRadFrac));
}

// floor(sqrt(n)) for any uint32 n, exactly, and the remainder n - root^2 (<= 2 root < 2^17).
// Digit by digit, one root bit per pair of n's bits from the top: with root R so far and the
// next pair brought down into the remainder, the bit is 1 iff rem >= (2R + 1)^2 - (2R)^2 =
// 4R + 1. The result is the true floor, hence monotone in n. Portable version; on the AVR the
// reference the benchmark checks the assembly against.
inline uint16_t isqrt32_portable(uint32_t n, uint32_t& rem) {
  uint32_t r = 0;
  uint32_t s = 0;  // 4 R
  for (uint8_t i = 0; i < 16; ++i) {
    r = (r << 2) | (n >> 30);
    n <<= 2;
    const bool bit = r > s;  // r >= 4 R + 1
    if (bit) r -= s + 1u;
    s = (s + (bit ? 2u : 0u)) << 1;  // 4 (2 R + bit); s has its two low bits clear
  }
  rem = r;
  return static_cast<uint16_t>(s >> 2);
}

#if defined(__AVR__)
// The same on the AVR in ~60 instructions (~300 cycles with the call). The remainder and 4R grow
// a bit a step (below 2^(k+3) in step k), so they are kept as narrow as they can be: one byte in
// the first four steps (n's top byte), two in the next eight (its bytes 2 and 1), three in the
// last four (its byte 0). The bits of n are shifted out of the top of those bytes straight into
// the remainder, never a 32-bit shift of n.
__attribute__((noinline)) inline uint16_t isqrt32(uint32_t n, uint32_t& rem) {
  // Ten registers, placed so that with rem's address (Z) they are the call-clobbered ones: none
  // saved (4R's bytes apart: a 3-byte value starts at an even register). The steps are counted
  // in a byte not yet (r's top) or no longer (n's top) used, 0 again when they end.
  register uint32_t nr __asm__("r22") = n;
  register __uint24 r __asm__("r18");  // the remainder
  register uint8_t s0 __asm__("r26");  // 4 R
  register uint8_t s1 __asm__("r27");
  register uint8_t s2 __asm__("r21");
  __asm__(
      "clr  %A[r]         \n\t"
      "clr  %B[r]         \n\t"
      "ldi  %C[r], 4      \n\t"
      "clr  %[s0]         \n\t"
      "clr  %[s1]         \n\t"
      "clr  %[s2]         \n\t"
      "1:                 \n\t"  // bits 15..12 of the root from n's byte 3
      "lsl  %D[n]         \n\t"
      "rol  %A[r]         \n\t"
      "lsl  %D[n]         \n\t"
      "rol  %A[r]         \n\t"
      "cp   %[s0], %A[r]  \n\t"  // 4R < r: the bit is 1
      "brcc 2f            \n\t"
      "sec                \n\t"  // r -= 4R + 1
      "sbc  %A[r], %[s0]  \n\t"
      "ori  %[s0], 2      \n\t"
      "2:                 \n\t"
      "lsl  %[s0]         \n\t"
      "dec  %C[r]         \n\t"
      "brne 1b            \n\t"
      "ldi  %D[n], 8      \n\t"  // n's top byte is shifted out
      "3:                 \n\t"  // bits 11..4 from n's bytes 2, 1
      "lsl  %B[n]         \n\t"
      "rol  %C[n]         \n\t"
      "rol  %A[r]         \n\t"
      "rol  %B[r]         \n\t"
      "lsl  %B[n]         \n\t"
      "rol  %C[n]         \n\t"
      "rol  %A[r]         \n\t"
      "rol  %B[r]         \n\t"
      "cp   %[s0], %A[r]  \n\t"
      "cpc  %[s1], %B[r]  \n\t"
      "brcc 4f            \n\t"
      "sec                \n\t"
      "sbc  %A[r], %[s0]  \n\t"
      "sbc  %B[r], %[s1]  \n\t"
      "ori  %[s0], 2      \n\t"
      "4:                 \n\t"
      "lsl  %[s0]         \n\t"
      "rol  %[s1]         \n\t"
      "dec  %D[n]         \n\t"
      "brne 3b            \n\t"
      "ldi  %D[n], 4      \n\t"
      "5:                 \n\t"  // bits 3..0 from n's byte 0
      "lsl  %A[n]         \n\t"
      "rol  %A[r]         \n\t"
      "rol  %B[r]         \n\t"
      "rol  %C[r]         \n\t"
      "lsl  %A[n]         \n\t"
      "rol  %A[r]         \n\t"
      "rol  %B[r]         \n\t"
      "rol  %C[r]         \n\t"
      "cp   %[s0], %A[r]  \n\t"
      "cpc  %[s1], %B[r]  \n\t"
      "cpc  %[s2], %C[r]  \n\t"
      "brcc 6f            \n\t"
      "sec                \n\t"
      "sbc  %A[r], %[s0]  \n\t"
      "sbc  %B[r], %[s1]  \n\t"
      "sbc  %C[r], %[s2]  \n\t"
      "ori  %[s0], 2      \n\t"
      "6:                 \n\t"
      "lsl  %[s0]         \n\t"
      "rol  %[s1]         \n\t"
      "rol  %[s2]         \n\t"
      "dec  %D[n]         \n\t"
      "brne 5b            \n\t"
      "lsr  %[s2]         \n\t"  // R = 4R / 4
      "ror  %[s1]         \n\t"
      "ror  %[s0]         \n\t"
      "lsr  %[s2]         \n\t"
      "ror  %[s1]         \n\t"
      "ror  %[s0]         \n\t"
      : [r] "=&d"(r), [s0] "=&d"(s0), [s1] "=&r"(s1), [s2] "=&r"(s2), [n] "+d"(nr));
  (void)s2;
  rem = r;
  return static_cast<uint16_t>((s1 << 8) | s0);
}
#else
inline uint16_t isqrt32(uint32_t n, uint32_t& rem) { return isqrt32_portable(n, rem); }
#endif

// The kernels of cos_ramp and cos_ramp_inv on the lower half, x in Q0.32 (x32 <= 2^31) -> the
// ramp in Q0.32 (<= 2^31), one copy of what the two share: the square of x's top 16 bits, its
// top half times a constant, the 32x16 products at the end.
//
// Inverse ramp: g = acos(1 - 2y) / pi = (2/pi) asin(sqrt(y)) for y in [0, 0.5]. g = sqrt(y) R(y),
// R a minimax fit on powers {0, 1, 2, 4} of y (|error of g| <= 1.9e-6), on y's top 16 bits; the
// root of all of y32. All coefficients are positive and every product rounds down, so g is
// non-decreasing in y by construction (the model needs monotone inverse ramps).
// R(y) = r0 + y (r1 + y (r2 + y^2 r4)), r0 = 0.63662460556, r1 = 0.10561080269,
// r2 = 0.05413052369, r4 = 0.06626434138.
constexpr uint32_t kRampR0 = UINT32_C(2734281861);  // r0 in Q0.32
constexpr uint16_t kRampR1 = 27685;                 // r1 in Q0.18
constexpr uint16_t kRampR2 = 28380;                 // r2 in Q0.19
constexpr uint16_t kRampR4 = 34742;                 // r4 in Q0.19
//
// Haversine ramp: h(x) = 0.5 [1 - cos(pi x)], from x's top 16 bits xm. (2x)^2 in Q0.30 equals x^2
// in Q0.32: the product of the Q0.16 raw values, exactly. h = w B = 4 x^2 B in Q0.30 is x^2 B in
// Q0.32: B = b0 - w q18 (haversine_b32), then B x, then B x^2, three 32x16 products in a loop
// (their floors lose < 2^-29 of h; a full 32x32 grid would cost ~150 B more). h < 2^30 in Q0.30
// (B < b0 < 2^32 times x <= 1/2 twice), so the shift to Q0.32 keeps every bit.
//
// The products after the root (s: sqrt(y) rounded, Q0.16; the inverse's only). Portable version;
// on the AVR the reference the benchmark checks the assembly against.
inline uint32_t ramp_products_portable(uint16_t xm, uint16_t s, bool inverse) {
  const uint32_t sq = mul16(xm, xm);  // x^2 in Q0.32
  uint32_t v;
  uint16_t factor;
  uint8_t i = 0;  // the haversine's three products; the inverse's last one
  if (inverse) {
    const uint32_t p = mul16(hi16(sq), kRampR4);                                         // y^2 r4, Q0.19
    const uint16_t t19 = static_cast<uint16_t>(kRampR2 + hi16(p));                      // Q0.19
    const uint16_t t18 = static_cast<uint16_t>(kRampR1 + (hi16(mul16(xm, t19)) >> 1));  // Q0.18
    v = kRampR0 + (mul16(xm, t18) >> 2);                                                 // Q0.32
    factor = s;
    i = 2;  // R sqrt(y)
  } else {
    v = sq;
    factor = haversine_q18(hi16(sq));  // w = 4 x^2 in Q2.14 is x^2's top 16 bits
  }
  for (; i < 3; ++i) {
    v = mul32x16_portable(v, factor);
    if (i == 0) v = kHaversineB0 - v;
    factor = xm;
  }
  if (!inverse) v <<= 2;               // Q0.30 -> Q0.32
  return v < kHalfQ32 ? v : kHalfQ32;  // <= 0.5 keeps the mirrored upper half monotone
}
#if defined(__AVR__) && defined(__AVR_HAVE_MUL__)
// The same in one assembly block whose products all call one local 16x16 routine (label 7): one
// copy of its four MULs instead of one per product, ~7 cycles of rcall and ret a product, and
// no registers saved around it. A 32x16 product is two of them:
// floor(v b / 2^16) = hi16(v) b + floor(lo16(v) b / 2^16).
inline uint32_t ramp_products(uint16_t xm, uint16_t s, bool inverse) {
  uint32_t v;  // the result
  uint32_t p;  // the routine's product
  uint16_t a;  // its operands
  uint16_t b;
  uint8_t i;
  __asm__(
      "movw %A[a], %A[x]  \n\t"
      "movw %A[b], %A[x]  \n\t"
      "rcall 7f           \n\t"  // x^2
      "movw %A[v], %A[p]  \n\t"
      "movw %C[v], %C[p]  \n\t"
      "movw %A[a], %C[p]  \n\t"
      "ldi  %A[b], lo8(%[kb2]) \n\t"
      "ldi  %B[b], hi8(%[kb2]) \n\t"
      "tst  %[inv]        \n\t"
      "breq 1f            \n\t"
      "ldi  %A[b], lo8(%[kr4]) \n\t"
      "ldi  %B[b], hi8(%[kr4]) \n\t"
      "1:                 \n\t"
      "rcall 7f           \n\t"  // hi16(x^2) r4 or b2
      "ldi  %[i], 0       \n\t"
      "tst  %[inv]        \n\t"
      "breq 2f            \n\t"
      "movw %A[b], %C[p]  \n\t"  // inverse: t19 = r2 + hi16(p)
      "subi %A[b], lo8(-(%[kr2])) \n\t"
      "sbci %B[b], hi8(-(%[kr2])) \n\t"
      "movw %A[a], %A[x]  \n\t"
      "rcall 7f           \n\t"  // x t19
      "movw %A[b], %C[p]  \n\t"  // t18 = r1 + hi16(x t19) / 2
      "lsr  %B[b]         \n\t"
      "ror  %A[b]         \n\t"
      "subi %A[b], lo8(-(%[kr1])) \n\t"
      "sbci %B[b], hi8(-(%[kr1])) \n\t"
      "rcall 7f           \n\t"  // x t18
      "lsr  %D[p]         \n\t"
      "ror  %C[p]         \n\t"
      "ror  %B[p]         \n\t"
      "ror  %A[p]         \n\t"
      "lsr  %D[p]         \n\t"
      "ror  %C[p]         \n\t"
      "ror  %B[p]         \n\t"
      "ror  %A[p]         \n\t"
      "movw %A[v], %A[p]  \n\t"  // v = r0 + x t18 / 4
      "movw %C[v], %C[p]  \n\t"
      "subi %A[v], lo8(-(%[kr0])) \n\t"
      "sbci %B[v], hi8(-(%[kr0])) \n\t"
      "sbci %C[v], hlo8(-(%[kr0])) \n\t"
      "sbci %D[v], hhi8(-(%[kr0])) \n\t"
      "movw %A[b], %A[s]  \n\t"
      "ldi  %[i], 2       \n\t"
      "rjmp 3f            \n\t"
      "2:                 \n\t"  // haversine: b1 - hi16(p + 2^15)
      "lsl  %B[p]         \n\t"
      "adc  %C[p], r1     \n\t"  // r1 is zero after the routine
      "adc  %D[p], r1     \n\t"
      "ldi  %A[b], lo8(%[kb1]) \n\t"
      "ldi  %B[b], hi8(%[kb1]) \n\t"
      "sub  %A[b], %C[p]  \n\t"
      "sbc  %B[b], %D[p]  \n\t"
      "3:                 \n\t"  // v = floor(v b / 2^16)
      "movw %A[a], %A[v]  \n\t"
      "rcall 7f           \n\t"  // lo16(v) b
      "movw %A[a], %C[v]  \n\t"
      "movw %A[v], %C[p]  \n\t"
      "rcall 7f           \n\t"  // hi16(v) b
      "add  %A[p], %A[v]  \n\t"
      "adc  %B[p], %B[v]  \n\t"
      "adc  %C[p], r1     \n\t"
      "adc  %D[p], r1     \n\t"
      "movw %A[v], %A[p]  \n\t"
      "movw %C[v], %C[p]  \n\t"
      "tst  %[i]          \n\t"
      "brne 4f            \n\t"
      "ldi  %A[v], lo8(%[b0])  \n\t"  // the first: v = b0 - v
      "ldi  %B[v], hi8(%[b0])  \n\t"
      "ldi  %C[v], hlo8(%[b0]) \n\t"
      "ldi  %D[v], hhi8(%[b0]) \n\t"
      "sub  %A[v], %A[p]  \n\t"
      "sbc  %B[v], %B[p]  \n\t"
      "sbc  %C[v], %C[p]  \n\t"
      "sbc  %D[v], %D[p]  \n\t"
      "4:                 \n\t"
      "movw %A[b], %A[x]  \n\t"
      "inc  %[i]          \n\t"
      "cpi  %[i], 3       \n\t"
      "brlo 3b            \n\t"
      "tst  %[inv]        \n\t"
      "brne 5f            \n\t"
      "lsl  %A[v]         \n\t"  // Q0.30 -> Q0.32
      "rol  %B[v]         \n\t"
      "rol  %C[v]         \n\t"
      "rol  %D[v]         \n\t"
      "lsl  %A[v]         \n\t"
      "rol  %B[v]         \n\t"
      "rol  %C[v]         \n\t"
      "rol  %D[v]         \n\t"
      "5:                 \n\t"
      "sbrs %D[v], 7      \n\t"  // at most 2^31
      "rjmp 8f            \n\t"
      "clr  %A[v]         \n\t"
      "clr  %B[v]         \n\t"
      "clr  %C[v]         \n\t"
      "ldi  %D[v], 0x80   \n\t"
      "rjmp 8f            \n\t"
      "7:                 \n\t"  // p = a b, r1 = 0 on return
      "mul  %A[a], %A[b]  \n\t"
      "movw %A[p], r0     \n\t"
      "mul  %B[a], %B[b]  \n\t"
      "movw %C[p], r0     \n\t"
      "mul  %A[a], %B[b]  \n\t"
      "add  %B[p], r0     \n\t"
      "adc  %C[p], r1     \n\t"
      "clr  r1            \n\t"
      "adc  %D[p], r1     \n\t"
      "mul  %B[a], %A[b]  \n\t"
      "add  %B[p], r0     \n\t"
      "adc  %C[p], r1     \n\t"
      "clr  r1            \n\t"
      "adc  %D[p], r1     \n\t"
      "ret                \n\t"
      "8:                 \n\t"
      : [v] "=&d"(v), [p] "=&r"(p), [a] "=&r"(a), [b] "=&d"(b), [i] "=&d"(i)
      : [x] "r"(xm), [s] "r"(s), [inv] "r"(static_cast<uint8_t>(inverse)), [kr0] "n"(kRampR0),
        [kr1] "n"(kRampR1), [kr2] "n"(kRampR2), [kr4] "n"(kRampR4), [kb1] "n"(kHaversineB1),
        [kb2] "n"(kHaversineB2), [b0] "n"(kHaversineB0)
      : "r0");
  return v;
}
#else
inline uint32_t ramp_products(uint16_t xm, uint16_t s, bool inverse) { return ramp_products_portable(xm, s, inverse); }
#endif
inline uint32_t ramp_kernel_q32(uint32_t x32, bool inverse) {
  uint16_t s = 0;
  if (inverse) {
    uint32_t rem;
    const uint16_t root = isqrt32(x32, rem);  // floor(sqrt(y)) in Q0.16
    // Round to nearest (still monotone); y <= 1/2 keeps the result below 2^16.
    s = static_cast<uint16_t>(root + (rem > root ? 1u : 0u));
  }
  return ramp_products(hi16(x32), s, inverse);
}
inline uint32_t ramp_inv_q32(uint32_t y32) { return ramp_kernel_q32(y32, true); }

// 2^f for f in [0, 1) given in Q0.16; returns Q2.30 (in [2^30, 2^31)). Degree-5 minimax fit,
// |error| <= 1.1e-7; inner Horner steps on 16 bits with per-step scaling, the last two on 32.
inline uint32_t exp2_frac_q30(uint16_t f16) {
  constexpr uint32_t kC0 = UINT32_C(1073741709);  // 0.99999989312 in Q2.30
  constexpr uint32_t kC1 = UINT32_C(1488538496);  // 0.69315475236 in Q1.31
  constexpr uint16_t kC2 = 31476;                 // 0.24013971157 in Q0.17
  constexpr uint16_t kC3 = 29290;                 // 0.05586624560 in Q0.19
  constexpr uint16_t kC4 = 37509;                 // 0.00894282930 in Q0.22
  constexpr uint16_t kC5 = 31817;                 // 0.00189646117 in Q0.24
  const uint16_t a4 = static_cast<uint16_t>(kC4 + (hi16(mul16(f16, kC5)) >> 2));  // Q0.22
  const uint16_t a3 = static_cast<uint16_t>(kC3 + (hi16(mul16(f16, a4)) >> 3));   // Q0.19
  const uint16_t a2 = static_cast<uint16_t>(kC2 + (hi16(mul16(f16, a3)) >> 2));   // Q0.17
  const uint32_t a1 = kC1 + (mul16(f16, a2) >> 2);                                // Q1.31
  return kC0 + (mul32x16(a1, f16) >> 1);                                          // Q2.30
}

}  // namespace fixed_detail

// ---- math overloads found by ADL ------------------------------------------------------------

// cos(x) for any x, |error| < 2.5e-5 (measured in test_fixed.cpp). The phase is reduced in turns
// to 2^-32, so large angles lose nothing beyond what their Q16.16 value already lost.
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

namespace fixed_detail {
// The rest of both ramps, one copy for the two: x clamped to [0, 1], the mirror symmetry
// f(1 - x) = 1 - f(x) so the kernel only sees x <= 0.5, the kernel's Q0.32 rounded to Q16.16.
// Non-decreasing in x when the kernel is (checked exhaustively by the tests).
__attribute__((noinline)) inline Fixed mirrored_ramp(Fixed x, bool inverse) {
  const int32_t r = x.raw();
  if (r <= 0) return Fixed::from_raw(0);
  if (r >= kRawOne) return Fixed::from_raw(kRawOne);
  const uint16_t r16 = lo16(static_cast<uint32_t>(r));  // 0 < r < 1: the fraction alone
  const bool upper = r16 > 0x8000u;
  const uint16_t xm = upper ? static_cast<uint16_t>(0u - r16) : r16;  // Q0.16, <= 0.5
  const int32_t h = static_cast<int32_t>(hi16(ramp_kernel_q32(static_cast<uint32_t>(xm) << 16, inverse) + 0x8000u));
  return Fixed::from_raw(upper ? kRawOne - h : h);
}
}  // namespace fixed_detail

// cos_ramp(x) = 0.5 [1 - cos(pi x)] for x clamped to [0, 1] (eqs 2, 3 and 11). Hot path: one
// haversine kernel, no range reduction.
inline Fixed cos_ramp(Fixed x) { return fixed_detail::mirrored_ramp(x, false); }

// cos_ramp_inv(y) = acos(1 - 2y) / pi for y clamped to [0, 1] (eqs 15 and 16): the inverse of
// cos_ramp. The kernel needs one 16-bit integer square root.
inline Fixed cos_ramp_inv(Fixed y) { return fixed_detail::mirrored_ramp(y, true); }

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
// sqrt(r / 2^16) * 2^16 = sqrt(r * 2^16), a 48-bit radicand: shift r up by as many bit pairs as
// fit (j <= 8), take the exact 32-bit root, then produce the missing 8 - j bits digit by digit
// (none for x < 1, one for x < 4, ...).
inline Fixed sqrt(Fixed x) {
  using namespace fixed_detail;
  if (x.raw() <= 0) return Fixed::from_raw(0);
  uint32_t n = static_cast<uint32_t>(x.raw());
  uint8_t pairs_left = 8;
  if (n < (UINT32_C(1) << 16)) {
    n <<= 16;
    pairs_left = 0;
  } else {
    // Up by bit pairs until n >= 2^30 (at most 7 pairs from n >= 2^16): 4, 2, then 1 pair at a
    // time, not a loop of 2-bit shifts (each a loop of its own on the AVR).
    if (n < (UINT32_C(1) << 24)) {
      n <<= 8;
      pairs_left = 4;
    }
    if (n < (UINT32_C(1) << 28)) {
      n <<= 4;
      pairs_left = static_cast<uint8_t>(pairs_left - 2);
    }
    if (n < (UINT32_C(1) << 30)) {
      n <<= 2;
      --pairs_left;
    }
  }
  uint32_t rem_out;
  uint32_t root = isqrt32(n, rem_out);
  uint32_t rem = rem_out;  // a copy the loop keeps in registers (isqrt32 writes rem_out in memory)
  // Remaining digits: the radicand continues with zero bits. rem <= 2 root < 2^25, so 4 rem fits.
  for (; pairs_left != 0; --pairs_left) {
    rem <<= 2;
    root <<= 1;
    const uint32_t trial = (root << 1) | 1u;  // 2 root + 1 (root already doubled)
    if (rem >= trial) {
      rem -= trial;
      root |= 1u;
    }
  }
  if (rem > root) ++root;  // (root + 1/2)^2 < radicand  <=>  rem > root
  return Fixed::from_raw(static_cast<int32_t>(root));
}

// exp(x) = 2^(x log2 e) = 2^k * 2^f. Absolute error ~1 LSB for x <= 0, which is what the model
// uses (exp(-dt / tau)); relative error < 1e-4 above. Saturates for x > ln 32768 (about 10.397)
// and returns 0 below -12 (the result is under half an LSB there).
inline Fixed exp(Fixed x) {
  using namespace fixed_detail;
  if (x.raw() < -12 * kRawOne) return Fixed::from_raw(0);
  if (x.raw() > 11 * kRawOne) return Fixed::max();
  constexpr int32_t kLog2eQ16 = 94548;  // log2(e) in Q16.16
  const int32_t t = mul_raw(x.raw(), kLog2eQ16);  // |t| < 18
  // k = floor(t) without shifting a negative value: bias t to be non-negative first.
  const int32_t k = static_cast<int32_t>(hi16(static_cast<uint32_t>(t + 32 * kRawOne))) - 32;
  const uint32_t p30 = exp2_frac_q30(lo16(static_cast<uint32_t>(t)));  // 2^f, Q2.30
  if (k >= 15) return Fixed::max();
  const int32_t shift = 14 - k;  // Q2.30 * 2^k -> Q16.16
  if (shift <= 0) return Fixed::from_raw(static_cast<int32_t>(p30));
  if (shift >= 32) return Fixed::from_raw(0);
  const uint32_t half = UINT32_C(1) << (shift - 1);
  return Fixed::from_raw(static_cast<int32_t>((p30 + half) >> shift));
}

}  // namespace sma

#undef SMA_FIXED_AVR_PRODUCT_GRID
#undef SMA_FIXED_ALWAYS_INLINE

#endif  // SMA_FIXED_HPP
