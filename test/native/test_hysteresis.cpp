// Phase transformation (eqs 2-11): the check values of model.md, and the physics of the
// state machine: eps in [0, 1], monotone branches, rate independence, loop memory.
#include <gtest/gtest.h>
#include <math.h>
#include <string.h>
#include <vector>
#include "sma/hysteresis.hpp"
#include "sma_host/plant.hpp"
#include "temperature_walk.hpp"

namespace {
const sma::Params kP;
const sma::PhaseCurves<double> kCurves(kP);
constexpr double kTol = 1e-3;  // model.md: match within 1e-3

using temperature_walk::walk;
}  // namespace

TEST(Hysteresis, MajorHeatingCurveCheckValues) {
  EXPECT_NEAR(kCurves.eps_heat(55.0), 0.0623, kTol);
  EXPECT_NEAR(kCurves.eps_heat(60.8), 0.2793, kTol);
  EXPECT_NEAR(kCurves.eps_heat(63.1), 0.3931, kTol);
  EXPECT_NEAR(kCurves.eps_heat(68.5), 0.6724, kTol);
  EXPECT_NEAR(kCurves.eps_heat(75.9), 0.9521, kTol);
  EXPECT_EQ(kCurves.eps_heat(50.2), 0.0);
  EXPECT_EQ(kCurves.eps_heat(10.0), 0.0);
  EXPECT_EQ(kCurves.eps_heat(80.1), 1.0);
  EXPECT_EQ(kCurves.eps_heat(200.0), 1.0);
}

TEST(Hysteresis, MartensiteStartOfMinorLoopsCheckValues) {
  auto tms = [](double Ti) { return kCurves.make_loop(Ti, kCurves.eps_heat(Ti)).T_MSi; };
  EXPECT_NEAR(tms(60.8), 51.333, kTol);  // eq 10 at T_s
  EXPECT_NEAR(tms(63.1), 39.357, kTol);  // eq 8 polynomial
  EXPECT_NEAR(tms(68.5), 31.768, kTol);
  EXPECT_NEAR(tms(71.5), 29.812, kTol);
  EXPECT_NEAR(tms(75.9), 29.338, kTol);  // eq 10 at T_f
  EXPECT_NEAR(tms(80.1), 27.772, kTol);  // eq 10
  EXPECT_NEAR(tms(55.0), 55.0, kTol);    // clamped to T_ii = T_i
  // The polynomial reproduces Table II's identified T_MSi within 1.5 K.
  EXPECT_NEAR(tms(63.1), 40.8, 1.5);
  EXPECT_NEAR(tms(68.5), 32.1, 1.5);
  EXPECT_NEAR(tms(71.5), 30.1, 1.5);
}

TEST(Hysteresis, MinorLoopAt68_5CheckValues) {
  sma::Hysteresis<double> h(kCurves, 22.0);
  walk(h, 68.5);
  EXPECT_NEAR(h.eps(), 0.6724, kTol);
  EXPECT_NEAR(h.update(60.0), 0.8442, kTol);  // rise (eqs 5-6)
  for (double T = 59.1; T >= 31.768; T -= 0.5) EXPECT_NEAR(h.update(T), 0.8624, kTol) << T;
  EXPECT_NEAR(h.update(31.768), 0.8624, kTol);
  EXPECT_NEAR(h.update(30.0), 0.7945, kTol);  // eq 11
  EXPECT_NEAR(h.update(25.0), 0.1856, kTol);
  EXPECT_NEAR(h.update(22.0), 0.0, kTol);
}

TEST(Hysteresis, MinorLoopAt63_1CheckValues) {
  sma::Hysteresis<double> h(kCurves, 22.0);
  walk(h, 63.1);
  for (double T = 61.2; T >= 39.357; T -= 0.4) EXPECT_NEAR(h.update(T), 0.5531, kTol) << T;
  EXPECT_NEAR(h.update(39.357), 0.5531, kTol);
  EXPECT_NEAR(h.update(35.0), 0.4715, kTol);
  EXPECT_NEAR(h.update(30.0), 0.2427, kTol);
  EXPECT_NEAR(h.update(25.0), 0.0398, kTol);
}

TEST(Hysteresis, FractionStaysInUnitIntervalOnRandomPaths) {
  sma::Noise rng(7);
  sma::Hysteresis<double> h(kCurves, 22.0);
  double T = 22.0;
  for (int k = 0; k < 200000; ++k) {
    T += (rng.uniform() - 0.5) * 4.0;
    T = sma::clamp(T, 0.0, 140.0);
    const double e = h.update(T);
    ASSERT_GE(e, 0.0);
    ASSERT_LE(e, 1.0);
  }
}

