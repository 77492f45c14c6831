// The two readings of a re-heat that stops short of transformation (Params::reheat,
// hysteresis.hpp): return_point keeps the interrupted loop, new_loop (model.md taken literally)
// opens a loop at every peak. Checked against eqs 10-11 and against plant B, which implements
// the literal reading apart from the library (plant_b.hpp).
#include <gtest/gtest.h>
#include <math.h>
#include "sma/hysteresis.hpp"
#include "sma_host/identify.hpp"
#include "sma_host/plant_b.hpp"
#include "temperature_walk.hpp"

namespace {

sma::Params with_reading(sma::Reheat r) {
  sma::Params p;
  p.reheat = r;
  return p;
}

using temperature_walk::walk;

// Eq 11 on a loop of top 1 whose martensite start is T_MSi.
double eq11(double T, double T_MSi, double T_MF) {
  return 0.5 * (1.0 - cos(M_PI * (T - T_MF) / (T_MSi - T_MF)));
}

}  // namespace

TEST(ReheatReading, DefaultIsReturnPoint) {
  EXPECT_TRUE(sma::Params().reheat == sma::Reheat::return_point);
  EXPECT_FALSE(sma::PhaseCurves<double>(sma::Params()).every_peak_opens_loop());
}

// model.md's example: a fully transformed wire cooled to 50 degC and re-heated to 53.6 degC.
// Literally (eq 10 at T_i = 53.6: q eps_h(53.6) + e = 59.4 degC, clamped to T_ii = T_i) the new
// loop's martensite start is 53.6 and the wire lengthens at once along eq 11; with
// return-point memory it stays transformed until its old branch (T_MSi 27.8 degC).
TEST(ReheatReading, ReheatShortOfTransformationOpensALoopAtItsPeak) {
  const sma::Params lit = with_reading(sma::Reheat::new_loop), rpm = with_reading(sma::Reheat::return_point);
  const sma::PhaseCurves<double> cl(lit), cr(rpm);
  sma::Hysteresis<double> hl(cl, 22.0), hr(cr, 22.0);
  for (sma::Hysteresis<double>* h : {&hl, &hr}) {
    walk(*h, 85.0);
    walk(*h, 50.0);
    ASSERT_NEAR(h->eps(), 1.0, 1e-12);
    walk(*h, 53.6);
    ASSERT_NEAR(h->eps(), 1.0, 1e-12);  // heating from above the curve: flat (eq 4)
  }
  const double eq10 = lit.q * cl.eps_heat(53.6) + lit.e;
  ASSERT_GT(eq10, 53.6);  // so the clamp to T_ii = T_i applies
  EXPECT_NEAR(hl.loop_for_cooling().T_MSi, 53.6, 1e-9);
  walk(hl, 40.0);
  walk(hr, 40.0);
  EXPECT_NEAR(hl.loop().T_i, 53.6, 1e-9);
  EXPECT_NEAR(hl.eps(), eq11(40.0, 53.6, lit.T_MF), 1e-9);  // ~0.61: lengthening
  EXPECT_NEAR(hr.eps(), 1.0, 1e-12);                        // still flat above 27.8
}

// After a heating that transforms, both readings are the paper's minor loop (model.md check
// values of the 68.5 degC loop).
TEST(ReheatReading, TransformingHeatingGivesThePapersLoopInBothReadings) {
  for (sma::Reheat r : {sma::Reheat::return_point, sma::Reheat::new_loop}) {
    const sma::Params p = with_reading(r);
    const sma::PhaseCurves<double> c(p);
    sma::Hysteresis<double> h(c, 22.0);
    walk(h, 68.5);
    EXPECT_NEAR(h.eps(), 0.6724, 1e-3);
    EXPECT_NEAR(h.update(60.0), 0.8442, 1e-3);
    EXPECT_NEAR(h.update(40.0), 0.8624, 1e-3);
    EXPECT_NEAR(h.update(30.0), 0.7945, 1e-3);
    EXPECT_NEAR(h.update(25.0), 0.1856, 1e-3);
  }
}

