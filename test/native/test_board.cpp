// sma::Board (sma/board.hpp), the firmware's logic as one unit: settings change only when a
// command sets them, the rig's limits come from its constants, the uploaded sensor calibration
// acts in the feedback.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <string.h>

#include <string>
#include <vector>

#include "../board_test_rig.hpp"
#include "board_test_io.hpp"
#include "sma/board.hpp"

namespace {

// A rig whose boot limit is not the console's historical 110 degC: a command that reset the
// latch from a default would show.
struct TestRig : BoardTestRig {
  static constexpr double v_max() { return 1.8; }
  static constexpr double t_limit_C() { return 95.0; }
};

typedef BoardTestIo Io;
typedef sma::Board<float, TestRig, Io> TestBoard;

struct Bench : BoardTestBench<TestBoard> {
  // One tick with the sensor reading `mm` (the rig's calibration inverted to ADC counts).
  uint16_t tick(double mm) {
    const double v = (mm - TestRig::sensor_offset_mm()) / TestRig::sensor_mm_per_v();
    const uint32_t a = static_cast<uint32_t>(v / TestRig::adc_vref() * TestRig::adc_counts() + 0.5);
    const uint16_t n = b->control(a * 96u, 96, 0);
    b->report();
    b->poll();
    return n;
  }
};

TEST(Board, BootsWithTheRigsLimits) {
  Bench r;
  EXPECT_DOUBLE_EQ(r.b->safety().t_limit_C(), 95.0);
  EXPECT_NE(r.cmd("status").find("tlim=95"), std::string::npos);
  EXPECT_DOUBLE_EQ(r.b->safety().t_limit_C(), 95.0);
  // volt in 0..V_max of the rig, not the console's default 2 V.
  EXPECT_EQ(r.cmd("volt 1.9").rfind("ERR volt", 0), 0u);
  EXPECT_EQ(r.cmd("volt 1.8").rfind("OK volt", 0), 0u);
  // pos in 0..g of the model (the paper's g = 0.958 mm, below the rig's 1.5 mm).
  EXPECT_EQ(r.cmd("pos 1.0").rfind("ERR pos", 0), 0u);
  EXPECT_EQ(r.cmd("pos 0.9").rfind("OK pos", 0), 0u);
}

TEST(Board, TlimSurvivesEveryOtherCommand) {
  Bench r;
  ASSERT_EQ(r.cmd("tlim 80").rfind("OK tlim", 0), 0u);
  const char* others[] = {"status", "pos 0.3", "step", "sine", "traj clear", "traj 1 0.3", "traj run",
                          "mode pid", "mode ff", "mode open", "mode ffpid", "volt 0.5", "gains 1 2 3",
                          "tele on", "tele off", "help", "stop", "pinfo", "pget rho", "pbegin",
                          "pset rho 6400", "pcommit", "pbegin", "pabort", "train", "stop", "",
                          "nonsense", "tlim 999"};
  for (const char* c : others) {
    r.cmd(c);
    r.tick(0.3);
    EXPECT_DOUBLE_EQ(r.b->safety().t_limit_C(), 80.0) << "after '" << c << "'";
    EXPECT_DOUBLE_EQ(r.b->state().tlim_C, 80.0) << "after '" << c << "'";
  }
  EXPECT_NE(r.cmd("status").find("tlim=80"), std::string::npos);
}

// `train [slope]` answers the length of the paper's plan at that slope: the board folds its
// slope-free parts at compile time (TrainingPlan::holds_s, ramp_V); here the length is summed
// segment by segment (section III.B: a hold, then per peak a rise and a descent at +-slope and a
// hold, then the probe's levels and its last probe_s off).
TEST(Board, TrainAnswersThePlansLengthAtItsSlope) {
  const sma::TrainingPlan p;
  for (double slope : {0.0, 1.0, 0.02}) {  // 0: no argument, the paper's slope
    Bench r;
    const double s = slope > 0.0 ? slope : p.slope;
    double want = p.hold_s;
    for (uint8_t k = 0; k < p.n_peaks; ++k) want += 2.0 * (p.peaks[k] - p.floor_V) / s + p.hold_s;
    want += p.n_probes * p.probe_s + p.probe_s;
    const std::string rep = r.cmd(slope > 0.0 ? "train " + std::to_string(slope) : std::string("train"));
    ASSERT_EQ(rep.rfind("OK train ", 0), 0u) << rep;
    EXPECT_NEAR(atof(rep.c_str() + 9), want, 0.051) << rep;  // printed to 0.1 s
  }
}

TEST(Board, OpenLoopVoltageChangesOnlyWithVolt) {
  Bench r;
  ASSERT_EQ(r.cmd("volt 1.0").rfind("OK volt", 0), 0u);
  const uint16_t before = r.tick(0.3);
  EXPECT_GT(before, 0u);
  r.cmd("tlim 90");
  r.cmd("gains 1 1 0");
  r.cmd("status");
  EXPECT_EQ(r.tick(0.3), before);
}

// The uploaded sensor calibration acts in the feedback: with measured = 2 D + 0.1 and the wire
// below the reference (D = 0.15 mm for 0.3 mm, the sensor showing 0.4 mm), the board that knows
// the calibration heats; the one that does not sees the wire past the reference and keeps the
// heater off.
TEST(Board, UploadedCalibrationIsUndoneInTheFeedback) {
  Bench known, unknown;
  ASSERT_EQ(known.cmd("pbegin").rfind("OK", 0), 0u);
  ASSERT_EQ(known.cmd("pset sensor_calibration.gain 2").rfind("OK", 0), 0u);
  ASSERT_EQ(known.cmd("pset sensor_calibration.offset_mm 0.1").rfind("OK", 0), 0u);
  ASSERT_EQ(known.cmd("pcommit").rfind("OK pcommit", 0), 0u);
  for (Bench* r : {&known, &unknown}) {
    r->cmd("mode pid");
    ASSERT_EQ(r->cmd("pos 0.3").rfind("OK pos", 0), 0u);
  }
  uint32_t sum_known = 0, sum_unknown = 0;
  for (int k = 0; k < 100; ++k) {
    sum_known += known.tick(0.4);
    sum_unknown += unknown.tick(0.4);
  }
  EXPECT_EQ(sum_unknown, 0u);
  EXPECT_GT(sum_known, 100u * 1000u);  // heating: above 1/16 duty on average
}

}  // namespace

