// The host's closed loop on the Board (sma_host/board_loop.hpp, run_board_loop in closed_loop.hpp)
// against the Controller-level loop: the same controller and model on the same simulated wire,
// so the two may differ only by what the board adds, its ADC and PWM quantization and its
// sampling of the tick.
#include <gtest/gtest.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <string>
#include <vector>

#include "sma_host/board_rig.hpp"
#include "sma_host/closed_loop.hpp"
#include "sma_host/metrics.hpp"

namespace {
using sma_host::HostRig;
using sma_host::RunSetup;
typedef sma_host::BoardLoop<HostRig, sma::Plant> Loop;

// The paper's sine on a wire that is not the paper's (a board that kept the paper's model would
// show), the controller's model = the wire, ideal condition (no noise, no quantization but the
// board's).
RunSetup foreign_sine(sma::Mode mode) {
  RunSetup s;
  s.mode = mode;
  s.config.gains = sma::console::default_gains(mode);
  s.reference = sma::Reference::sine();
  s.plant_params.T_AS += 4.0;
  s.plant_params.T_AF += 4.0;
  s.plant_params.h *= 1.15;
  s.model_params = s.plant_params;
  return s;
}

// What the board adds to the feedback: one ADC count of the sensor (the mean of the tick's
// samples is no coarser), and its timing: the controller acts on the mean of the tick's samples,
// (n + 1) / 2 samples after the instant the Controller-level loop reads, so the two see the wire
// apart by at most its fastest speed over that time. The PWM's 1/16000 of duty (~0.1 mV at 1 V)
// is nothing next to these.
double board_tolerance_mm(const std::vector<sma_host::Sample>& run) {
  const double count_mm = HostRig::adc_vref() / HostRig::adc_counts() * HostRig::sensor_mm_per_v();
  const double sample_s = sma_host::BoardLoopOptions().sample_s;
  const double n = floor(1.0 / (HostRig::tick_hz() * sample_s) + 0.5);  // samples per tick
  double speed = 0.0;
  for (size_t k = 1; k < run.size(); ++k)
    speed = fmax(speed, fabs(run[k].truth - run[k - 1].truth) / (run[k].t - run[k - 1].t));
  return count_mm + speed * (n + 1.0) / 2.0 * sample_s;
}

TEST(BoardLoop, SineTracksLikeTheControllerLoop) {
  for (sma::Mode mode : {sma::Mode::FeedforwardPid, sma::Mode::Pid}) {
    const RunSetup s = foreign_sine(mode);
    const std::vector<sma_host::Sample> ctl = sma_host::run_closed_loop<float>(s);
    const std::vector<sma_host::Sample> brd = sma_host::run_board_loop<HostRig>(s);
    ASSERT_EQ(ctl.size(), brd.size());
    const double tol = board_tolerance_mm(ctl);
    const double period = s.reference.sine_period_s;
    const sma_host::Metrics a = sma_host::sine_metrics(ctl, period), b = sma_host::sine_metrics(brd, period);
    std::printf("%s, RMS whole / heating / cooling, max heating: controller %.4f / %.4f / %.4f, %.4f; board "
                "%.4f / %.4f / %.4f, %.4f mm (tolerance %.4f)\n",
                sma::mode_name(mode), a.rms_mm, a.rms_heat_mm, a.rms_fall_mm, a.max_heat_mm, b.rms_mm, b.rms_heat_mm,
                b.rms_fall_mm, b.max_heat_mm, tol);
    // The board tracks (a board that stays off would have the sine's own RMS, 0.18 mm).
    EXPECT_LT(b.rms_mm, 0.5 * (s.reference.sine_hi_mm - s.reference.sine_lo_mm));
    EXPECT_NEAR(b.rms_mm, a.rms_mm, tol);
    EXPECT_NEAR(b.rms_heat_mm, a.rms_heat_mm, tol);
    EXPECT_NEAR(b.rms_fall_mm, a.rms_fall_mm, tol);
    EXPECT_NEAR(b.max_heat_mm, a.max_heat_mm, tol);
    // The reference the board ran is the paper's sine at the same ticks.
    for (size_t k = 0; k < ctl.size(); k += 500) EXPECT_NEAR(brd[k].ref, ctl[k].ref, 1e-5) << "t " << ctl[k].t;
  }
}

TEST(BoardLoop, ARefusedCommandGivesTheBoardsErrLine) {
  RunSetup s = foreign_sine(sma::Mode::FeedforwardPid);
  s.duration_s = 1.0;
  try {
    sma_host::run_board_loop<HostRig>(s, {"tlim 500"});
    FAIL() << "tlim 500 (range 30..150) was accepted";
  } catch (const sma_host::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'tlim 500'"), std::string::npos) << what;
    EXPECT_NE(what.find("ERR tlim"), std::string::npos) << what;
  }
  // A gain beyond the console's range, from the run's own setup.
  s.config.gains.kp = 2000.0;
  EXPECT_THROW(sma_host::run_board_loop<HostRig>(s), sma_host::Error);
}

TEST(BoardLoop, TheModelSentIsTheModelTheBoardRuns) {
  // A model other than the paper's, sent as pset lines: every value reads back as sent (float).
  RunSetup s = foreign_sine(sma::Mode::FeedforwardPid);
  s.model_params.T_AS += 3.25;
  s.model_params.h *= 1.1;
  s.model_effects.sensor_delay_s = 0.05;
  sma::Plant plant(s.plant_params);
  Loop loop(plant);
  loop.boot();
  for (const std::string& l : sma_host::board_commands(s)) ASSERT_EQ(loop.send(l).compare(0, 2, "OK"), 0) << l;
  // `OK pget <key> <value> 0x<float32 bits>`: the value the board stored, exactly.
  auto got = [&](const char* key) {
    const std::string r = loop.send(std::string("pget ") + key);
    const uint32_t bits = static_cast<uint32_t>(strtoul(r.substr(r.rfind(" 0x") + 1).c_str(), nullptr, 16));
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
  };
  EXPECT_EQ(got("T_AS"), static_cast<float>(s.model_params.T_AS));
  EXPECT_EQ(got("h"), static_cast<float>(s.model_params.h));
  EXPECT_EQ(got("sensor_delay.delay_s"), 0.05f);
}

TEST(BoardLoop, AdcAndPwmAreTheRigs) {
  // The calibration inverted: the sensor's valid range ends at its volts.
  EXPECT_NEAR(Loop::sensor_mv(HostRig::sensor_offset_mm() + 2.0 * HostRig::sensor_mm_per_v()), 2000.0, 1e-9);
  EXPECT_EQ(Loop::adc_counts(HostRig::adc_vref() * 1000.0), HostRig::adc_counts() - 1);  // full scale
  EXPECT_EQ(Loop::adc_counts(-5.0), 0);
  // PWM counts and volts are each other's inverse within one count (duty = (V / V_supply)^2).
  for (double v : {0.3, 1.0, 1.7, 2.0}) {
    const uint16_t n = Loop::Board::pwm_counts(static_cast<float>(v));
    const double count_v = HostRig::v_supply() * HostRig::v_supply() / (2.0 * v * (HostRig::pwm_top() + 1.0));
    EXPECT_NEAR(Loop::pwm_volts(n), v, count_v);
  }
}

// Inverse + PID's known future goes to the board as `lead F`, the factor on the board's tuned
// lead of the reference's kind; a lead the console cannot express is refused, naming it.
TEST(BoardLoop, TheLeadIsSentAsTheBoardsFactor) {
  auto lead_line = [](const RunSetup& s) {
    for (const std::string& l : sma_host::board_commands(s))
      if (l.compare(0, 5, "lead ") == 0) return l;
    return std::string();
  };
  RunSetup s = foreign_sine(sma::Mode::FeedforwardPid);
  EXPECT_EQ(lead_line(s), "lead 0");  // no lead: the paper's inverse + PID
  s.lead = sma::lead_for(s.reference.kind);
  EXPECT_EQ(lead_line(s), "lead 1");
  s.lead.lead_s = 0.5 * sma::lead_for(s.reference.kind).lead_s;  // half of the sine's
  EXPECT_EQ(lead_line(s), "lead 0.5");
  s.reference = sma::Reference::multi_step();
  s.lead.lead_s = 15.0;  // 1.5 x the steps' 10 s
  EXPECT_EQ(lead_line(s), "lead 1.5");
  s.reference = sma::Reference::constant(0.4);  // no future: no line
  EXPECT_EQ(lead_line(s), "");
  s.reference = sma::Reference::sine();
  s.lead.lead_s = 2.1 * sma::lead_for(sma::RefKind::Sine).lead_s;  // beyond the console's 0..2
  EXPECT_THROW(sma_host::board_commands(s), sma_host::Error);
  s.lead.lead_s = 3.0;
  s.lead.peak_window_s = 5.0;  // the board's window is the default one
  EXPECT_THROW(sma_host::board_commands(s), sma_host::Error);
  s.lead.peak_window_s = sma::LeadConfig().peak_window_s;
  EXPECT_THROW(sma_host::board_commands(s, false), sma_host::Error);  // a board without the lead
  s.mode = sma::Mode::Pid;  // PID alone: no line
  EXPECT_EQ(lead_line(s), "");
}

}  // namespace
