// sma::Fixed (Q16.16) against exact integer references and against <math.h> in double.
//
// Stated bounds (all absolute unless said otherwise; 1 LSB = 2^-16 = 1.53e-5):
//   conversions, + - * /        exact: equal to the correctly rounded, saturated result
//                               (* and / round half away from zero), i.e. <= 0.5 LSB
//   cos, sin                    5e-5      (measured ~2.2e-5)
//   cos_ramp                    5e-5      (measured ~1.4e-5), exhaustive on [0, 1]
//   acos                        2e-4 rad  (measured ~3.5e-5), exhaustive on [-1, 1]
//   cos_ramp_inv                1e-4      (measured ~1.6e-5), exhaustive on [0, 1]
//   cos_ramp(cos_ramp_inv(y))   5e-5 from y (measured ~3.1e-5)
//   sqrt                        0.5 LSB of the result (round to nearest), exact integer check
//   exp on [-20, 0]             2 LSB     (measured ~1 LSB); relative 1e-4 on [0, 10.39]
// cos_ramp and cos_ramp_inv are also checked to be non-decreasing over every input in [0, 1]
// (the model relies on it) and mirror-symmetric bit for bit.
// Each accuracy test prints the measured maximum error ("[ measured ]" lines).
#include <limits>
#include <cstring>
#include <gtest/gtest.h>

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <new>
#include <random>
#include <type_traits>

#include "sma/fixed.hpp"
#include "sma/float_from_int.hpp"
#include "sma/reference.hpp"

namespace {

using sma::Fixed;

constexpr double kLsb = 1.0 / 65536.0;
constexpr double kPi = 3.14159265358979323846;

// Bounds, as stated above.
constexpr double kTrigBound = 5e-5;
constexpr double kCosRampBound = 5e-5;
constexpr double kAcosBound = 2e-4;
constexpr double kCosRampInvBound = 1e-4;
constexpr double kRoundTripBound = 5e-5;
constexpr double kSqrtBoundLsb = 0.5;
constexpr double kExpBoundLsb = 2.0;
constexpr double kExpRelBound = 1e-4;

double d(Fixed x) { return static_cast<double>(x); }
Fixed raw(int64_t r) { return Fixed::from_raw(static_cast<int32_t>(r)); }

void report(const char* what, double measured, double bound) {
  printf("[ measured ] %-28s max error %.3g (bound %.3g)\n", what, measured, bound);
}

// ---- exact integer references ---------------------------------------------------------------
int32_t saturate(int64_t v) {
  return v > INT32_MAX ? INT32_MAX : v < INT32_MIN ? INT32_MIN : static_cast<int32_t>(v);
}
// round(n / 2^s) with ties away from zero, for |n| < 2^63.
int64_t round_shift(int64_t n, int s) {
  const int64_t half = int64_t{1} << (s - 1);
  return n >= 0 ? (n + half) >> s : -((-n + half) >> s);
}
int32_t ref_mul(int32_t a, int32_t b) {
  return saturate(round_shift(static_cast<int64_t>(a) * b, 16));
}
int32_t ref_div(int32_t a, int32_t b) {
  if (b == 0) return a < 0 ? INT32_MIN : INT32_MAX;
  // |a| * 2^17 < 2^49: the quotient with one extra bit, then round half away from zero.
  const int64_t n = static_cast<int64_t>(a) * 131072;
  const int64_t q2 = n / b;  // truncated toward zero, one extra bit
  const int64_t q = q2 >= 0 ? (q2 + 1) / 2 : -((-q2 + 1) / 2);
  return saturate(q);
}
uint64_t isqrt64(uint64_t n) {
  uint64_t r = static_cast<uint64_t>(sqrtl(static_cast<long double>(n)));
  while (r * r > n) --r;
  while ((r + 1) * (r + 1) <= n) ++r;
  return r;
}

// Operands spread over all magnitudes and signs (a random right shift of a random word).
class Operands {
 public:
  int32_t next() {
    const uint32_t w = static_cast<uint32_t>(gen_());
    const int32_t v = static_cast<int32_t>(w >> (gen_() % 32u));
    return (gen_() & 1u) != 0 ? -v : v;
  }

 private:
  std::mt19937 gen_{12345u};
};

const int32_t kEdges[] = {0,          1,          -1,         2,         -2,        0x7FFF,
                          0x8000,     -0x8000,    0xFFFF,     0x10000,   -0x10000,  0x18000,
                          0x7FFFFFFF, INT32_MIN,  -0x7FFFFFFF, 0x7FFF0000, 181 << 16,
                          -(182 << 16), 0x00B504F3, 46341,    -46341,    12345678,  -87654321};

}  // namespace

// ---- conversions ------------------------------------------------------------------------------

TEST(FixedConversion, ConstexprConstructionFromDoubleAndInt) {
  static_assert(Fixed(0.5).raw() == 32768, "Fixed(double) must be constexpr");
  static_assert(Fixed(-1.25).raw() == -81920, "");
  static_assert(Fixed(2).raw() == 131072, "Fixed(int) must be constexpr");
  static_assert(Fixed::from_raw(7).raw() == 7, "");
  static_assert(Fixed().raw() == 0, "");
  static_assert(Fixed::max().raw() == INT32_MAX && Fixed::lowest().raw() == INT32_MIN, "");
  static_assert(Fixed::epsilon().raw() == 1, "");
}

