// AVR cycle benchmark: sma::Fixed vs soft float on the ATmega328P.
//
// Bare-metal program (no Arduino core), meant to run in simavr under cycles.c, which reads the
// exact cycle counter. Protocol, through the otherwise unused general-purpose I/O registers:
//   GPIOR1 <- the characters of a group name, then 0   (starts a new group)
//   GPIOR0 <- 1 just before one operation, 2 just after (one sample of the current group)
// A group whose name starts with "base" measures only the loads/stores around an operation; the
// host subtracts the latest baseline from the groups that follow it.
//   GPIOR2 <- at the end: the number of self-check mismatches, then the 4 bytes (LSB first) of
//             sweep::fixed_results_hash()
// The self-check runs the AVR assembly paths of fixed.hpp (mul16, mul32x16, mulhi32, the Q16.16
// multiply and division, the saturating add and subtract, the integer square root; the float <->
// Q16.16 conversions by integer shifts) against their portable C versions (the conversions: also
// the float arithmetic) on pseudo-random operands: host tests cannot execute the assembly.
// The hash fingerprints every Fixed operation's results; sweep_host prints the host's, and the
// CTest test requires them to be equal (bit-identical results on the host and the AVR).
//
// Inputs are read from volatile arrays and results written to volatile sinks, so nothing can be
// constant-folded or hoisted out of the marker pair; the operations themselves are compiled as
// the model would compile them (-Os, inlined or called as the compiler decides).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "sma/fixed.hpp"
#include "sma/float_from_int.hpp"
#include "sweep.hpp"

using sma::Fixed;

// The Q16.16 image's int -> float conversions under names of their own, so that the
// compiler's casts here still run avr-libc's (the reference).
extern "C" float sma_float_from_u32(uint32_t u);
extern "C" float sma_float_from_i32(int32_t v);
extern "C" float sma_float_from_q16_test(int32_t raw);
__asm__(SMA_FLOAT_FROM_INT_ASM("sma_float_from_u32", "sma_float_from_i32", "sma_float_from_q16_test"));