TEST(Hysteresis, BranchesAreMonotone) {
  // Heating: eps never decreases. Cooling below the rise: eps never increases.
  sma::Hysteresis<double> h(kCurves, 22.0);
  double prev = h.eps();
  for (double T = 22.0; T <= 90.0; T += 0.01) {
    const double e = h.update(T);
    ASSERT_GE(e, prev - 1e-15);
    prev = e;
  }
  for (double T = 90.0; T >= 15.0; T -= 0.01) {
    const double e = h.update(T);
    ASSERT_LE(e, prev + 1e-15) << T;  // from T_i >= T_f there is no rise
    prev = e;
  }
  // On a minor loop, the rise is monotone up, then the cooling branch monotone down.
  walk(h, 68.5);
  prev = h.eps();
  const double T_ii = h.loop_for_cooling().T_ii;
  for (double T = 68.5; T > 22.0; T -= 0.01) {
    const double e = h.update(T);
    if (T > T_ii - 0.01) {  // the last sample of the rise may land just below T_ii
      ASSERT_GE(e, prev - 1e-15) << T;
    } else {
      ASSERT_LE(e, prev + 1e-15) << T;
    }
    prev = e;
  }
}

TEST(Hysteresis, RateIndependent) {
  // The same temperature path sampled coarsely or finely ends in the same state.
  const double path[] = {22, 70, 45, 66, 30, 74, 60, 28};
  sma::Hysteresis<double> coarse(kCurves, 22.0), fine(kCurves, 22.0);
  for (double T : path) {
    walk(coarse, T, 2.0);
    walk(fine, T, 0.001);
    EXPECT_NEAR(coarse.eps(), fine.eps(), 1e-9) << T;
  }
}

TEST(Hysteresis, NonFiniteTemperatureIsIgnored) {
  sma::Hysteresis<double> h(kCurves, 22.0);
  walk(h, 70.0);
  const double e = h.eps();
  EXPECT_EQ(h.update(NAN), e);
  EXPECT_EQ(h.update(INFINITY), e);
  EXPECT_EQ(h.temperature(), 70.0);
}

TEST(Hysteresis, HeatingFromAboveTheCurveStaysFlatUntilItMeetsIt) {
  sma::Hysteresis<double> h(kCurves, 22.0);
  walk(h, 68.5);
  walk(h, 45.0);  // on the flat stage at 0.8624
  const double flat = h.eps();
  walk(h, 74.0);  // eps_h(74) = 0.897 > 0.8624: meets the curve on the way
  EXPECT_NEAR(h.eps(), kCurves.eps_heat(74.0), 1e-12);
  // Before it meets the curve, eps does not move.
  sma::Hysteresis<double> g(kCurves, 22.0);
  walk(g, 68.5);
  walk(g, 45.0);
  walk(g, 72.0);  // eps_h(72) = 0.837 < 0.8624
  EXPECT_NEAR(g.eps(), flat, 1e-12);
}

TEST(Hysteresis, ReturnPointMemoryOverNestedReversals) {
  // A loop at 68.5, cooled onto its eq-11 branch; inner excursions that do not reach the
  // major heating curve must not change the branch: back at the same temperature, the same
  // fraction, however many and however nested the excursions.
  sma::Hysteresis<double> ref(kCurves, 22.0);
  walk(ref, 68.5);
  walk(ref, 30.0);
  const double at30 = ref.eps(), at27 = (walk(ref, 27.0), ref.eps());

  sma::Hysteresis<double> h(kCurves, 22.0);
  walk(h, 68.5);
  walk(h, 30.0);
  walk(h, 45.0);  // excursion 1 (flat: below eps_h)
  walk(h, 35.0);  // nested reversal
  walk(h, 50.0);  // nested excursion 2
  walk(h, 32.0);
  walk(h, 40.0);
  EXPECT_NEAR(h.eps(), at30, 1e-12);  // flat during all excursions
  walk(h, 30.0);
  EXPECT_NEAR(h.eps(), at30, 1e-12);  // back on the branch where it left it
  walk(h, 27.0);
  EXPECT_NEAR(h.eps(), at27, 1e-12);  // and follows the same branch below
  // Whereas an excursion that transforms opens a new loop (the paper's minor loops).
  walk(h, 70.0);
  EXPECT_NEAR(h.eps(), kCurves.eps_heat(70.0), 1e-12);
  EXPECT_NEAR(h.loop_for_cooling().T_i, 70.0, 1e-12);
}