// Default construction as float's: trivial (a member a constructor leaves out is not zeroed by
// code, which cost the Q16.16 Uno image ~440 B of stores the constructors overwrote), while a
// value-initialized Fixed, T() in the templates, is still 0.
TEST(FixedConversion, DefaultConstructionIsTrivialAndValueInitializationIsZero) {
  static_assert(std::is_trivially_default_constructible<Fixed>::value, "Fixed() as float's: no code");
  static_assert(Fixed().raw() == 0 && Fixed{}.raw() == 0, "value-initialized: zero");
  struct Pair {
    Fixed a, b;
  };
  Pair p;
  memset(&p, 0x5A, sizeof p);
  new (&p) Pair();  // value-initialized: every member zero
  EXPECT_EQ(p.a.raw(), 0);
  EXPECT_EQ(p.b.raw(), 0);
}

// The Q16.16 image's float -> integer conversion (trunc_u32.hpp) by integer shifts: the cast's
// value for 0 <= y < 2^32 (truncation toward zero), 0 below 1, for negative values and NaN.
TEST(FixedConversion, TruncU32FromFloatBitsIsTheCastFromOneTo2Pow32) {
  uint32_t checked = 0;
  for (uint64_t b = 0; b < 0x4F800000ull; b += 977) {  // every exponent up to 2^32, mantissas spread
    const uint32_t bits = static_cast<uint32_t>(b);
    float y;
    std::memcpy(&y, &bits, 4);
    const uint32_t want = y < 1.0f ? 0u : static_cast<uint32_t>(y);
    ASSERT_EQ(sma::fixed_detail::trunc_u32_from_float_bits_portable(bits), want) << y;
    ++checked;
  }
  EXPECT_GT(checked, 1000000u);
  const float edge[] = {1.0f, 1.5f, 2.0f, 8388607.5f, 8388608.0f, 16777215.0f, 16777216.0f,
                        2147483648.0f, 4294967040.0f, 0.99999994f, 1999999999.5f};
  for (float y : edge) {
    uint32_t bits;
    std::memcpy(&bits, &y, 4);
    EXPECT_EQ(sma::fixed_detail::trunc_u32_from_float_bits_portable(bits), static_cast<uint32_t>(y)) << y;
  }
  for (float y : {0.0f, -0.0f, 0.5f, -1.0f, -3e9f, std::numeric_limits<float>::quiet_NaN()}) {
    uint32_t bits;
    std::memcpy(&bits, &y, 4);
    EXPECT_EQ(sma::fixed_detail::trunc_u32_from_float_bits_portable(bits), 0u) << y;
  }
}

// The Q16.16 image's int -> float conversion (float_from_int.hpp; the AVR assembly is checked
// against avr-libc by bench/avr_math): IEEE round to nearest, ties to even, as the cast.
uint32_t float_bits(float f) {
  uint32_t b;
  std::memcpy(&b, &f, 4);
  return b;
}
TEST(FixedConversion, FloatFromIntRoundsToNearestEvenAsTheCast) {
  uint32_t checked = 0;
  for (uint64_t u = 0; u <= 0xFFFFFFFFull; u += 997) {  // every magnitude, low bits spread
    const uint32_t v = static_cast<uint32_t>(u);
    ASSERT_EQ(sma::fixed_detail::float_bits_from_u32(v), float_bits(static_cast<float>(v))) << v;
    const int32_t s = static_cast<int32_t>(v);
    ASSERT_EQ(sma::fixed_detail::float_bits_from_i32(s), float_bits(static_cast<float>(s))) << s;
    ++checked;
  }
  EXPECT_GT(checked, 4000000u);
  // Ties: 2^24 + 1 (even: down), 2^24 + 3 (odd: up), the largest values (up to 2^32 and -2^31).
  const uint32_t edge[] = {0u, 1u, 0xFFFFFFu, 0x1000000u, 0x1000001u, 0x1000003u, 0x7FFFFFC0u,
                           0x7FFFFFFFu, 0x80000000u, 0x80000080u, 0x80000180u, 0xFFFFFF7Fu,
                           0xFFFFFF80u, 0xFFFFFFFFu};
  for (uint32_t v : edge) {
    EXPECT_EQ(sma::fixed_detail::float_bits_from_u32(v), float_bits(static_cast<float>(v))) << v;
    const int32_t s = static_cast<int32_t>(v);
    EXPECT_EQ(sma::fixed_detail::float_bits_from_i32(s), float_bits(static_cast<float>(s))) << s;
  }
  EXPECT_EQ(sma::fixed_detail::float_bits_from_u32(0x1000003u), float_bits(16777220.0f));
}

TEST(FixedConversion, DoubleRoundsToNearestHalfAwayFromZero) {
  EXPECT_EQ(Fixed(0.5 * kLsb).raw(), 1);
  EXPECT_EQ(Fixed(-0.5 * kLsb).raw(), -1);
  EXPECT_EQ(Fixed(0.49 * kLsb).raw(), 0);
  EXPECT_EQ(Fixed(-0.49 * kLsb).raw(), 0);
  EXPECT_EQ(Fixed(1.5 * kLsb).raw(), 2);
  EXPECT_EQ(Fixed(3.0 + 0.75 * kLsb).raw(), 3 * 65536 + 1);
  std::mt19937 gen(7u);
  std::uniform_real_distribution<double> u(-32767.0, 32767.0);
  for (int i = 0; i < 100000; ++i) {
    const double x = u(gen);
    ASSERT_EQ(Fixed(x).raw(), llround(x * 65536.0)) << x;
    ASSERT_LE(fabs(d(Fixed(x)) - x), 0.5 * kLsb);
  }
}

