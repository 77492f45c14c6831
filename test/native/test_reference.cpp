// Reference generators: the paper's two tests and user trajectories.
#include <gtest/gtest.h>
#include <math.h>
#include "sma/reference.hpp"
#include "sma/training.hpp"

TEST(Reference, MultiStepIsThePapersSequence) {
  const sma::ReferenceGen<double> r(sma::Reference::multi_step());
  const double levels[] = {0.2, 0.4, 0.6, 0.8, 0.5, 0.3};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(r.at(25.0 * k + 0.01), levels[k]);
    EXPECT_EQ(r.at(25.0 * k + 24.99), levels[k]);
  }
  EXPECT_EQ(r.at(1000.0), 0.3);  // held after the end
  EXPECT_EQ(sma::Reference::multi_step().duration(), 150.0);
}

TEST(Reference, SineSpansPointTwoToPointSevenWithA50sPeriod) {
  const sma::ReferenceGen<double> r(sma::Reference::sine());
  EXPECT_NEAR(r.at(0.0), 0.2, 1e-12);   // starts at the bottom: no jump at t = 0
  EXPECT_NEAR(r.at(25.0), 0.7, 1e-12);
  EXPECT_NEAR(r.at(50.0), 0.2, 1e-12);
  EXPECT_NEAR(r.at(112.5), 0.45, 1e-12);
  double lo = 1, hi = 0;
  for (double t = 0; t < 150; t += 0.01) {
    lo = fmin(lo, r.at(t));
    hi = fmax(hi, r.at(t));
  }
  EXPECT_NEAR(lo, 0.2, 1e-9);
  EXPECT_NEAR(hi, 0.7, 1e-7);
}

TEST(Reference, TrajectoryInterpolatesAndRejectsBadPoints) {
  sma::Reference ref;
  ref.kind = sma::RefKind::Trajectory;
  EXPECT_TRUE(ref.add_point(0.0, 0.1));
  EXPECT_TRUE(ref.add_point(10.0, 0.5));
  EXPECT_FALSE(ref.add_point(10.0, 0.6));  // time must increase
  EXPECT_FALSE(ref.add_point(NAN, 0.6));
  EXPECT_FALSE(ref.add_point(12.0, INFINITY));
  EXPECT_FALSE(ref.add_point(12.0, -0.05));  // below the stroke: not a position
  EXPECT_EQ(ref.n_points, 2);
  EXPECT_TRUE(ref.add_point(12.0, 0.0));  // the stroke's start is one
  ref.n_points = 2;
  const sma::ReferenceGen<double> r(ref);
  EXPECT_NEAR(r.at(5.0), 0.3, 1e-12);
  EXPECT_NEAR(r.at(-1.0), 0.1, 1e-12);
  EXPECT_NEAR(r.at(20.0), 0.5, 1e-12);
  for (int k = 0; k < 20; ++k) ref.add_point(11.0 + k, 0.2);
  EXPECT_EQ(ref.n_points, sma::kMaxPoints);  // full: further points refused
}

// A player that keeps a cursor (the firmware, every tick) hears the same plan as one that walks
// every cycle from the start at each call, ticks at 100 Hz from before the start to past the end.
TEST(Training, ACursorPlaysTheSamePlan) {
  for (double slope : {5.88e-3, 1.0}) {
    sma::TrainingPlan p;
    p.slope = slope;
    sma::TrainingPlan::Cursor c;
    uint8_t cycles_seen = 0;
    for (int k = -10; k * 0.01 < p.duration() + 5.0; ++k) {
      const double t = k * 0.01;
      // (At a step of the probe the two roundings of t can fall on either side of it: the level
      // of t +- 1 us counts there.)
      const double v = p.voltage_at(t, c);
      const bool same = fabs(v - p.voltage_at(t)) < 1e-9 || fabs(v - p.voltage_at(t - 1e-6)) < 1e-9 ||
                        fabs(v - p.voltage_at(t + 1e-6)) < 1e-9;
      ASSERT_TRUE(same) << "t = " << t << " s, slope " << slope << ": " << v << " V, the plan " << p.voltage_at(t);
      cycles_seen = c.k;
    }
    EXPECT_EQ(cycles_seen, p.n_peaks);  // it walked through every cycle, not from the start
  }
}

