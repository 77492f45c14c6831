// Parameters: Table II defaults, derived constants of eq 1, and validation of bad sets.
#include <gtest/gtest.h>
#include "sma/params.hpp"
#include "sma/effects.hpp"

TEST(Params, DerivedThermalConstantsMatchModelMd) {
  const sma::Params p;
  EXPECT_NEAR(p.heat_capacity(), 0.14952, 1e-5);   // C_th = rho c pi d0^2 L0 / 4
  EXPECT_NEAR(p.conductance(), 0.036285, 1e-6);    // G = pi d0 L0 h
  EXPECT_NEAR(p.heat_capacity() / p.conductance(), 4.1206, 1e-4);  // tau
  EXPECT_EQ(p.check(), nullptr);
}

TEST(Params, RejectsNonPhysicalSetsNamingTheKey) {
  struct Case { void (*mutate)(sma::Params&); const char* key; };
  const Case cases[] = {
      {[](sma::Params& p) { p.T_AF = p.T_AS; }, "T_AF"},
      {[](sma::Params& p) { p.T_AF = p.T_AS - 1; }, "T_AF"},
      {[](sma::Params& p) { p.h = -1; }, "h"},
      {[](sma::Params& p) { p.h = NAN; }, "h"},
      {[](sma::Params& p) { p.R = 0; }, "R"},
      {[](sma::Params& p) { p.d0 = INFINITY; }, "d0"},
      {[](sma::Params& p) { p.g = 0; }, "g"},
      {[](sma::Params& p) { p.T_f = p.T_s; }, "T_f"},
      {[](sma::Params& p) { p.T_MS = p.T_MF; }, "T_MS"},
      {[](sma::Params& p) { p.m[3] = NAN; }, "m"},
      {[](sma::Params& p) { p.loops[1].T_i = 62.0; }, "loops"},   // not increasing
      {[](sma::Params& p) { p.loops[0].j = 1.5; }, "loops"},
      {[](sma::Params& p) { p.loops[0].T_ii = 70.0; }, "loops"},  // T_ii above T_i
      {[](sma::Params& p) { p.n_loops = 99; }, "loops"},
  };
  for (const Case& c : cases) {
    sma::Params p;
    c.mutate(p);
    const char* msg = p.check();
    ASSERT_NE(msg, nullptr) << c.key;
    EXPECT_EQ(std::string(msg).rfind(c.key, 0), 0u) << msg;
  }
}

TEST(Effects, DefaultsAreThePapersModelAndBadValuesAreRejected) {
  sma::Effects fx;
  EXPECT_FALSE(fx.thermal_active());
  EXPECT_EQ(fx.check(), nullptr);
  fx.sensor_delay_s = -0.1;
  EXPECT_NE(fx.check(), nullptr);
  fx = sma::Effects();
  fx.latent_heat_J = NAN;
  EXPECT_NE(fx.check(), nullptr);
  fx = sma::Effects();
  fx.sensor_gain = 0.0;
  EXPECT_NE(fx.check(), nullptr);
}