TEST(FixedConversion, DoubleSaturatesAndMapsNanToZero) {
  EXPECT_EQ(Fixed(32768.0), Fixed::max());
  EXPECT_EQ(Fixed(1e9), Fixed::max());
  EXPECT_EQ(Fixed(HUGE_VAL), Fixed::max());
  EXPECT_EQ(Fixed(-32768.0).raw(), INT32_MIN);  // exactly representable
  EXPECT_EQ(Fixed(-32768.0 - kLsb), Fixed::lowest());
  EXPECT_EQ(Fixed(-1e9), Fixed::lowest());
  EXPECT_EQ(Fixed(-HUGE_VAL), Fixed::lowest());
  EXPECT_EQ(Fixed(NAN).raw(), 0);
  EXPECT_EQ(Fixed(32767.99999).raw(), INT32_MAX);  // rounds up to 2^31: saturates
}

TEST(FixedConversion, IntegersScaleAndSaturate) {
  EXPECT_EQ(Fixed(3).raw(), 3 * 65536);
  EXPECT_EQ(Fixed(-32768).raw(), INT32_MIN);
  EXPECT_EQ(Fixed(32767).raw(), 32767 * 65536);
  EXPECT_EQ(Fixed(32768), Fixed::max());
  EXPECT_EQ(Fixed(-32769), Fixed::lowest());
  EXPECT_EQ(Fixed(100000L), Fixed::max());
  EXPECT_EQ(Fixed(-5L).raw(), -5 * 65536);
  EXPECT_EQ(Fixed(7u).raw(), 7 * 65536);
  EXPECT_EQ(Fixed(40000u), Fixed::max());
  EXPECT_EQ(Fixed(9UL).raw(), 9 * 65536);
  EXPECT_EQ(Fixed(static_cast<uint16_t>(65535)), Fixed::max());
  EXPECT_EQ(Fixed(static_cast<int8_t>(-3)).raw(), -3 * 65536);
}

TEST(FixedConversion, ToDoubleAndFloatAreExactAndRoundTrip) {
  Operands ops;
  for (int i = 0; i < 100000; ++i) {
    const int32_t r = ops.next();
    const Fixed x = Fixed::from_raw(r);
    ASSERT_EQ(d(x), r / 65536.0);
    ASSERT_EQ(Fixed(d(x)).raw(), r);
    ASSERT_EQ(sma::to_double(x), d(x));
    ASSERT_EQ(sma::from_double<Fixed>(d(x)).raw(), r);
    ASSERT_EQ(static_cast<float>(x), static_cast<float>(r) / 65536.0f);
  }
}

// The AVR's run-time conversions (double is float there) by integer shifts: every float bit
// pattern class (random, halfway cases, tiny, huge, inf, NaN, denormals, signed zeros) gives what
// the exact double conversion gives, and back to float the same bits as float(raw) / 2^16.
TEST(FixedConversion, FloatBitsConversionsAreExact) {
  auto via_bits = [](float f) { return sma::fixed_from_float(f).raw(); };
  auto expect = [](float f) { return Fixed(static_cast<double>(f)).raw(); };
  const float special[] = {0.0f, -0.0f, 1e-30f, -1e-30f, 1e-45f, 0.5f * static_cast<float>(kLsb),
                           -0.5f * static_cast<float>(kLsb), 0.49f * static_cast<float>(kLsb),
                           static_cast<float>(kLsb), 1.5f * static_cast<float>(kLsb), 127.99998f,
                           128.0f, 128.0000153f, -128.0000153f, 32767.998f, 32768.0f, -32768.0f,
                           -32768.004f, 1e9f, -1e9f, HUGE_VALF, -HUGE_VALF, NAN, -NAN};
  for (float f : special) EXPECT_EQ(via_bits(f), expect(f)) << f;
  std::mt19937 gen(11u);
  for (int i = 0; i < 400000; ++i) {
    uint32_t bits = static_cast<uint32_t>(gen());
    if (i % 2) bits = (bits & 0x807FFFFFu) | ((102u + bits % 45u) << 23);  // |x| ~ 2^-25 .. 2^19
    float f;
    memcpy(&f, &bits, 4);
    ASSERT_EQ(via_bits(f), expect(f)) << std::hex << bits;
  }
  // Halfway cases: x = (k + 1/2) LSB exactly.
  for (int32_t k = -70000; k < 70000; k += 7) {
    const float f = (static_cast<float>(k) + 0.5f) * static_cast<float>(kLsb);
    ASSERT_EQ(via_bits(f), expect(f)) << k;
  }
  Operands ops;
  for (int i = 0; i < 100000; ++i) {
    const int32_t r = ops.next();
    const float f = static_cast<float>(r);
    uint32_t fb;
    memcpy(&fb, &f, 4);
    const uint32_t got = sma::fixed_detail::float_bits_from_raw(r, fb);
    const float want = static_cast<float>(r) / 65536.0f;
    uint32_t wb;
    memcpy(&wb, &want, 4);
    ASSERT_EQ(got, wb) << r;
  }
}

// ---- arithmetic -------------------------------------------------------------------------------

TEST(FixedArithmetic, AddSubExactWithSaturation) {
  Operands ops;
  auto check = [](int32_t a, int32_t b) {
    const Fixed x = Fixed::from_raw(a), y = Fixed::from_raw(b);
    ASSERT_EQ((x + y).raw(), saturate(static_cast<int64_t>(a) + b)) << a << " + " << b;
    ASSERT_EQ((x - y).raw(), saturate(static_cast<int64_t>(a) - b)) << a << " - " << b;
    Fixed z = x;
    z += y;
    ASSERT_EQ(z, x + y);
    z = x;
    z -= y;
    ASSERT_EQ(z, x - y);
  };
  for (int32_t a : kEdges) {
    for (int32_t b : kEdges) check(a, b);
  }
  for (int i = 0; i < 200000; ++i) check(ops.next(), ops.next());
}

