// The preview at the sine's top (preview.hpp): the heating stops at the plan's best time between
// its candidates, and the wire, past the top of the loop's rise (eq 5), is cooled on through the
// flat stage (eqs 7-10) to T_MSi instead of waiting there while the reference is above it; it then
// follows the reference down at once. Issue 13: the sine's whole-period max within 1.5x of the
// bound bench_optimal_bound computes (rig-like sine 0.0144 mm on the paper's model, docs/control.md
// section 3: the search that starts from the controllers' own 10 ms profiles).
#include <gtest/gtest.h>
#include "sma/fixed.hpp"
#include "sma_host/metrics.hpp"
#include "sma_host/plant_b_rig.hpp"

namespace {

// The paper's sine, rig-like, under the preview with the given ride margin.
sma_host::RunSetup preview_sine(double ride_margin_mm) {
  sma_host::RunSetup s;
  s.mode = sma::Mode::Preview;
  s.preview.ride_margin_mm = ride_margin_mm;
  s.reference = sma::Reference::sine();
  s.condition = sma_host::Condition::rig_like();
  return s;
}

template <class T>
double sine_max_rig_like(double ride_margin_mm = sma::PreviewConfig().ride_margin_mm) {
  const sma_host::RunSetup s = preview_sine(ride_margin_mm);
  return sma_host::sine_metrics(sma_host::run_closed_loop<T>(s), s.reference.sine_period_s).max_mm;
}

// With the flat stage waited out at the top (and the heating stopped only when "now" won
// outright) the float sine's max was 0.050 mm: the wire sat at the top ~5 s into the fall.
// Riding the rise up to its very top (ride_margin_mm = 0) leaves the wire at ~60 C there, and
// the fall waits for the flat stage: 0.027 mm, over 1.5x (the check can fail).
TEST(PreviewTop, SineWithinOneAndAHalfTimesTheBound) {
  const double bound_mm = 0.0144;
  EXPECT_LE(sine_max_rig_like<float>(), 1.5 * bound_mm);
  EXPECT_LE(sine_max_rig_like<sma::Fixed>(), 1.5 * bound_mm);
  EXPECT_GT(sine_max_rig_like<float>(0.0), 1.5 * bound_mm);
}

// Plant B (written apart from the library) with its convection 8-12 % off the model's, where
// the heat-loss observer moves the model wire: it follows the reference up a loop's rise, and
// whether a reference that still climbs lies just above it or just below is a rounding. Read
// as a move down, the plan's "stop heating now" saw the whole rest of the rise ahead (eqs 5-6),
// the heating stopped late and the wire rose past the top in Q16.16 (sine max 0.121-0.135 mm,
// float 0.027-0.041). Within the ride's margin (PreviewConfig::ride_margin_mm) the reference is
// still ridden: every scalar meets issue 13's sine targets; without it Q16.16 does not.
template <class T>
sma_host::Metrics sine_on_b(double wire_h_scale, double ride_margin_mm) {
  const sma_host::RunSetup s = preview_sine(ride_margin_mm);
  sma_host::plant_b::Wire w;
  w.h *= wire_h_scale;
  w.return_point_memory = true;
  sma_host::plant_b::RigB rig(w, sma_host::plant_b::WireEffects(), s.condition.rig, s.config.dt);
  return sma_host::sine_metrics(sma_host::run_closed_loop_on<T>(rig, s), s.reference.sine_period_s);
}

TEST(PreviewTop, TheRideDoesNotHingeOnARounding) {
  const double margin = sma::PreviewConfig().ride_margin_mm;
  for (double h : {0.88, 0.92, 1.12}) {
    const sma_host::Metrics mf = sine_on_b<float>(h, margin), mq = sine_on_b<sma::Fixed>(h, margin);
    for (const sma_host::Metrics* m : {&mf, &mq}) {
      EXPECT_LE(m->max_mm, 0.12) << "wire h x" << h;
      EXPECT_LE(m->rms_mm, 0.05) << "wire h x" << h;
    }
  }
  EXPECT_GT(sine_on_b<sma::Fixed>(1.12, 0.0).max_mm, 0.12);
}

}  // namespace
