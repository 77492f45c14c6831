// The constructors' derived-constant helpers (sma/derived.hpp).
#include <gtest/gtest.h>
#include <float.h>
#include <math.h>
#include "sma/derived.hpp"
#include "sma/effects.hpp"

namespace {

// Every class of float a field can hold: both zeros, denormals (1e-45f: the smallest), normals,
// infinities, NaNs.
const float kValues[] = {0.0f, -0.0f, 1e-45f, -1e-45f, FLT_MIN, -FLT_MIN, 1e-30f, -1.0f, 1.0f,
                         2.5f, FLT_MAX, -FLT_MAX, INFINITY, -INFINITY, NAN, -NAN};

}  // namespace

// The AVR's test of which effects are on, on the bit patterns, is the three compares with 0
// for every combination (a NaN is not 0, -0 is).
TEST(Derived, AnyNonzeroFloatIsThreeComparesWithZero) {
  int zero_triples = 0;
  for (float a : kValues)
    for (float b : kValues)
      for (float c : kValues) {
        const bool expected = a != 0.0f || b != 0.0f || c != 0.0f;
        EXPECT_EQ(sma::any_nonzero_float(a, b, c), expected) << a << " " << b << " " << c;
        zero_triples += expected ? 0 : 1;
      }
  EXPECT_EQ(zero_triples, 8);  // {+0, -0}^3
}

// Effects::nonlinear_thermal() (through any_nonzero) on each of its three effects.
TEST(Derived, NonlinearThermalIsOnWithAnyOfItsEffects) {
  sma::Effects fx;
  EXPECT_FALSE(fx.nonlinear_thermal());
  fx.ambient_offset_K = 5.0;  // shifts T_a only: eq 1 stays linear
  EXPECT_FALSE(fx.nonlinear_thermal());
  fx.convection_beta_per_K = -0.0;
  EXPECT_FALSE(fx.nonlinear_thermal());
  double sma::Effects::*const fields[] = {&sma::Effects::convection_beta_per_K, &sma::Effects::resistance_k,
                                          &sma::Effects::latent_heat_J};
  for (auto f : fields) {
    sma::Effects e;
    e.*f = 1e-3;
    EXPECT_TRUE(e.nonlinear_thermal());
  }
}