namespace {

constexpr uint8_t kSamples = 8;

// Binary-operation operands: mixed signs and magnitudes, small values, one saturating product.
volatile float g_fa[kSamples] = {1.5f, -3.25f, 0.001f, 123.4f, -0.7f, 2.0f, 250.0f, -17.0f};
volatile float g_fb[kSamples] = {2.25f, 0.7f, 0.5f, -0.03f, -1.9f, 3.0f, 300.0f, 0.125f};
// Unit-interval arguments for the ramps, acos(1 - 2y), cos etc. Interior points: the clamped
// ends (0 and 1) return early and would flatter the fixed-point means.
volatile float g_fu[kSamples] = {0.01f, 0.05f, 0.2f, 0.4999f, 0.5f, 0.73f, 0.95f, 0.99f};
// Positive arguments for sqrt.
volatile float g_fs[kSamples] = {0.0001f, 0.02f, 0.5f, 1.0f, 2.0f, 77.7f, 1000.0f, 30000.0f};
// Negative arguments for exp(-dt / tau).
volatile float g_fe[kSamples] = {0.0f, -0.01f, -0.1f, -0.5f, -1.0f, -3.0f, -7.5f, -11.0f};

#define SMA_FIXED_RAW(x) Fixed(x).raw()
volatile int32_t g_xa[kSamples] = {
    SMA_FIXED_RAW(1.5), SMA_FIXED_RAW(-3.25), SMA_FIXED_RAW(0.001), SMA_FIXED_RAW(123.4),
    SMA_FIXED_RAW(-0.7), SMA_FIXED_RAW(2.0), SMA_FIXED_RAW(250.0), SMA_FIXED_RAW(-17.0)};
volatile int32_t g_xb[kSamples] = {
    SMA_FIXED_RAW(2.25), SMA_FIXED_RAW(0.7), SMA_FIXED_RAW(0.5), SMA_FIXED_RAW(-0.03),
    SMA_FIXED_RAW(-1.9), SMA_FIXED_RAW(3.0), SMA_FIXED_RAW(300.0), SMA_FIXED_RAW(0.125)};
volatile int32_t g_xu[kSamples] = {
    SMA_FIXED_RAW(0.01), SMA_FIXED_RAW(0.05), SMA_FIXED_RAW(0.2), SMA_FIXED_RAW(0.4999),
    SMA_FIXED_RAW(0.5), SMA_FIXED_RAW(0.73), SMA_FIXED_RAW(0.95), SMA_FIXED_RAW(0.99)};
volatile int32_t g_xs[kSamples] = {
    SMA_FIXED_RAW(0.0001), SMA_FIXED_RAW(0.02), SMA_FIXED_RAW(0.5), SMA_FIXED_RAW(1.0),
    SMA_FIXED_RAW(2.0), SMA_FIXED_RAW(77.7), SMA_FIXED_RAW(1000.0), SMA_FIXED_RAW(30000.0)};
volatile int32_t g_xe[kSamples] = {
    SMA_FIXED_RAW(0.0), SMA_FIXED_RAW(-0.01), SMA_FIXED_RAW(-0.1), SMA_FIXED_RAW(-0.5),
    SMA_FIXED_RAW(-1.0), SMA_FIXED_RAW(-3.0), SMA_FIXED_RAW(-7.5), SMA_FIXED_RAW(-11.0)};
#undef SMA_FIXED_RAW

volatile float g_fsink;
volatile int32_t g_xsink;
uint32_t g_rem;

void group(const char* name) {
  while (*name != '\0') GPIOR1 = static_cast<uint8_t>(*name++);
  GPIOR1 = 0;
}

inline Fixed fx(volatile int32_t* v, uint8_t i) { return Fixed::from_raw(v[i]); }

// xorshift32: operands spread over all magnitudes (random right shift) and both signs.
uint32_t g_rng = 2463534242u;
uint32_t next_random() {
  g_rng ^= g_rng << 13;
  g_rng ^= g_rng >> 17;
  g_rng ^= g_rng << 5;
  return g_rng;
}
int32_t random_operand() {
  const uint32_t r = next_random();
  const int32_t v = static_cast<int32_t>(r >> (next_random() & 31u));
  return (next_random() & 1u) != 0 ? -v : v;
}

uint32_t bits_of(float f) {
  uint32_t b;
  __builtin_memcpy(&b, &f, 4);
  return b;
}

// The int -> float conversions against avr-libc's casts and against the portable version.
uint8_t float_from_int_mismatches(uint32_t u) {
  uint8_t n = 0;
  const uint32_t want_u = bits_of(static_cast<float>(u));
  if (bits_of(sma_float_from_u32(u)) != want_u) ++n;
  if (sma::fixed_detail::float_bits_from_u32(u) != want_u) ++n;
  const int32_t v = static_cast<int32_t>(u);
  if (bits_of(sma_float_from_i32(v)) != bits_of(static_cast<float>(v))) ++n;
  // Q16.16: Fixed's conversion here is avr-libc's cast and the exponent change.
  if (bits_of(sma_float_from_q16_test(v)) != bits_of(static_cast<float>(Fixed::from_raw(v)))) ++n;
  return n;
}

// Plain C 16x16 product in a separate function, so avr-gcc uses libgcc's __umulhisi3.
__attribute__((noinline)) uint32_t mul16_libgcc(uint16_t a, uint16_t b) {
  return static_cast<uint32_t>(a) * b;
}

uint8_t self_check() {
  uint16_t mismatches = 0;
  const int32_t edges[] = {0,          1,          -1,          INT32_C(65536), -INT32_C(65536),
                           INT32_MAX,  INT32_MIN,  INT32_C(0x7FFF8000),  INT32_C(181) * 65536,
                           INT32_C(-182) * 65536,  INT32_C(0x8000),      INT32_C(0x18000),
                           INT32_C(-0x8000),     INT32_C(0xFFFFFF),    INT32_C(-0xFFFFFF),
                           INT32_C(0x1000000),   INT32_C(-0x1000000),  INT32_C(0x7FFFFF),
                           INT32_C(-0x800000)};
  constexpr uint8_t kEdges = sizeof(edges) / sizeof(edges[0]);
  for (uint8_t i = 0; i < kEdges; ++i) {
    for (uint8_t j = 0; j < kEdges; ++j) {
      if (sma::fixed_detail::mul_raw(edges[i], edges[j]) !=
          sma::fixed_detail::mul_raw_portable(edges[i], edges[j])) {
        ++mismatches;
      }
      // The saturating add and subtract: the edges overflow both ways.
      if (sma::fixed_detail::add_raw(edges[i], edges[j]) !=
          sma::fixed_detail::add_raw_portable(edges[i], edges[j])) {
        ++mismatches;
      }
      if (sma::fixed_detail::sub_raw(edges[i], edges[j]) !=
          sma::fixed_detail::sub_raw_portable(edges[i], edges[j])) {
        ++mismatches;
      }
      if (sma::fixed_detail::div_raw(edges[i], edges[j]) !=
          sma::fixed_detail::div_raw_portable(edges[i], edges[j])) {
        ++mismatches;
      }
    }
  }
  // Every magnitude near its ties: 2^k - 1 .. 2^k + 2, and the odd and even halves above 2^24.
  for (uint8_t k = 0; k < 32; ++k) {
    const uint32_t p = UINT32_C(1) << k;
    for (uint32_t d = 0; d < 4; ++d) mismatches += float_from_int_mismatches(p - 1u + d);
    const uint32_t half = p >> 24;  // half of the last of 24 kept bits when the top bit is k >= 24
    if (half != 0) {
      for (uint32_t d = 0; d < 4; ++d) {
        mismatches += float_from_int_mismatches(p + (2u * d + 1u) * half);
        mismatches += float_from_int_mismatches(p + (2u * d + 1u) * half - 1u);
        mismatches += float_from_int_mismatches(p + (2u * d + 1u) * half + 1u);
      }
    }
  }
  // The ramps' products, every input of the lower half, both kernels (s: any root).
  for (uint16_t xm = 0; xm <= 0x8000u; ++xm) {
    const uint16_t s = static_cast<uint16_t>(random_operand());
    for (uint8_t inv = 0; inv < 2; ++inv) {
      if (sma::fixed_detail::ramp_products(xm, s, inv != 0) !=
          sma::fixed_detail::ramp_products_portable(xm, s, inv != 0)) {
        ++mismatches;
      }
    }
  }
  for (uint16_t i = 0; i < 20000; ++i) {
    const int32_t a = random_operand();
    const int32_t b = random_operand();
    if (sma::fixed_detail::mul_raw(a, b) != sma::fixed_detail::mul_raw_portable(a, b)) {
      ++mismatches;
    }
    if (sma::fixed_detail::add_raw(a, b) != sma::fixed_detail::add_raw_portable(a, b)) ++mismatches;
    if (sma::fixed_detail::sub_raw(a, b) != sma::fixed_detail::sub_raw_portable(a, b)) ++mismatches;
    if (sma::fixed_detail::div_raw(a, b) != sma::fixed_detail::div_raw_portable(a, b)) ++mismatches;
    // The ADC mean's division (Fixed ratio): numerators below d 2^15.
    const uint8_t d = static_cast<uint8_t>(b) != 0 ? static_cast<uint8_t>(b) : static_cast<uint8_t>(1);
    const uint32_t n = static_cast<uint32_t>(a) % (static_cast<uint32_t>(d) << 15);
    if (sma::fixed_detail::ratio_q17(n, d) != sma::fixed_detail::ratio_q17_portable(n, d)) ++mismatches;
    const uint32_t n10 = static_cast<uint32_t>(a) % (static_cast<uint32_t>(d) << 10);  // a mean below 1024
    if (sma::fixed_detail::fraction_q7(n10, d) != sma::fixed_detail::fraction_q7_portable(n10, d)) ++mismatches;
    const uint16_t x = static_cast<uint16_t>(a);
    const uint16_t y = static_cast<uint16_t>(b);
    if (sma::fixed_detail::mul16(x, y) != mul16_libgcc(x, y)) ++mismatches;
    const uint32_t ua = static_cast<uint32_t>(a);
    const uint32_t ub = static_cast<uint32_t>(b);
    if (sma::fixed_detail::mul32x16(ua, y) != sma::fixed_detail::mul32x16_portable(ua, y)) {
      ++mismatches;
    }
    if (sma::fixed_detail::mulhi32(ua, ub) != sma::fixed_detail::mulhi32_portable(ua, ub)) {
      ++mismatches;
    }
    // The square root's digits.
    uint32_t rem, rem_c;
    if (sma::fixed_detail::isqrt32(ua, rem) != sma::fixed_detail::isqrt32_portable(ua, rem_c) ||
        rem != rem_c) {
      ++mismatches;
    }
    // The run-time conversions by integer shifts against the float arithmetic they replace
    // (exact below 128, where x 2^16 + 1/2 needs no rounding in float).
    const Fixed q = Fixed::from_raw(a);
    if (static_cast<float>(q) != static_cast<float>(a) * (1.0f / 65536.0f)) ++mismatches;
    const float f = static_cast<float>(b) * (0.0037f / 65536.0f);
    if (sma::fixed_from_float(f).raw() != sma::fixed_detail::raw_from_double(f)) ++mismatches;
    // Every exponent (NaN, inf, saturation, zero, denormals): the shifts against the C version.
    if (sma::fixed_detail::raw_from_float_bits(ua) !=
        sma::fixed_detail::raw_from_float_bits_portable(ua)) {
      ++mismatches;
    }
    const uint32_t near_range = (ua & 0x807FFFFFu) | ((100u + (ub & 63u)) << 23);  // e 100..163
    if (sma::fixed_detail::raw_from_float_bits(near_range) !=
        sma::fixed_detail::raw_from_float_bits_portable(near_range)) {
      ++mismatches;
    }
    // The int -> float conversions: every magnitude (a's random shift), both signs.
    mismatches += float_from_int_mismatches(ua);
    mismatches += float_from_int_mismatches(ua ^ ub);
    // The truncating conversion (the Q16.16 image's float -> integer): every exponent, and 1..2^32.
    if (sma::fixed_detail::trunc_u32_from_float_bits(ua) !=
        sma::fixed_detail::trunc_u32_from_float_bits_portable(ua)) {
      ++mismatches;
    }
    const uint32_t to_2_32 = (ua & 0x807FFFFFu) | ((127u + (ub & 31u)) << 23);  // e 127..158
    if (sma::fixed_detail::trunc_u32_from_float_bits(to_2_32) !=
        sma::fixed_detail::trunc_u32_from_float_bits_portable(to_2_32)) {
      ++mismatches;
    }
  }
  return static_cast<uint8_t>(mismatches > 255 ? 255 : mismatches);
}

// The reference the notes measured: Q16.16 product through a 64-bit intermediate.
inline int32_t mul_via_int64(int32_t a, int32_t b) {
  return static_cast<int32_t>((static_cast<int64_t>(a) * b) >> 16);
}

}  // namespace