TEST(FixedArithmetic, MulIsTheCorrectlyRoundedSaturatedProduct) {
  // Bound: exactly the reference (round half away from zero), i.e. <= 0.5 LSB from the real
  // product while it is in range. Checked against long double too (exact for these operands).
  constexpr double kMulBoundLsb = 0.5;
  Operands ops;
  double worst = 0.0;
  auto check = [&](int32_t a, int32_t b) {
    const Fixed p = Fixed::from_raw(a) * Fixed::from_raw(b);
    ASSERT_EQ(p.raw(), ref_mul(a, b)) << a << " * " << b;
    const long double exact = static_cast<long double>(a) * b / 4294967296.0L;
    if (fabsl(exact) < 32767.0L) {
      const double err = static_cast<double>(fabsl(static_cast<long double>(d(p)) - exact));
      ASSERT_LE(err, kMulBoundLsb * kLsb);
      if (err > worst) worst = err;
    }
    Fixed q = Fixed::from_raw(a);
    q *= Fixed::from_raw(b);
    ASSERT_EQ(q, p);
  };
  for (int32_t a : kEdges) {
    for (int32_t b : kEdges) check(a, b);
  }
  for (int i = 0; i < 500000; ++i) check(ops.next(), ops.next());
  std::uniform_int_distribution<int32_t> small(-0x30000, 0x30000);  // |x| < 3: the common case
  std::mt19937 gen(3u);
  for (int i = 0; i < 200000; ++i) check(small(gen), small(gen));
  report("mul vs exact product", worst / kLsb, kMulBoundLsb);
}

TEST(FixedArithmetic, MulRoundingIsSignSymmetric) {
  Operands ops;
  for (int i = 0; i < 100000; ++i) {
    const int32_t a = ops.next(), b = ops.next();
    if (a == INT32_MIN || b == INT32_MIN) continue;
    const int32_t p = (Fixed::from_raw(a) * Fixed::from_raw(b)).raw();
    const int32_t n = (Fixed::from_raw(-a) * Fixed::from_raw(b)).raw();
    if (p != INT32_MAX && p != INT32_MIN) {
      ASSERT_EQ(n, -p) << a << " * " << b;
    }
  }
  // Ties: 0.5 LSB * +-1 -> +-1 LSB (away from zero).
  EXPECT_EQ((Fixed::from_raw(1) * Fixed(0.5)).raw(), 1);
  EXPECT_EQ((Fixed::from_raw(-1) * Fixed(0.5)).raw(), -1);
  EXPECT_EQ((Fixed::from_raw(1) * Fixed(0.49999)).raw(), 0);
}

TEST(FixedArithmetic, DivIsTheCorrectlyRoundedSaturatedQuotient) {
  Operands ops;
  auto check = [](int32_t a, int32_t b) {
    const Fixed q = Fixed::from_raw(a) / Fixed::from_raw(b);
    ASSERT_EQ(q.raw(), ref_div(a, b)) << a << " / " << b;
    Fixed z = Fixed::from_raw(a);
    z /= Fixed::from_raw(b);
    ASSERT_EQ(z, q);
  };
  for (int32_t a : kEdges) {
    for (int32_t b : kEdges) check(a, b);
  }
  for (int i = 0; i < 300000; ++i) check(ops.next(), ops.next());
  EXPECT_EQ(Fixed(1) / Fixed(3), Fixed(1.0 / 3.0));
  EXPECT_EQ(Fixed(-7) / Fixed(2), Fixed(-3.5));
  EXPECT_EQ(Fixed::from_raw(1) / Fixed(2), Fixed::from_raw(1));    // 0.5 LSB rounds away
  EXPECT_EQ(Fixed::from_raw(-1) / Fixed(2), Fixed::from_raw(-1));
}

TEST(FixedArithmetic, DivisionByZeroSaturates) {
  EXPECT_EQ(Fixed(1) / Fixed(0), Fixed::max());
  EXPECT_EQ(Fixed(-1) / Fixed(0), Fixed::lowest());
  EXPECT_EQ(Fixed(0) / Fixed(0), Fixed::max());
  EXPECT_EQ(Fixed::from_raw(1) / Fixed(0), Fixed::max());
  EXPECT_EQ(Fixed::lowest() / Fixed(0), Fixed::lowest());
}

TEST(FixedArithmetic, SaturationInsteadOfWrapAround) {
  const Fixed eps = Fixed::epsilon();
  EXPECT_EQ(Fixed::max() + eps, Fixed::max());
  EXPECT_EQ(Fixed::lowest() - eps, Fixed::lowest());
  EXPECT_EQ(Fixed::max() - (-Fixed(1)), Fixed::max());
  EXPECT_EQ(Fixed(20000) + Fixed(20000), Fixed::max());
  EXPECT_EQ(Fixed(-20000) - Fixed(20000), Fixed::lowest());
  EXPECT_EQ(Fixed(200) * Fixed(200), Fixed::max());
  EXPECT_EQ(Fixed(-200) * Fixed(200), Fixed::lowest());
  EXPECT_EQ(Fixed(-200) * Fixed(-200), Fixed::max());
  EXPECT_EQ(Fixed::max() * Fixed(2), Fixed::max());
  EXPECT_EQ(Fixed::lowest() * Fixed(-1), Fixed::max());
  EXPECT_EQ((Fixed::max() * Fixed(-1)).raw(), -INT32_MAX);
  EXPECT_EQ((Fixed(-16384) * Fixed(2)).raw(), INT32_MIN);  // exactly -32768: representable
  EXPECT_EQ(Fixed(30000) / Fixed(0.5), Fixed::max());
  EXPECT_EQ(Fixed(-30000) / Fixed(0.5), Fixed::lowest());
  EXPECT_EQ(-Fixed::lowest(), Fixed::max());
  EXPECT_EQ((-Fixed::max()).raw(), -INT32_MAX);
  // A heater command can never flip sign by overflowing.
  for (int i = 1; i < 200; ++i) {
    EXPECT_GT(Fixed(i) * Fixed(i * 7), Fixed(0));
    EXPECT_GT(Fixed(30000) + Fixed(i * 100), Fixed(0));
  }
}

