// Start values from the log (sma_host/initial_guess.hpp): on a log of a wire whose bands, h and
// stroke differ from the start values, the guess reads them back from where the displacement
// moves; the plausibility check names what leaves a NiTi wire's ranges and nothing else.
#include <gtest/gtest.h>
#include <math.h>
#include <vector>
#include "sma_host/plant.hpp"
#include "sma_host/initial_guess.hpp"

namespace {
// A foreign wire: bands 8-10 K away from the paper's, another h and stroke, no minor loops hit.
sma::Params foreign() {
  sma::Params p;
  p.h = 110.0;
  p.T_AS = 58.0;
  p.T_AF = 78.0;
  p.T_MF = 30.0;
  p.q = -20.0;
  p.e = 62.0;  // martensite start of a full transformation q + e = 42 degC
  p.T_MS = 42.0;
  p.g = 1.3;
  return p;
}

// Heat at 1.9 V for 60 s (steady state far past T_AF), cool for 60 s, sampled at 100 Hz.
void step_log(const sma::Params& p, std::vector<double>& t, std::vector<double>& v, std::vector<double>& d) {
  sma::Plant plant(p);
  for (int k = 0; k < 12000; ++k) {
    t.push_back(0.01 * k);
    v.push_back(k >= 500 && k < 6500 ? 1.9 : 0.0);
    d.push_back(plant.measure_clean());
    plant.step(v.back(), 0.01);
  }
}
}  // namespace

TEST(InitialGuess, ReadsBandsHAndStrokeFromTheLog) {
  const sma::Params truth = foreign();
  std::vector<double> t, v, d;
  step_log(truth, t, v, d);
  const sma::Params start;  // the paper's wire: h 165, bands 50-80 / 22-28
  const sma_host::Guess g = sma_host::initial_guess(t, v, d, start, sma::Effects());
  EXPECT_NEAR(g.p.g, truth.g, 0.02 * truth.g);
  EXPECT_NEAR(g.p.h, truth.h, 0.15 * truth.h);
  EXPECT_NEAR(g.p.T_AS, truth.T_AS, 3.0);
  EXPECT_NEAR(g.p.T_AF, truth.T_AF, 3.0);
  EXPECT_NEAR(g.p.q + g.p.e, truth.q + truth.e, 3.0);
  EXPECT_NEAR(g.p.T_MF, truth.T_MF, 3.0);
  // T_s, T_f moved with the heating band (tied to it), not left at the paper's 60.8, 75.9.
  EXPECT_GT(g.p.T_s, g.p.T_AS);
  EXPECT_LT(g.p.T_f, g.p.T_AF);
  EXPECT_NEAR(g.p.T_s - g.p.T_AS, (60.8 - 50.2) / 29.9 * (g.p.T_AF - g.p.T_AS), 1e-9);
  // Better than the start it replaced.
  EXPECT_LT(g.rms_mm, 0.2 * sma_host::model_rms(start, sma::Effects(), t, v, d));
  EXPECT_EQ(g.p.check(), nullptr);
}

TEST(InitialGuess, ExpansionReadFromTheRiseAfterTheHeaterGoesOff) {
  sma::Effects fx;
  fx.thermal_expansion_per_K = 1e-5;
  sma::Params truth = foreign();
  truth.L0 = 1.0;  // a long wire: 10 um per kelvin
  truth.g = 16.0;
  std::vector<double> t, v, d;
  sma::Plant plant(truth, fx);
  for (int k = 0; k < 12000; ++k) {
    t.push_back(0.01 * k);
    v.push_back(k >= 500 && k < 6500 ? 4.2 : 0.0);  // 1 m of wire loses 7x the heat: ~100 K rise
    d.push_back(plant.measure_clean());
    plant.step(v.back(), 0.01);
  }
  sma::Params start;
  start.L0 = 1.0;
  sma::Effects fx0;
  fx0.thermal_expansion_per_K = 3e-5;  // on, at a wrong value
  const sma_host::Guess g = sma_host::initial_guess(t, v, d, start, fx0);
  EXPECT_NEAR(g.fx.thermal_expansion_per_K, 1e-5, 0.3e-5);
}

TEST(InitialGuess, PlausibilityNamesTheParameterOutsideItsRange) {
  EXPECT_TRUE(sma_host::plausibility_warnings(sma::Params(), sma::Effects()).empty());  // the paper's wire
  sma::Params p;
  p.T_AS = 78.0;
  p.T_AF = 152.0;  // a 74 K band ending at 152 degC: what a fit bends to without the right effects
  const std::vector<std::string> w = sma_host::plausibility_warnings(p, sma::Effects());
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NE(w[0].find("T_AF = 152"), std::string::npos) << w[0];
  EXPECT_NE(w[1].find("T_AF - T_AS"), std::string::npos) << w[1];
  p = sma::Params();
  p.h = 800.0;
  const std::vector<std::string> wh = sma_host::plausibility_warnings(p, sma::Effects());
  ASSERT_EQ(wh.size(), 1u);
  EXPECT_EQ(wh[0].rfind("h = ", 0), 0u) << wh[0];
}