// One sample per input: markers around exactly one statement.
#define MEASURE(name, statement)                  \
  do {                                            \
    group(name);                                  \
    for (uint8_t i = 0; i < kSamples; ++i) {      \
      GPIOR0 = 1;                                 \
      statement;                                  \
      GPIOR0 = 2;                                 \
    }                                             \
  } while (0)

int main() {
  // ---- Fixed, two operands ----
  MEASURE("base.fixed2", g_xsink = g_xa[i]; (void)g_xb[i]);
  MEASURE("fixed.add", g_xsink = (fx(g_xa, i) + fx(g_xb, i)).raw());
  MEASURE("fixed.mul", g_xsink = (fx(g_xa, i) * fx(g_xb, i)).raw());
  MEASURE("fixed.mul_int64_ref", g_xsink = mul_via_int64(g_xa[i], g_xb[i]));
  MEASURE("fixed.div", g_xsink = (fx(g_xa, i) / fx(g_xb, i)).raw());
  MEASURE("fixed.from_float", g_xsink = sma::fixed_from_float(g_fa[i]).raw());
  // ---- Fixed, one operand ----
  MEASURE("base.fixed1", g_xsink = g_xu[i]);
  MEASURE("fixed.cos_ramp", g_xsink = sma::cos_ramp(fx(g_xu, i)).raw());
  MEASURE("fixed.cos_ramp_inv", g_xsink = sma::cos_ramp_inv(fx(g_xu, i)).raw());
  MEASURE("fixed.cos", g_xsink = sma::cos(fx(g_xu, i)).raw());
  MEASURE("fixed.acos", g_xsink = sma::acos(fx(g_xu, i)).raw());
  MEASURE("fixed.sqrt", g_xsink = sma::sqrt(fx(g_xs, i)).raw());
  MEASURE("fixed.isqrt32_kernel",
          g_xsink = sma::fixed_detail::isqrt32(static_cast<uint32_t>(g_xs[i]) << 8, g_rem));
  MEASURE("fixed.exp", g_xsink = sma::exp(fx(g_xe, i)).raw());
  // The generic scalar.hpp template instantiated for Fixed (what a qualified call
  // sma::cos_ramp<Fixed> would run): shows that T(0.5), T(1) and T(kPi) fold to constants.
  MEASURE("fixed.cos_ramp_generic", g_xsink = sma::cos_ramp<Fixed>(fx(g_xu, i)).raw());
  // ---- float, two operands ----
  MEASURE("base.float2", g_fsink = g_fa[i]; (void)g_fb[i]);
  MEASURE("float.add", g_fsink = g_fa[i] + g_fb[i]);
  MEASURE("float.mul", g_fsink = g_fa[i] * g_fb[i]);
  MEASURE("float.div", g_fsink = g_fa[i] / g_fb[i]);
  MEASURE("float.from_int32_libc", g_fsink = static_cast<float>(g_xa[i]));
  MEASURE("float.from_int32_sma", g_fsink = sma_float_from_i32(g_xa[i]));
  // ---- float, one operand ----
  MEASURE("base.float1", g_fsink = g_fu[i]);
  // The generic templates of scalar.hpp are what the float model runs.
  MEASURE("float.cos_ramp", g_fsink = sma::cos_ramp(static_cast<float>(g_fu[i])));
  MEASURE("float.cos_ramp_inv", g_fsink = sma::cos_ramp_inv(static_cast<float>(g_fu[i])));
  MEASURE("float.cos", g_fsink = sma::cos(static_cast<float>(g_fu[i])));
  MEASURE("float.acos", g_fsink = sma::acos(static_cast<float>(g_fu[i])));
  MEASURE("float.sqrt", g_fsink = sma::sqrt(static_cast<float>(g_fs[i])));
  MEASURE("float.exp", g_fsink = sma::exp(static_cast<float>(g_fe[i])));

  GPIOR2 = self_check();
  uint32_t hash = sweep::fixed_results_hash();
  for (uint8_t i = 0; i < 4; ++i) {
    GPIOR2 = static_cast<uint8_t>(hash);
    hash >>= 8;
  }

  // End of program: sleeping with interrupts off makes simavr stop (cpu_Done).
  cli();
  sleep_enable();
  sleep_cpu();
  for (;;) {
  }
}