TEST(FixedArithmetic, UnaryOperatorsAndComparisons) {
  Operands ops;
  for (int i = 0; i < 100000; ++i) {
    const int32_t a = ops.next(), b = ops.next();
    const Fixed x = Fixed::from_raw(a), y = Fixed::from_raw(b);
    ASSERT_EQ(x == y, a == b);
    ASSERT_EQ(x != y, a != b);
    ASSERT_EQ(x < y, a < b);
    ASSERT_EQ(x <= y, a <= b);
    ASSERT_EQ(x > y, a > b);
    ASSERT_EQ(x >= y, a >= b);
    ASSERT_EQ((+x).raw(), a);
    if (a != INT32_MIN) {
      ASSERT_EQ((-x).raw(), -a);
    }
  }
  EXPECT_TRUE(Fixed(1) == Fixed(1.0));
  EXPECT_TRUE(Fixed(-1) < Fixed(0));
}

TEST(FixedArithmetic, WorksWithTheGenericScalarHelpers) {
  EXPECT_EQ(sma::abs(Fixed(-2.5)), Fixed(2.5));
  EXPECT_EQ(sma::abs(Fixed(2.5)), Fixed(2.5));
  EXPECT_EQ(sma::min(Fixed(1), Fixed(2)), Fixed(1));
  EXPECT_EQ(sma::max(Fixed(1), Fixed(2)), Fixed(2));
  EXPECT_EQ(sma::clamp(Fixed(3), Fixed(0), Fixed(1)), Fixed(1));
  EXPECT_EQ(sma::clamp(Fixed(-3), Fixed(0), Fixed(1)), Fixed(0));
  EXPECT_EQ(sma::clamp(Fixed(0.25), Fixed(0), Fixed(1)), Fixed(0.25));
  EXPECT_TRUE(sma::is_finite(Fixed::max()));
  EXPECT_TRUE(sma::is_finite(Fixed::lowest()));
  EXPECT_TRUE(sma::is_finite(Fixed(1) / Fixed(0)));
}

// min, max and clamp of Fixed (fixed.hpp's overloads on the raw values) order the numbers as the
// reals they stand for, across the whole range (signs, the saturation edges, equal operands).
TEST(FixedArithmetic, MinMaxClampFollowTheOrderOfTheValues) {
  for (int32_t a : kEdges) {
    for (int32_t b : kEdges) {
      const Fixed x = Fixed::from_raw(a), y = Fixed::from_raw(b);
      const double dx = static_cast<double>(x), dy = static_cast<double>(y);
      ASSERT_EQ(static_cast<double>(sma::min(x, y)), dx < dy ? dx : dy);
      ASSERT_EQ(static_cast<double>(sma::max(x, y)), dx < dy ? dy : dx);
      if (dx > dy) continue;  // clamp needs lo <= hi
      for (int32_t v : kEdges) {
        const double dv = static_cast<double>(Fixed::from_raw(v));
        const double want = dv < dx ? dx : dv > dy ? dy : dv;
        ASSERT_EQ(static_cast<double>(sma::clamp(Fixed::from_raw(v), x, y)), want) << a << " " << b << " " << v;
      }
    }
  }
}

// ---- building blocks shared with the AVR paths ------------------------------------------------

// On the host these are the portable versions; bench/avr_math checks the AVR assembly against
// them, and that the AVR computes the same results hash as the host.
TEST(FixedKernels, PortableWideProductIsExact) {
  std::mt19937 gen(11u);
  for (int i = 0; i < 300000; ++i) {
    const uint32_t a = static_cast<uint32_t>(gen()) >> (gen() % 32u);
    const uint32_t b = static_cast<uint32_t>(gen()) >> (gen() % 32u);
    uint32_t hi, lo;
    sma::fixed_detail::umul32_wide_portable(a, b, hi, lo);
    const uint64_t p = static_cast<uint64_t>(a) * b;
    ASSERT_EQ(hi, static_cast<uint32_t>(p >> 32));
    ASSERT_EQ(lo, static_cast<uint32_t>(p));
    ASSERT_EQ(sma::fixed_detail::mul32x16(a, static_cast<uint16_t>(b)),
              static_cast<uint32_t>((static_cast<uint64_t>(a) * static_cast<uint16_t>(b)) >> 16));
    ASSERT_EQ(sma::fixed_detail::mulhi32(a, b), static_cast<uint32_t>(p >> 32));
  }
  uint32_t hi, lo;
  sma::fixed_detail::umul32_wide_portable(0xFFFFFFFFu, 0xFFFFFFFFu, hi, lo);
  EXPECT_EQ(hi, 0xFFFFFFFEu);
  EXPECT_EQ(lo, 1u);
}