// The inverse's route (loop_for_cooling / prepare_cooling / update with the known fraction)
// walks the same states as update() alone in the literal reading too.
TEST(ReheatReading, PreparedLoopWalksTheSamePathInTheLiteralReading) {
  const sma::Params p = with_reading(sma::Reheat::new_loop);
  const sma::PhaseCurves<double> c(p);
  sma::Hysteresis<double> plain(c, 22.0), hinted(c, 22.0);
  const double path[] = {85, 50, 53.6, 45, 52, 30, 66, 55, 58, 40, 22};
  double T = 22.0;
  for (double to : path) {
    const double s = to > T ? 0.25 : -0.25;
    while ((to - T) * s > 0) {
      T = fabs(to - T) < 0.25 ? to : T + s;
      const double eps = plain.update(T);
      const double known = s > 0 ? c.eps_heat(T) : c.eps_cool(hinted.prepare_cooling(), T);
      ASSERT_NEAR(hinted.update(T, known), eps, 1e-12) << "at T = " << T;
    }
  }
}

// Plant B's literal reading (written apart from the library) and the library's new_loop walk
// the same fraction along one temperature path with re-heats short of transformation.
TEST(ReheatReading, LiteralReadingAgreesWithPlantB) {
  const sma::Params p = with_reading(sma::Reheat::new_loop);
  const sma::PhaseCurves<double> c(p);
  sma::Hysteresis<double> h(c, 22.0);
  sma_host::plant_b::Wire w;
  w.return_point_memory = false;
  sma_host::plant_b::Transformation b(w);
  b.update(22.0);
  const double path[] = {85, 50, 53.6, 45, 52, 30, 66, 55, 58, 40, 64, 62, 63, 22};
  double T = 22.0;
  double worst = 0.0;
  for (double to : path) {
    const double s = to > T ? 0.1 : -0.1;
    while ((to - T) * s > 0) {
      T = fabs(to - T) < 0.1 ? to : T + s;
      b.update(T);
      worst = fmax(worst, fabs(h.update(T) - b.fraction()));
    }
  }
  EXPECT_LT(worst, 1e-9);
}

// The replay (the engine's one model run) follows the params' reading: on a drive that re-heats
// a transformed wire short of its band, the two readings differ; on one that does not, they agree.
TEST(ReheatReading, ReplayFollowsTheParamsReading) {
  std::vector<double> t, v;
  auto hold = [&](double volts, double seconds) {
    for (int k = 0; k < static_cast<int>(seconds * 100); ++k) {
      t.push_back(static_cast<double>(t.size()) * 0.01);
      v.push_back(volts);
    }
  };
  hold(0.0, 2);
  hold(2.0, 25);   // fully transformed
  hold(1.0, 25);   // cools to ~49.6 degC: still austenite (T_MSi 27.8)
  hold(1.12, 10);  // re-heat to ~56 degC: short of the curve at eps 1
  hold(0.0, 30);   // cool
  const std::vector<double> d;  // start at rest, martensite
  sma_host::ReplayOptions o;
  sma_host::Trace a, b;
  sma_host::replay(sma_host::Model{with_reading(sma::Reheat::return_point), {}}, t, v, d, o, a);
  sma_host::replay(sma_host::Model{with_reading(sma::Reheat::new_loop), {}}, t, v, d, o, b);
  const size_t end_reheat = static_cast<size_t>(62 * 100);
  ASSERT_NEAR(a.eps[end_reheat - 1], 1.0, 1e-9);
  // 5 s into the cooling (about 35 degC): the literal wire has lengthened, the other has not.
  const size_t k = end_reheat + 500;
  EXPECT_GT(a.T[k], 27.8);
  EXPECT_NEAR(a.eps[k], 1.0, 1e-9);
  EXPECT_LT(b.eps[k], 0.9);
  for (size_t i = 0; i < 5200; ++i) ASSERT_EQ(a.eps[i], b.eps[i]);  // identical before the re-heat
}
