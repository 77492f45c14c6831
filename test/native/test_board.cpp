// sma::Board (sma/board.hpp), the firmware's logic as one unit: settings change only when a
// command sets them, the rig's limits come from its constants, the uploaded sensor calibration
// acts in the feedback.
#include <gtest/gtest.h>
#include <string.h>

#include <string>
#include <vector>

#include "sma/board.hpp"

namespace {

// A rig whose boot limit is not the console's historical 110 degC: a command that reset the
// latch from a default would show.
struct TestRig {
  static constexpr double tick_hz() { return 100; }
  static constexpr double v_max() { return 1.8; }
  static constexpr double v_supply() { return 5.0; }
  static constexpr unsigned long pwm_top() { return 15999; }
  static constexpr double adc_vref() { return 5.0; }
  static constexpr double adc_counts() { return 1024; }
  static constexpr double sensor_mm_per_v() { return 0.4; }
  static constexpr double sensor_offset_mm() { return -0.5; }
  static constexpr double sensor_v_min() { return 0.1; }
  static constexpr double sensor_v_max() { return 4.9; }
  static constexpr double t_limit_C() { return 95.0; }
  static constexpr double link_timeout_s() { return 0.0; }
  static constexpr double stroke_mm() { return 1.5; }
  static constexpr bool model() { return true; }
  static constexpr bool train() { return true; }
  static constexpr bool compensate() { return true; }
};

struct Io {
  uint8_t* ee;
  std::vector<std::string>* lines;
  bool line(const char* s, uint8_t len) {
    lines->push_back(std::string(s, len));
    return true;
  }
  uint8_t read(uint16_t a) const { return ee[a % 1024]; }
  void write(uint16_t a, uint8_t v) { ee[a % 1024] = v; }
  uint8_t irq_off() { return 0; }
  void irq_restore(uint8_t) {}
};
typedef sma::Board<float, TestRig, Io> TestBoard;

struct Bench {
  uint8_t ee[1024];
  std::vector<std::string> lines;
  TestBoard* b;
  Bench() {
    memset(ee, 0xFF, sizeof ee);
    b = new TestBoard(Io{ee, &lines});
    b->boot(false, "# ready");
  }
  ~Bench() { delete b; }
  // A line in, its reply out.
  std::string cmd(const std::string& s) {
    lines.clear();
    for (char c : s + "\n") {
      if (!b->rx(c)) continue;
      b->handle_line();
      if (b->model_pending()) b->run_model_op();
      b->poll();
    }
    return lines.empty() ? "" : lines.back();
  }
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
  EXPECT_DOUBLE_EQ(r.b->safety().config().t_limit_C, 95.0);
  EXPECT_NE(r.cmd("status").find("tlim=95"), std::string::npos);
  EXPECT_DOUBLE_EQ(r.b->safety().config().t_limit_C, 95.0);
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
    EXPECT_DOUBLE_EQ(r.b->safety().config().t_limit_C, 80.0) << "after '" << c << "'";
    EXPECT_DOUBLE_EQ(r.b->state().tlim_C, 80.0) << "after '" << c << "'";
  }
  EXPECT_NE(r.cmd("status").find("tlim=80"), std::string::npos);
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