TEST(FixedKernels, IntegerSquareRootIsTheExactFloor) {
  auto check = [](uint32_t n) {
    uint32_t rem;
    const uint16_t r = sma::fixed_detail::isqrt32(n, rem);
    const uint64_t e = isqrt64(n);
    ASSERT_EQ(r, e) << n;
    ASSERT_EQ(rem, n - e * e) << n;
  };
  for (uint32_t n = 0; n < (1u << 20); ++n) check(n);
  for (uint64_t k = 1; k < 65536; k += 3) {
    check(static_cast<uint32_t>(k * k - 1));
    check(static_cast<uint32_t>(k * k));
    check(static_cast<uint32_t>(k * k + 1));
  }
  check(0xFFFFFFFFu);
  check(0xFFFE0001u);
  std::mt19937 gen(5u);
  for (int i = 0; i < 1000000; ++i) check(static_cast<uint32_t>(gen()) >> (gen() % 32u));
}

// ---- transcendental functions ------------------------------------------------------------------

TEST(FixedMath, CosAndSinOverSeveralTurns) {
  double ec = 0.0, es = 0.0;
  for (int64_t r = -50 * 65536; r <= 50 * 65536; r += 3) {
    const Fixed x = raw(r);
    const double xv = d(x);
    ec = fmax(ec, fabs(d(sma::cos(x)) - ::cos(xv)));
    es = fmax(es, fabs(d(sma::sin(x)) - ::sin(xv)));
  }
  EXPECT_LE(ec, kTrigBound);
  EXPECT_LE(es, kTrigBound);
  report("cos on [-50, 50]", ec, kTrigBound);
  report("sin on [-50, 50]", es, kTrigBound);
  EXPECT_EQ(sma::cos(Fixed(0)), Fixed(1));
  EXPECT_EQ(sma::sin(Fixed(0)), Fixed(0));
  EXPECT_EQ(sma::cos(Fixed(kPi)), Fixed(-1));
}

TEST(FixedMath, CosAndSinOverTheWholeRange) {
  // The phase is reduced in turns to 2^-32, so large angles keep the same bound.
  double ec = 0.0, es = 0.0;
  for (int64_t r = INT32_MIN; r <= INT32_MAX; r += 65521) {
    const Fixed x = raw(r);
    const double xv = d(x);
    ec = fmax(ec, fabs(d(sma::cos(x)) - ::cos(xv)));
    es = fmax(es, fabs(d(sma::sin(x)) - ::sin(xv)));
  }
  EXPECT_LE(ec, kTrigBound);
  EXPECT_LE(es, kTrigBound);
  report("cos on the whole range", ec, kTrigBound);
  report("sin on the whole range", es, kTrigBound);
}

TEST(FixedMath, CosRampExhaustiveAccuracyMonotonicityAndSymmetry) {
  double err = 0.0;
  int32_t prev = -1;
  for (int32_t r = 0; r <= 65536; ++r) {
    const Fixed x = Fixed::from_raw(r);
    const Fixed y = sma::cos_ramp(x);
    err = fmax(err, fabs(d(y) - 0.5 * (1.0 - ::cos(kPi * d(x)))));
    ASSERT_GE(y.raw(), prev) << "cos_ramp decreases at x = " << d(x);
    prev = y.raw();
    ASSERT_EQ(sma::cos_ramp(Fixed::from_raw(65536 - r)).raw(), 65536 - y.raw()) << r;
  }
  EXPECT_LE(err, kCosRampBound);
  report("cos_ramp on [0, 1]", err, kCosRampBound);
  EXPECT_EQ(sma::cos_ramp(Fixed(0)), Fixed(0));
  EXPECT_EQ(sma::cos_ramp(Fixed(0.5)), Fixed(0.5));
  EXPECT_EQ(sma::cos_ramp(Fixed(1)), Fixed(1));
  // Clamped outside [0, 1].
  EXPECT_EQ(sma::cos_ramp(Fixed(-3)), Fixed(0));
  EXPECT_EQ(sma::cos_ramp(Fixed::lowest()), Fixed(0));
  EXPECT_EQ(sma::cos_ramp(Fixed(1.0001)), Fixed(1));
  EXPECT_EQ(sma::cos_ramp(Fixed::max()), Fixed(1));
}

TEST(FixedMath, CosRampInvExhaustiveAccuracyMonotonicityAndSymmetry) {
  double err = 0.0;
  int32_t prev = -1;
  for (int32_t r = 0; r <= 65536; ++r) {
    const Fixed y = Fixed::from_raw(r);
    const Fixed x = sma::cos_ramp_inv(y);
    err = fmax(err, fabs(d(x) - ::acos(1.0 - 2.0 * d(y)) / kPi));
    ASSERT_GE(x.raw(), prev) << "cos_ramp_inv decreases at y = " << d(y);
    prev = x.raw();
    ASSERT_EQ(sma::cos_ramp_inv(Fixed::from_raw(65536 - r)).raw(), 65536 - x.raw()) << r;
  }
  EXPECT_LE(err, kCosRampInvBound);
  report("cos_ramp_inv on [0, 1]", err, kCosRampInvBound);
  EXPECT_EQ(sma::cos_ramp_inv(Fixed(0)), Fixed(0));
  EXPECT_EQ(sma::cos_ramp_inv(Fixed(0.5)), Fixed(0.5));
  EXPECT_EQ(sma::cos_ramp_inv(Fixed(1)), Fixed(1));
  EXPECT_EQ(sma::cos_ramp_inv(Fixed(-0.1)), Fixed(0));
  EXPECT_EQ(sma::cos_ramp_inv(Fixed(7)), Fixed(1));
}

TEST(FixedMath, CosRampOfCosRampInvGivesBackY) {
  double err = 0.0;
  for (int32_t r = 0; r <= 65536; ++r) {
    const Fixed y = Fixed::from_raw(r);
    err = fmax(err, fabs(d(sma::cos_ramp(sma::cos_ramp_inv(y))) - d(y)));
  }
  EXPECT_LE(err, kRoundTripBound);
  report("cos_ramp(cos_ramp_inv(y))", err, kRoundTripBound);
}