// A cursor that has walked to the plan's end, asked for an earlier t (a player restarted, a
// clock that stepped back), plays the plan there: the middle of each cycle's rise, last cycle
// first, is halfway between the floor and that cycle's peak (not the ramp extended below it).
TEST(Training, ACursorIsRightWhenTimeGoesBack) {
  sma::TrainingPlan p;
  sma::TrainingPlan::Cursor c;
  p.voltage_at(p.duration() + 1.0, c);
  ASSERT_EQ(c.k, p.n_peaks);
  double start[sma::kMaxTrainingPeaks];
  double t = p.hold_s;
  for (uint8_t k = 0; k < p.n_peaks; ++k) {
    start[k] = t;
    t += p.cycle_s(k);
  }
  for (int k = p.n_peaks - 1; k >= 0; --k) {
    const double rise = (p.peaks[k] - p.floor_V) / p.slope;
    EXPECT_NEAR(p.voltage_at(start[k] + 0.5 * rise, c), 0.5 * (p.peaks[k] + p.floor_V), 1e-9) << "cycle " << k;
  }
}

TEST(Training, ThePapersDecayingRampWithReversalsAndAProbe) {
  const sma::TrainingPlan p;
  EXPECT_EQ(p.check(), nullptr);
  // Ramps at exactly +-slope between the floor and each (decaying) peak.
  double t = p.hold_s;
  for (uint8_t k = 0; k < p.n_peaks; ++k) {
    const double rise = (p.peaks[k] - p.floor_V) / p.slope;
    EXPECT_NEAR(p.voltage_at(t + 0.5 * rise), 0.5 * (p.peaks[k] + p.floor_V), 1e-9);
    EXPECT_NEAR(p.voltage_at(t + rise), p.peaks[k], 1e-6);
    EXPECT_NEAR(p.voltage_at(t + 1.5 * rise), 0.5 * (p.peaks[k] + p.floor_V), 1e-9);
    if (k > 0) {
      EXPECT_LT(p.peaks[k], p.peaks[k - 1]);  // decaying
    }
    t += p.cycle_s(k);
  }
  // The probe: each level held probe_s in turn, then probe_s off.
  ASSERT_GT(p.n_probes, 2);
  for (uint8_t k = 0; k < p.n_probes; ++k) {
    EXPECT_EQ(p.voltage_at(t + (k + 0.02) * p.probe_s), p.probes[k]);
    EXPECT_EQ(p.voltage_at(t + (k + 0.98) * p.probe_s), p.probes[k]);
  }
  EXPECT_EQ(p.voltage_at(t + (p.n_probes + 0.5) * p.probe_s), 0.0);
  EXPECT_EQ(p.voltage_at(p.duration() + 1.0), 0.0);
  EXPECT_NEAR(p.duration(), t + (p.n_probes + 1) * p.probe_s, 1e-9);
  // It goes up and down through the band: both directions of the transformation are probed.
  bool up = false, down = false;
  for (uint8_t k = 1; k < p.n_probes; ++k) {
    up = up || p.probes[k] > p.probes[k - 1];
    down = down || p.probes[k] < p.probes[k - 1];
  }
  EXPECT_TRUE(up && down);
  EXPECT_GT(p.duration(), 3600.0);  // the paper's slope makes it slow: 1.7 h
  sma::TrainingPlan bad;
  bad.slope = 0;
  EXPECT_NE(bad.check(), nullptr);
  bad = sma::TrainingPlan();
  bad.peaks[3] = -1;
  EXPECT_NE(bad.check(), nullptr);
  bad = sma::TrainingPlan();
  bad.probes[2] = 6.0;  // above the supply
  EXPECT_NE(bad.check(), nullptr);
  bad = sma::TrainingPlan();
  bad.probe_s = 0;  // no probe time: the plan ends after the ramps, never divides by zero
  EXPECT_EQ(bad.check(), nullptr);
  EXPECT_EQ(bad.voltage_at(bad.duration() - 1e-9), 0.0);
}
