// Parameters: Table II defaults, derived constants of eq 1, and validation of bad sets.
#include <gtest/gtest.h>
#include "sma/params.hpp"
#include "sma/effects.hpp"
#include "sma/param_table_access.hpp"
#include "sma/storage.hpp"

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
      {[](sma::Params& p) { p.m[3] = NAN; }, "m3"},
      {[](sma::Params& p) { p.loops[1].T_i = 62.0; }, "loops"},   // not increasing
      {[](sma::Params& p) { p.loops[0].j = 1.5; }, "loop0.j"},
      {[](sma::Params& p) { p.loops[0].T_ii = 70.0; }, "loops"},  // T_ii above T_i
      {[](sma::Params& p) { p.n_loops = 99; }, "loops"},
      {[](sma::Params& p) { p.rho = 50.0; }, "rho"},              // a wire is no foam
      {[](sma::Params& p) { p.T_amb = 120.0; }, "T_amb"},
  };
  for (const Case& c : cases) {
    sma::Params p;
    c.mutate(p);
    const sma::param::Violation v = p.check();
    ASSERT_FALSE(v.ok()) << c.key;
    std::string msg;
    struct Out {
      std::string* s;
      void put(char ch) { s->push_back(ch); }
    } o{&msg};
    sma::param::put_violation(o, v);
    EXPECT_EQ(msg.rfind(std::string(c.key) + ": ", 0), 0u) << msg;
  }
}

// The messages are built from the table: its ranges as written, the ordering's other key.
TEST(Params, MessagesComeFromTheTable) {
  auto text = [](sma::param::Violation v) {
    std::string s;
    struct Out {
      std::string* s;
      void put(char ch) { s->push_back(ch); }
    } o{&s};
    sma::param::put_violation(o, v);
    return s;
  };
  sma::Params p;
  p.T_AF = p.T_AS;
  EXPECT_EQ(text(p.check()), "T_AF: must be > T_AS");
  p = sma::Params();
  p.d0 = 0.02;  // a 20 mm "wire"
  EXPECT_EQ(text(p.check()), "d0: must be in 1e-6..0.01");
  p = sma::Params();
  p.loops[2].T_ii = 500.0;
  EXPECT_EQ(text(p.check()), "loop2.T_ii: must be in -100..400");
  sma::Effects fx;
  fx.resistance_k = -1.0;  // a resistance that would vanish
  EXPECT_EQ(text(fx.check()), "resistance_phase.k_R: must be in -0.9..2");
  fx = sma::Effects();
  fx.thermal_expansion_per_K = 1e-3;
  EXPECT_EQ(text(fx.check()), "thermal_expansion.alpha_per_K: must be in 0..1e-4");
}

// Every flat key: its name leads back to it, its range holds the paper's value, the console's
// range and check() agree at the bounds.
TEST(ParamTable, KeysNamesRangesAgree) {
  for (uint8_t k = 0; k < sma::param::kKeys; ++k) {
    std::string name;
    struct Out {
      std::string* s;
      void put(char ch) { s->push_back(ch); }
    } o{&name};
    sma::param::put_key_name(o, k);
    EXPECT_EQ(sma::param::key_index(name.c_str(), static_cast<uint8_t>(name.size())), k) << name;
    double lo, hi;
    sma::param::key_range(k, lo, hi);
    sma::Params p;
    sma::Effects fx;
    const double v = sma::param::get_value(p, fx, k);
    EXPECT_TRUE(v >= lo && v <= hi) << name;
    if (k == sma::storage::kKeyLoops) continue;
    // just outside the range: check() names this key (loops beyond n_loops are not checked)
    if (name.rfind("loop", 0) == 0 && name[4] - '0' >= p.n_loops) continue;
    if (name.find(".T_i") != std::string::npos) continue;  // the loop order rule names "loops"
    *sma::param::value_ptr(p, fx, k) = lo - (hi - lo) * 0.01;
    sma::param::Violation bad = p.check();
    if (bad.ok()) bad = fx.check();
    if (name == "thermal_expansion.alpha_per_K" && !sma::kThermalExpansion) continue;
    EXPECT_EQ(bad.key, k) << name;
  }
  EXPECT_EQ(sma::param::key_index("beta_per_K", 10), sma::param::key_of<sma::param::Row::beta_per_K>());
  EXPECT_EQ(sma::param::key_index("T_i", 3), sma::param::kNoKey);  // a loop field needs its loop
  EXPECT_EQ(sma::param::key_index("m6", 2), sma::param::kNoKey);
  EXPECT_EQ(sma::param::key_index("d0", 2), 3);
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