TEST(FixedMath, SpecialisedRampsAgreeWithTheGenericTemplates) {
  // The generic scalar.hpp templates instantiated for Fixed go through cos/acos and two
  // products; they must agree with the fast overloads within the sum of the bounds.
  for (int32_t r = 0; r <= 65536; r += 17) {
    const Fixed x = Fixed::from_raw(r);
    ASSERT_NEAR(d(sma::cos_ramp<Fixed>(x)), d(sma::cos_ramp(x)), kTrigBound + kCosRampBound);
    ASSERT_NEAR(d(sma::cos_ramp_inv<Fixed>(x)), d(sma::cos_ramp_inv(x)),
                kAcosBound / kPi + kCosRampInvBound);
  }
}

TEST(FixedMath, AcosExhaustiveOnMinusOneToOne) {
  double err = 0.0;
  int32_t prev = INT32_MAX;
  for (int32_t r = -65536; r <= 65536; ++r) {
    const Fixed x = Fixed::from_raw(r);
    const Fixed a = sma::acos(x);
    err = fmax(err, fabs(d(a) - ::acos(d(x))));
    ASSERT_LE(a.raw(), prev) << "acos increases at x = " << d(x);
    prev = a.raw();
  }
  EXPECT_LE(err, kAcosBound);
  report("acos on [-1, 1]", err, kAcosBound);
  EXPECT_EQ(sma::acos(Fixed(1)), Fixed(0));
  EXPECT_NEAR(d(sma::acos(Fixed(-1))), kPi, kLsb);
  EXPECT_NEAR(d(sma::acos(Fixed(0))), kPi / 2, kLsb);
  // Clamped outside [-1, 1].
  EXPECT_EQ(sma::acos(Fixed(2)), sma::acos(Fixed(1)));
  EXPECT_EQ(sma::acos(Fixed(-2)), sma::acos(Fixed(-1)));
}

TEST(FixedMath, SqrtIsRoundedToNearest) {
  double worst = 0.0;
  auto check = [&](int32_t r) {
    const Fixed s = sma::sqrt(Fixed::from_raw(r));
    // Exact reference: round(sqrt(r * 2^16)); no ties are possible for an integer radicand.
    const uint64_t n = static_cast<uint64_t>(r) << 16;
    uint64_t e = isqrt64(n);
    if (n - e * e > e) ++e;
    ASSERT_EQ(static_cast<uint64_t>(s.raw()), e) << r;
    worst = fmax(worst, fabs(s.raw() - ::sqrt(static_cast<double>(n))));
  };
  for (int32_t r = 0; r < (1 << 20); ++r) check(r);
  Operands ops;
  for (int i = 0; i < 500000; ++i) {
    const int32_t r = ops.next();
    check(r < 0 ? (r == INT32_MIN ? INT32_MAX : -r) : r);
  }
  check(INT32_MAX);
  EXPECT_LE(worst, kSqrtBoundLsb);
  report("sqrt (in LSB)", worst, kSqrtBoundLsb);
  EXPECT_EQ(sma::sqrt(Fixed(4)), Fixed(2));
  EXPECT_EQ(sma::sqrt(Fixed(0.25)), Fixed(0.5));
  EXPECT_EQ(sma::sqrt(Fixed(0)), Fixed(0));
  EXPECT_EQ(sma::sqrt(Fixed(-1)), Fixed(0));  // no NaN in fixed point
  EXPECT_EQ(sma::sqrt(Fixed::lowest()), Fixed(0));
}

TEST(FixedMath, ExpOnTheModelsRangeAndAbove) {
  double err = 0.0;
  for (int32_t r = -20 * 65536; r <= 0; ++r) {
    const Fixed x = Fixed::from_raw(r);
    err = fmax(err, fabs(d(sma::exp(x)) - ::exp(d(x))));
  }
  EXPECT_LE(err, kExpBoundLsb * kLsb);
  report("exp on [-20, 0] (in LSB)", err / kLsb, kExpBoundLsb);
  double rel = 0.0;
  for (int32_t r = 0; r <= static_cast<int32_t>(10.39 * 65536); r += 3) {
    const Fixed x = Fixed::from_raw(r);
    const double e = ::exp(d(x));
    rel = fmax(rel, fabs(d(sma::exp(x)) - e) / e);
  }
  EXPECT_LE(rel, kExpRelBound);
  report("exp on [0, 10.39] (relative)", rel, kExpRelBound);
  EXPECT_EQ(sma::exp(Fixed(0)), Fixed(1));
  EXPECT_EQ(sma::exp(Fixed(10.4)), Fixed::max());
  EXPECT_EQ(sma::exp(Fixed(30000)), Fixed::max());
  EXPECT_EQ(sma::exp(Fixed(-12.5)), Fixed(0));
  EXPECT_EQ(sma::exp(Fixed::lowest()), Fixed(0));
  // exp(-dt/tau) is a contraction factor: never above 1 for x <= 0, and non-increasing.
  int32_t prev = INT32_MAX;
  for (int32_t r = 0; r >= -13 * 65536; r -= 5) {
    const int32_t e = sma::exp(Fixed::from_raw(r)).raw();
    ASSERT_LE(e, 65536);
    ASSERT_LE(e, prev);
    prev = e;
  }
}