// pget on a blank EEPROM answers the paper's value of every key (Table II, Effects() identity):
// the board reads it from its copy of the defaults without building a Params, and must answer
// as the console's model_command() does from sma::Params() / sma::Effects().
TEST(Board, PgetOfEveryDefaultKeyIsThePapersValue) {
  Bench r;
  EXPECT_EQ(r.cmd("pget T_AS"), "OK pget T_AS 50.2 0x4248cccd");  // Table II: T_AS 50.2 degC
  EXPECT_EQ(r.cmd("pget loops"), "OK pget loops 3 0x03");
  EXPECT_EQ(r.cmd("pget sensor_calibration.gain"), "OK pget sensor_calibration.gain 1 0x3f800000");
  uint8_t ee[1024];
  memset(ee, 0xFF, sizeof ee);
  sma::storage::Store<Io> store(Io{ee, nullptr});
  for (uint8_t k = 0; k < sma::storage::kNumKeys; ++k) {
    sma::console::Reply name;
    sma::storage::put_key_name(name, k);
    sma::console::Command c;
    c.op = sma::console::Op::PGet;
    c.key = k;
    sma::Params p;
    sma::Effects fx;
    sma::console::Reply expect;
    sma::console::model_command(c, store, p, fx, expect);
    EXPECT_EQ(r.cmd(std::string("pget ") + name.text), std::string(expect.text)) << name.text;
  }
}

// tele plot: the telemetry's four values as Teleplot lines (one reply, a line each), no header;
// tele on afterwards sends the header, then rows.
TEST(Board, TelePlotStreamsTeleplotLinesAndRowsResumeWithTheHeader) {
  Bench r;
  EXPECT_EQ(r.cmd("tele plot"), "OK tele plot");
  r.cmd("pos 0.3");
  r.lines.clear();
  r.tick(0.25);
  ASSERT_EQ(r.lines.size(), 1u);
  const std::string& s = r.lines[0];
  EXPECT_EQ(s.rfind(">v_V:", 0), 0u) << s;
  EXPECT_NE(s.find("\r\n>d_mm:0.2500\r\n>ref_mm:0.3000\r\n>duty:"), std::string::npos) << s;
  EXPECT_EQ(r.cmd("tele on"), "OK tele on");
  r.lines.clear();
  r.tick(0.25);
  ASSERT_EQ(r.lines.size(), 2u);
  EXPECT_EQ(r.lines[0], "t_s,v_V,d_mm,ref_mm,duty");
  EXPECT_EQ(r.lines[1].find('>'), std::string::npos);
  EXPECT_EQ(r.cmd("tele plot"), "OK tele plot");
  r.lines.clear();
  r.tick(0.25);
  ASSERT_EQ(r.lines.size(), 1u);
  EXPECT_EQ(r.lines[0].rfind(">v_V:", 0), 0u);
}