TEST(Hysteresis, SmallRipplesDoNotRatchetTheFraction) {
  // Temperature ripple of +-0.2 K around 40 deg C on a cooling branch, 1000 times.
  sma::Hysteresis<double> h(kCurves, 22.0);
  walk(h, 68.5);
  walk(h, 40.0);
  const double e = h.eps();
  for (int k = 0; k < 1000; ++k) {
    h.update(40.2);
    h.update(39.8);
    h.update(40.0);
  }
  EXPECT_NEAR(h.eps(), e, 1e-12);
}

// The inverse model hands the memory the fraction it inverted (update(Tw, eps)) and builds a
// reversal's loop once (prepare_cooling): the walk must be the one update(Tw) alone gives.
TEST(Hysteresis, KnownFractionAndPreparedLoopWalkTheSamePath) {
  sma::Hysteresis<double> plain(kCurves, 22.0), hinted(kCurves, 22.0);
  const double path[] = {40, 64, 50, 66, 45, 66.5, 62, 70, 55, 72, 30, 80, 61, 90, 22};
  double T = 22.0;
  int reversals_checked = 0;
  for (double to : path)
    T = temperature_walk::steps(T, to, 0.25, [&](double x, bool rising) {
      const double eps = plain.update(x);
      double known;
      if (rising) {
        known = kCurves.eps_heat(x);
      } else {
        const sma::CoolingLoop<double> expect = hinted.loop_for_cooling();
        const sma::CoolingLoop<double>& L = hinted.prepare_cooling();
        ASSERT_EQ(L.T_MSi, expect.T_MSi);
        ASSERT_EQ(L.top, expect.top);
        ASSERT_EQ(hinted.loop_for_cooling().T_i, expect.T_i);  // still the prepared loop
        reversals_checked += hinted.heating();
        known = kCurves.eps_cool(L, x);
      }
      ASSERT_NEAR(hinted.update(x, known), eps, 1e-12) << "at T = " << x;
      ASSERT_EQ(hinted.loop().T_MSi, plain.loop().T_MSi) << "at T = " << x;
    });
  EXPECT_GE(reversals_checked, 7);
}

// The inverse's route on a reversal tick: the loop's shape only (prepare_cooling_shape, its two
// rates left pending), inverted by eq 16; the memory must still walk the path update(Tw) alone
// gives, and every loop it reads must have the rates make_loop computes (float, as on the Uno).
TEST(Hysteresis, ShapeOnlyReversalWalksTheSamePathWithTheSameLoop) {
  const sma::PhaseCurves<float> curves(kP);
  sma::Hysteresis<float> plain(curves, 22.0f), hinted(curves, 22.0f);
  const float path[] = {40, 64, 50, 66, 45, 66.5f, 62, 70, 55, 72, 30, 80, 61, 90, 22};
  float T = 22.0f;
  int reversals = 0;
  for (float to : path)
    T = temperature_walk::steps(T, to, 0.25f, [&](float x, bool rising) {
      const float eps = plain.update(x);
      if (rising) {
        hinted.update(x, curves.eps_heat(x));
      } else {
        const bool reversal = hinted.heating();
        const sma::CoolingLoop<float> full = hinted.loop_for_cooling();
        const sma::CoolingLoop<float>& L = hinted.prepare_cooling_shape();
        ASSERT_EQ(L.T_MSi, full.T_MSi);
        ASSERT_EQ(L.top, full.top);
        ASSERT_EQ(L.inv_top, full.inv_top);
        ASSERT_EQ(curves.has_cooling_stage(L), full.inv_cool > 0.0f);
        // The inverse's eq 16 on the shape, then the memory told that fraction.
        const float e = curves.eps_cool(full, x);
        reversals += reversal;
        if (e > 0.0f && e < L.top) hinted.update(x, e);
        else hinted.update(x);
      }
      ASSERT_NEAR(hinted.eps(), eps, 1e-6f) << "at T = " << x;
      const sma::CoolingLoop<float> a = hinted.loop(), b = plain.loop();
      ASSERT_EQ(a.rise_rate, b.rise_rate) << "at T = " << x;
      ASSERT_EQ(a.inv_cool, b.inv_cool) << "at T = " << x;
      ASSERT_EQ(a.T_ii, b.T_ii) << "at T = " << x;
    });
  EXPECT_GE(reversals, 7);
}