// The board's integers into Q16.16 (scalar.hpp's ratio, from_q31, floor_u16; fixed.hpp's
// integer versions): against the exact rational in double, rounded half up, for every divisor
// and numerators over the whole range (a tick's ADC sum: up to 255 samples of 10 bits).
TEST(FixedConversion, RatioOfCountsIsTheRoundedQuotient) {
  std::mt19937 rng(12);
  for (unsigned d = 1; d < 256; ++d) {
    for (int k = 0; k < 400; ++k) {
      const uint32_t n = k < 4 ? static_cast<uint32_t>(k) * (d * 32767u / 3u) : static_cast<uint32_t>(rng() % (d * 32768u));
      const double exact = static_cast<double>(n) * 65536.0 / d;  // exact in double (< 2^48)
      const int32_t want = static_cast<int32_t>(floor(exact + 0.5));
      ASSERT_EQ(sma::ratio<Fixed>(n, static_cast<uint8_t>(d)).raw(), want) << n << " / " << d;
    }
    // Past the range (quotient >= 32768) and a zero divisor: saturated.
    EXPECT_EQ(sma::ratio<Fixed>(d * 32768u, static_cast<uint8_t>(d)), Fixed::max());
  }
  EXPECT_EQ(sma::ratio<Fixed>(5, 0), Fixed::max());
  // The ADC's mean: 84 samples at 512 counts and one at 513.
  EXPECT_EQ(sma::ratio<Fixed>(84u * 512u + 513u, 85).raw(), static_cast<int32_t>(floor((84.0 * 512 + 513) * 65536 / 85 + 0.5)));
}

// The ADC mean as a fraction of full scale (fixed.hpp's adc_fraction, the Q16.16 board's volts):
// n / (1024 d) against the exact rational, rounded half up, for every divisor over a 10-bit ADC's
// whole range; past it (a mean >= 1024) within two LSB of the exact value.
TEST(FixedConversion, AdcFractionIsTheRoundedQuotient) {
  std::mt19937 rng(13);
  for (unsigned d = 1; d < 256; ++d) {
    for (int k = 0; k < 400; ++k) {
      const uint32_t n = k == 0 ? 0u : k == 1 ? d * 1024u - 1u : static_cast<uint32_t>(rng() % (d * 1024u));
      const double exact = static_cast<double>(n) * 64.0 / d;  // n / (1024 d) in LSB of 2^-16
      ASSERT_EQ(sma::adc_fraction(n, static_cast<uint8_t>(d)).raw(), static_cast<int32_t>(floor(exact + 0.5)))
          << n << " / (1024 " << d << ")";
    }
    const uint32_t big = d * 1024u + static_cast<uint32_t>(rng() % (d * 4096u));
    EXPECT_NEAR(sma::adc_fraction(big, static_cast<uint8_t>(d)).raw(), static_cast<double>(big) * 64.0 / d, 2.0);
  }
  // Volts as the board computes them: 85 samples at 512 counts of a 5 V reference: 2.5 V.
  EXPECT_EQ(sma::adc_volts<Fixed>(85u * 512u, 85, Fixed(5.0 / 1024), Fixed(5.0)), Fixed(2.5));
  EXPECT_DOUBLE_EQ(sma::adc_volts<double>(85u * 512u, 85, 5.0 / 1024, 5.0), 2.5);
}

TEST(FixedConversion, PhaseAndCountsConversions) {
  // x / 2^31, rounded (ties up): the sine's folded phase.
  const uint32_t xs[] = {0u, 1u, 0x4000u, 0x8000u, 0xC000u, 0x40000000u, 0x7FFFFFFFu, 0x80000000u, 123456789u};
  for (uint32_t x : xs)
    EXPECT_EQ(sma::from_q31<Fixed>(x).raw(), static_cast<int32_t>(floor(static_cast<double>(x) / 32768.0 + 0.5))) << x;
  // floor for the PWM counts; negatives give 0.
  EXPECT_EQ(sma::floor_u16(Fixed(2560.75)), 2560u);
  EXPECT_EQ(sma::floor_u16(Fixed(16000)), 16000u);
  EXPECT_EQ(sma::floor_u16(Fixed(0.999)), 0u);
  EXPECT_EQ(sma::floor_u16(Fixed(-3)), 0u);
}

// The board's reference: the sine from the tick count (Q0.32 phase) in Q16.16 and in double
// against its closed form (0.2..0.7 mm, 50 s period, 3 periods at 100 Hz).
TEST(FixedReference, SineFromTheTickCountMatchesDouble) {
  const sma::Reference r = sma::Reference::sine();
  const sma::ReferenceGen<Fixed> gen(r, 0.01);
  const sma::ReferenceGen<double> gen_d(r, 0.01);
  double worst = 0.0;
  for (uint32_t k = 0; k <= 15000; ++k) {
    const double t = k * 0.01;
    const double want = 0.2 + 0.5 * 0.5 * (1.0 - cos(2.0 * M_PI * t / 50.0));
    worst = fmax(worst, fabs(static_cast<double>(gen.at_tick(k, 0.01)) - want));
    // The phase per tick is rounded to 2^-32 turn: after k ticks <= k / 2^33 turn off, i.e.
    // <= (span / 2) 2 pi k / 2^33 mm (2.7e-6 mm at the end of the third period).
    ASSERT_NEAR(gen_d.at_tick(k, 0.01), want, 0.25 * 2.0 * M_PI * k / 8589934592.0 + 1e-12) << k;
  }
  printf("[ measured ] Q16.16 sine reference max error %.2e mm\n", worst);
  EXPECT_LT(worst, 5e-5);
  // Another kind goes through at(k dt).
  const sma::ReferenceGen<Fixed> steps(sma::Reference::multi_step(), 0.01);
  EXPECT_EQ(steps.at_tick(2600, 0.01), Fixed(0.4));
}
