// Closed loop at 100 Hz on the simulated plant: the paper's two tests (multi-step, Fig. 9-11;
// sine, Fig. 12-13), feedforward + PID against PID alone, each tuned for its own best result
// in each condition by the same method (host/include/sma_host/tune.hpp: log grid over
// kp, ki, kd from 0 to far past stability, then coordinate descent).
// The paper: max |error| while heating improves by 51.4 % with the inverse model.
#include <gtest/gtest.h>
#include "sma_host/tune.hpp"

namespace {
using sma_host::Condition;
using sma_host::RunSetup;
using sma_host::TuneResult;

TuneResult tuned(sma::Mode mode, bool sine, const Condition& c) {
  RunSetup s;
  s.mode = mode;
  s.condition = c;
  s.reference = sine ? sma::Reference::sine() : sma::Reference::multi_step();
  return sma_host::tune_pid(s);
}

struct Case {
  bool sine;
  bool rig_like;
};

class PaperTest : public ::testing::TestWithParam<Case> {};

TEST_P(PaperTest, FeedforwardPlusPidBeatsTunedPid) {
  const Case c = GetParam();
  const Condition cond = c.rig_like ? Condition::rig_like() : Condition::ideal();
  const TuneResult pid = tuned(sma::Mode::Pid, c.sine, cond);
  const TuneResult ffpid = tuned(sma::Mode::FeedforwardPid, c.sine, cond);
  ASSERT_TRUE(std::isfinite(pid.cost));
  ASSERT_TRUE(std::isfinite(ffpid.cost));
  const double e_pid = pid.metrics.max_heat_mm, e_ff = ffpid.metrics.max_heat_mm;
  std::printf("%s %s: max|e| heating PID %.4f mm, FF+PID %.4f mm\n", c.sine ? "sine" : "steps",
              cond.name, e_pid, e_ff);
  if (!c.sine) {
    // Zero steady-state error on steps for both (< 5 um averaged over each step's last 2 s).
    EXPECT_LT(pid.metrics.sse_mm, 0.005);
    EXPECT_LT(ffpid.metrics.sse_mm, 0.005);
  }
  if (!c.sine && !c.rig_like) {
    // Ideal plant, steps: both reach every setpoint without overshoot, so both heating errors
    // after arrival are ~0 and there is nothing for the inverse to halve (README, "Results").
    EXPECT_LT(e_ff, e_pid + 0.001);
    return;
  }
  EXPECT_LE(e_ff, (1.0 - 0.514) * e_pid) << "improvement " << 100 * (1 - e_ff / e_pid) << " %";
}

INSTANTIATE_TEST_SUITE_P(SineAndSteps, PaperTest,
                         ::testing::Values(Case{true, false}, Case{true, true}, Case{false, false},
                                           Case{false, true}),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           return std::string(i.param.sine ? "Sine" : "Steps") +
                                  (i.param.rig_like ? "RigLike" : "Ideal");
                         });

TEST(ClosedLoop, CoolingErrorIsBoundedByPassiveCooling) {
  // Cooling error on the sine is set by the minor-loop rise and passive cooling, for any
  // controller (model.md: ~0.24 mm): check we are in that regime, not worse.
  RunSetup s;
  s.config.gains.kp = 12.8;
  s.config.gains.ki = 4;
  s.config.gains.kd = 0.09;
  const sma_host::Metrics m = sma_host::evaluate(s, s.config.gains);
  EXPECT_GT(m.max_cool_mm, 0.15);
  EXPECT_LT(m.max_cool_mm, 0.30);
}
}  // namespace
