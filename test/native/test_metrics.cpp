// The tracking metrics (host/include/sma_host/metrics.hpp) on runs whose errors are known by
// construction: what each number means is what the README's tables report.
#include <gtest/gtest.h>
#include <math.h>
#include <vector>
#include "sma_host/metrics.hpp"

namespace {

sma_host::Sample at(double t, double ref, double truth) { return {t, ref, truth, truth, 0, 0, 0}; }

// A sine reference whose position lags by 0.01 mm while it rises and leads by 0.02 mm while
// it falls: the heating numbers see only the first, the cooling one only the second.
TEST(Metrics, SineSplitsHeatingFromCooling) {
  const double period = 10.0;
  std::vector<sma_host::Sample> run;
  for (int k = 0; k <= 4000; ++k) {
    const double t = 0.01 * k;
    const double ref = 0.5 + 0.3 * sin(2 * M_PI * t / period);
    const double rising = cos(2 * M_PI * t / period) > 0;
    run.push_back(at(t, ref, rising ? ref - 0.01 : ref + 0.02));
  }
  const sma_host::Metrics m = sma_host::sine_metrics(run, period);
  EXPECT_NEAR(m.max_heat_mm, 0.01, 1e-12);
  EXPECT_NEAR(m.rms_heat_mm, 0.01, 1e-12);
  EXPECT_NEAR(m.max_cool_mm, 0.02, 1e-12);
  EXPECT_NEAR(m.rms_mm, sqrt(0.5 * (0.01 * 0.01 + 0.02 * 0.02)), 2e-4);  // half the time each
}

// One step up: the position ramps to the setpoint in 1 s (not scored as error: that is the
// settling), then holds 0.05 mm past it (5 % overshoot of a 1 mm step).
TEST(Metrics, StepScoresFromArrivalAndReportsOvershoot) {
  std::vector<sma_host::Sample> run;
  for (int k = 0; k < 1000; ++k) {
    const double t = 0.01 * k;
    run.push_back(at(t, 1.0, t < 1.0 ? t : 1.05));
  }
  const sma_host::Metrics m = sma_host::step_metrics(run, 10.0);
  EXPECT_NEAR(m.max_heat_mm, 0.05, 1e-12);
  EXPECT_NEAR(m.rms_heat_mm, 0.05, 1e-12);
  EXPECT_NEAR(m.overshoot_pct, 5.0, 1e-9);
  EXPECT_NEAR(m.sse_mm, 0.05, 1e-12);
  EXPECT_EQ(m.max_cool_mm, 0.0);
}

}  // namespace

namespace {
// A step the position never reaches (it settles 0.1 mm short): that shortfall is its error while
// heating, not zero.
TEST(Metrics, StepNeverReachedCountsItsShortfall) {
  std::vector<sma_host::Sample> run;
  for (int k = 0; k < 1000; ++k) {
    const double t = 0.01 * k;
    run.push_back(at(t, 1.0, fmin(t, 0.9)));
  }
  const sma_host::Metrics m = sma_host::step_metrics(run, 10.0);
  EXPECT_NEAR(m.max_heat_mm, 0.1, 1e-12);
  EXPECT_NEAR(m.rms_heat_mm, 0.1, 1e-12);
  EXPECT_NEAR(m.sse_mm, 0.1, 1e-12);
  EXPECT_EQ(m.overshoot_pct, 0.0);
}
}  // namespace