// float's own cos_ramp_inv (a polynomial, scalar.hpp) against double acos: within 1e-6 of the
// normalised result, monotone, exact at the ends and the middle.
TEST(Hysteresis, FloatCosRampInvMatchesDouble) {
  double worst = 0.0;
  float prev = -1.0f;
  for (int i = 0; i <= 200000; ++i) {
    const float y = static_cast<float>(i) / 200000.0f;
    const float r = sma::cos_ramp_inv(y);
    worst = fmax(worst, fabs(static_cast<double>(r) - acos(1.0 - 2.0 * static_cast<double>(y)) / sma::kPi));
    ASSERT_GE(r, prev) << "decreases at y = " << y;
    prev = r;
  }
  EXPECT_LE(worst, 1e-6);
  EXPECT_EQ(sma::cos_ramp_inv(0.0f), 0.0f);
  EXPECT_NEAR(sma::cos_ramp_inv(0.5f), 0.5f, 1e-6);
  EXPECT_EQ(sma::cos_ramp_inv(1.0f), 1.0f);
  EXPECT_EQ(sma::cos_ramp_inv(-3.0f), 0.0f);
  EXPECT_EQ(sma::cos_ramp_inv(NAN), 0.0f);
}

// float's clamp01 works on the bit pattern: the same float as the soft-float clamp for the edges
// (signed zeros, 1, infinities, NaNs of both signs, denormals) and random bit patterns.
TEST(Hysteresis, FloatClamp01IsClampToTheUnitInterval) {
  auto same = [](float x) {
    const float a = sma::clamp01(x), b = sma::clamp(x, 0.0f, 1.0f);
    return sma::float_bits(a) == sma::float_bits(b);
  };
  const float edges[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, 1e-45f, -1e-45f, 0.99999994f, 1.0000001f,
                         INFINITY, -INFINITY, NAN, -NAN, 3.0f, -3.0f};
  for (float x : edges) EXPECT_TRUE(same(x)) << x;
  uint32_t s = 12345u;
  for (int i = 0; i < 1000000; ++i) {
    s = s * 1664525u + 1013904223u;
    float x;
    memcpy(&x, &s, 4);
    ASSERT_TRUE(same(x)) << std::hex << s;
  }
  EXPECT_EQ(sma::float_bits(sma::clamp01(-0.0f)), 0u);  // +0: never a negative fraction
}

// The PID's sign and magnitude tests on float bits agree with float compares for every number
// that is not NaN (signed zeros, denormals, infinities, random bit patterns).
TEST(Hysteresis, FloatSignTestsAreCompares) {
  const float limits[] = {0.0f, 0.05f, 1e-45f, 1.0f, INFINITY};
  auto check = [&](float x) {
    if (x != x) return true;
    bool ok = sma::positive(x) == (x > 0.0f) && sma::negative(x) == (x < 0.0f);
    for (float l : limits) ok = ok && sma::abs_below(x, l) == (fabsf(x) < l);
    return ok;
  };
  const float edges[] = {0.0f, -0.0f, 1e-45f, -1e-45f, 0.05f, -0.05f, 0.049999997f, -0.050000004f,
                         INFINITY, -INFINITY};
  for (float x : edges) EXPECT_TRUE(check(x)) << x;
  uint32_t s = 54321u;
  for (int i = 0; i < 1000000; ++i) {
    s = s * 1664525u + 1013904223u;
    float x;
    memcpy(&x, &s, 4);
    ASSERT_TRUE(check(x)) << std::hex << s;
  }
}

// float's own cos_ramp (a polynomial, scalar.hpp) against double cos: within float rounding
// (2e-7), monotone, exact at the ends.
TEST(Hysteresis, FloatCosRampMatchesDouble) {
  double worst = 0.0;
  float prev = -1.0f;
  for (int i = 0; i <= 200000; ++i) {
    const float x = static_cast<float>(i) / 200000.0f;
    const float r = sma::cos_ramp(x);
    worst = fmax(worst, fabs(static_cast<double>(r) - 0.5 * (1.0 - cos(sma::kPi * static_cast<double>(x)))));
    ASSERT_GE(r, prev) << "decreases at x = " << x;
    prev = r;
  }
  EXPECT_LE(worst, 2e-7);
  EXPECT_EQ(sma::cos_ramp(0.0f), 0.0f);
  EXPECT_EQ(sma::cos_ramp(1.0f), 1.0f);
  EXPECT_EQ(sma::cos_ramp(2.0f), 1.0f);
  EXPECT_EQ(sma::cos_ramp(NAN), 0.0f);
}
