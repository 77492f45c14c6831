// The serial console (sma/console.hpp): every command, every class of bad line, the line
// assembly, the number formatting of replies and telemetry, and a deterministic fuzz loop.
#include <gtest/gtest.h>

#include <stdint.h>
#include <string.h>

#include <algorithm>
#include <string>

#include "sma/console.hpp"

namespace con = sma::console;
using con::Reply;
using con::State;
using sma::Fault;
using sma::Mode;

namespace {

bool same_gains(const sma::PidGains& a, const sma::PidGains& b) {
  return a.kp == b.kp && a.ki == b.ki && a.kd == b.kd && a.d_filter_s == b.d_filter_s &&
         a.i_zone_mm == b.i_zone_mm;
}

// Field-by-field equality of two console states (no memcmp: padding).
bool same_state(const State& a, const State& b) {
  if (a.mode != b.mode || a.heat != b.heat || a.volt != b.volt || a.tlim_C != b.tlim_C || a.lead != b.lead ||
      a.tele != b.tele || a.run_kind != b.run_kind || a.pos_mm != b.pos_mm || a.run != b.run)
    return false;
  if (!same_gains(a.gains_pid, b.gains_pid) || !same_gains(a.gains_ffpid, b.gains_ffpid)) return false;
  if (a.traj.kind != b.traj.kind || a.traj.n_points != b.traj.n_points) return false;
  for (uint8_t k = 0; k < a.traj.n_points; ++k)
    if (a.traj.point_t[k] != b.traj.point_t[k] || a.traj.point_mm[k] != b.traj.point_mm[k]) return false;
  return true;
}

struct Console {
  State s;
  Reply r;
  Fault fault = Fault::None;
  bool ok = false;
  std::string run(const char* line) {
    ok = con::execute(line, s, fault, r);
    return std::string(r.text);
  }
};

bool starts_with(const std::string& s, const char* p) { return s.compare(0, strlen(p), p) == 0; }

}  // namespace

// ---- boot state --------------------------------------------------------------------------------
TEST(ConsoleState, BootsWithHeaterOffAndDefaults) {
  State s;
  EXPECT_FALSE(s.heat);
  EXPECT_EQ(s.active_mode(), Mode::Off);
  EXPECT_EQ(s.mode, Mode::FeedforwardPid);
  EXPECT_DOUBLE_EQ(s.tlim_C, 110.0);
  EXPECT_FALSE(s.tele);
  // Each PID mode starts with its own tuned defaults, and they are valid gains.
  const sma::PidGains dp = sma::console::default_gains(Mode::Pid);
  const sma::PidGains df = sma::console::default_gains(Mode::FeedforwardPid);
  EXPECT_EQ(dp.check(), nullptr);
  EXPECT_EQ(df.check(), nullptr);
  EXPECT_DOUBLE_EQ(s.gains_pid.kp, dp.kp);
  EXPECT_DOUBLE_EQ(s.gains_pid.ki, dp.ki);
  EXPECT_DOUBLE_EQ(s.gains_pid.kd, dp.kd);
  EXPECT_DOUBLE_EQ(s.gains_ffpid.kp, df.kp);
  EXPECT_DOUBLE_EQ(s.gains_ffpid.ki, df.ki);
  EXPECT_DOUBLE_EQ(s.gains_ffpid.kd, df.kd);
  EXPECT_GT(s.gains_pid.kp, 0.0);  // a PID that does something
  EXPECT_GT(s.gains_ffpid.ki, 0.0);  // integral action: zero steady-state error
  EXPECT_EQ(s.traj.n_points, 0);
  EXPECT_EQ(s.reference().kind, sma::RefKind::Constant);
}

// ---- every command, OK path --------------------------------------------------------------------
TEST(ConsoleCommands, Pos) {
  Console c;
  EXPECT_EQ(c.run("pos 0.4"), "OK pos 0.4000 ffpid");
  EXPECT_TRUE(c.ok);
  EXPECT_TRUE(c.s.heat);
  EXPECT_EQ(c.s.active_mode(), Mode::FeedforwardPid);
  EXPECT_EQ(c.s.run_kind, sma::RefKind::Constant);
  EXPECT_DOUBLE_EQ(c.s.pos_mm, 0.4);
  EXPECT_EQ(c.s.run, 1);
  EXPECT_DOUBLE_EQ(c.s.reference().constant_mm, 0.4);
  // Range ends, blanks and signs.
  EXPECT_EQ(c.run("  pos\t0  "), "OK pos 0.0000 ffpid");
  EXPECT_EQ(c.run("pos 0.958"), "OK pos 0.9580 ffpid");
  EXPECT_EQ(c.run("pos +.5"), "OK pos 0.5000 ffpid");
  EXPECT_EQ(c.run("pos -0"), "OK pos 0.0000 ffpid");
  EXPECT_EQ(c.run("pos 00.25"), "OK pos 0.2500 ffpid");
  EXPECT_EQ(c.run("pos 0.12345678901234"), "OK pos 0.1235 ffpid");
  EXPECT_EQ(c.s.run, 7);
}

TEST(ConsoleCommands, StepAndSine) {
  Console c;
  EXPECT_EQ(c.run("step"), "OK step ffpid");
  EXPECT_EQ(c.s.run_kind, sma::RefKind::MultiStep);
  EXPECT_TRUE(c.s.heat);
  EXPECT_DOUBLE_EQ(c.s.reference().duration(), 150.0);
  EXPECT_EQ(c.run("sine"), "OK sine ffpid");
  EXPECT_EQ(c.s.run_kind, sma::RefKind::Sine);
  EXPECT_EQ(c.s.run, 2);
}

TEST(ConsoleCommands, Trajectory) {
  Console c;
  EXPECT_EQ(c.run("traj 0 0.1"), "OK traj point 1");
  EXPECT_EQ(c.run("traj 2.5 0.5"), "OK traj point 2");
  EXPECT_EQ(c.run("traj 10 0.3"), "OK traj point 3");
  EXPECT_FALSE(c.s.heat);  // editing does not heat
  EXPECT_EQ(c.run("traj run"), "OK traj run 10.00 s ffpid");
  EXPECT_TRUE(c.s.heat);
  const sma::Reference r = c.s.reference();
  EXPECT_EQ(r.kind, sma::RefKind::Trajectory);
  EXPECT_EQ(r.n_points, 3);
  sma::ReferenceGen<double> gen(r);
  EXPECT_NEAR(gen.at(1.25), 0.3, 1e-12);
  EXPECT_NEAR(gen.at(20.0), 0.3, 1e-12);
  EXPECT_EQ(c.run("traj clear"), "OK traj clear");
  EXPECT_EQ(c.s.traj.n_points, 0);
  EXPECT_EQ(c.s.traj.kind, sma::RefKind::Trajectory);
  // Full at 16 points.
  for (int k = 0; k < 16; ++k) {
    const std::string line = "traj " + std::to_string(k) + " 0.2";
    EXPECT_TRUE(starts_with(c.run(line.c_str()), "OK traj point"));
  }
  const State before = c.s;
  EXPECT_EQ(c.run("traj 100 0.2"), "ERR traj: full (16 points)");
  EXPECT_TRUE(same_state(before, c.s));
}

TEST(ConsoleCommands, Mode) {
  Console c;
  EXPECT_EQ(c.run("mode pid"), "OK mode pid (heater off)");
  EXPECT_EQ(c.s.mode, Mode::Pid);
  EXPECT_EQ(c.s.active_mode(), Mode::Off);
  EXPECT_EQ(c.run("mode ff"), "OK mode ff (heater off)");
  EXPECT_EQ(c.s.mode, Mode::Feedforward);
  EXPECT_EQ(c.run("mode open"), "OK mode open (heater off)");
  EXPECT_EQ(c.s.mode, Mode::OpenLoop);
  EXPECT_EQ(c.run("mode ffpid"), "OK mode ffpid (heater off)");
  c.run("pos 0.3");
  EXPECT_EQ(c.run("mode pid"), "OK mode pid");  // live switch
  EXPECT_EQ(c.s.active_mode(), Mode::Pid);
  // A reference command in open loop goes back to the default closed loop.
  c.run("mode open");
  EXPECT_EQ(c.run("pos 0.2"), "OK pos 0.2000 ffpid");
}

// `lead F`: inverse + PID's heating/cooling trade-off (the factor on the tuned cooling lead,
// 0 the paper's controller); a setting, it heats nothing and keeps the mode.
TEST(ConsoleCommands, Lead) {
  Console c;
  EXPECT_DOUBLE_EQ(c.s.lead, 1.0);  // the tuned lead by default
  EXPECT_EQ(c.run("lead 0"), "OK lead 0.00");
  EXPECT_DOUBLE_EQ(c.s.lead, 0.0);
  EXPECT_FALSE(c.s.heat);
  EXPECT_EQ(c.run("lead 1.5"), "OK lead 1.50");
  EXPECT_DOUBLE_EQ(c.s.lead, 1.5);
  EXPECT_EQ(c.s.mode, Mode::FeedforwardPid);
  EXPECT_NE(c.run("help").find("|lead F|"), std::string::npos);
  // (A build without the feature has no such row: SMA_CONSOLE_LEAD 0, the Q16.16 and Mega
  // images, FIL test bad_lines on the Q16.16 ELF.)
}

TEST(ConsoleCommands, Volt) {
  Console c;
  EXPECT_EQ(c.run("volt 1.25"), "OK volt 1.2500 open");
  EXPECT_TRUE(c.s.heat);
  EXPECT_EQ(c.s.mode, Mode::OpenLoop);
  EXPECT_DOUBLE_EQ(c.s.volt, 1.25);
  EXPECT_EQ(c.run("volt 2"), "OK volt 2.0000 open");
  EXPECT_EQ(c.run("volt 0"), "OK volt 0.0000 open");
}

TEST(ConsoleCommands, GainsGoToTheSelectedPidMode) {
  Console c;
  EXPECT_EQ(c.run("gains 10 2 0.1"), "OK gains ffpid 10.0000 2.0000 0.1000");
  EXPECT_DOUBLE_EQ(c.s.gains_ffpid.kp, 10.0);
  EXPECT_DOUBLE_EQ(c.s.gains_ffpid.ki, 2.0);
  EXPECT_DOUBLE_EQ(c.s.gains_ffpid.kd, 0.1);
  EXPECT_DOUBLE_EQ(c.s.gains_ffpid.d_filter_s, 0.05);  // untouched
  EXPECT_DOUBLE_EQ(c.s.gains_pid.kp, sma::console::default_gains(Mode::Pid).kp);  // the other mode: untouched
  c.run("mode pid");
  EXPECT_EQ(c.run("gains 20 0 0"), "OK gains pid 20.0000 0.0000 0.0000");
  EXPECT_DOUBLE_EQ(c.s.gains().kp, 20.0);
  EXPECT_DOUBLE_EQ(c.s.gains_ffpid.kp, 10.0);
  EXPECT_EQ(c.s.gains().check(), nullptr);
}

TEST(ConsoleCommands, TlimTeleStatusStopHelpEmpty) {
  Console c;
  EXPECT_EQ(c.run("tlim 95.5"), "OK tlim 95.5");
  EXPECT_DOUBLE_EQ(c.s.tlim_C, 95.5);
  EXPECT_EQ(c.run("tele on"), "OK tele on");
  EXPECT_TRUE(c.s.tele);
  EXPECT_EQ(c.run("tele off"), "OK tele off");
  EXPECT_FALSE(c.s.tele);
  EXPECT_EQ(c.run("status"), "OK status");  // the firmware appends live values
  c.run("sine");
  EXPECT_EQ(c.run("stop"), "OK stop");
  EXPECT_FALSE(c.s.heat);
  EXPECT_EQ(c.s.active_mode(), Mode::Off);
  const std::string h = c.run("help");
  EXPECT_TRUE(starts_with(h, "OK pos mm|step|sine|traj"));
  EXPECT_NE(h.find("status|stop"), std::string::npos);
  EXPECT_EQ(h.substr(h.size() - 6), "|pinfo");  // not truncated: the table's last row
  EXPECT_LE(h.size(), static_cast<size_t>(con::kReplyMax - 1));
  EXPECT_EQ(c.run(""), "");
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.run("   \t "), "");
  EXPECT_TRUE(c.ok);
}

TEST(ConsoleCommands, ParsedCommandIsReported) {
  State s;
  Reply r;
  con::Command cmd;
  ASSERT_TRUE(con::execute("gains 1 2 3", s, Fault::None, r, con::Limits(), &cmd));
  EXPECT_EQ(cmd.op, con::Op::Gains);
  EXPECT_DOUBLE_EQ(cmd.a, 1.0);
  EXPECT_DOUBLE_EQ(cmd.b, 2.0);
  EXPECT_DOUBLE_EQ(cmd.c, 3.0);
  EXPECT_FALSE(cmd.heats());
  ASSERT_TRUE(con::execute("volt 1", s, Fault::None, r, con::Limits(), &cmd));
  EXPECT_TRUE(cmd.heats());
}

// ---- every class of error: ERR naming the problem, nothing changed -----------------------------
struct BadLine {
  const char* line;
  const char* reply;
};

class ConsoleErrors : public ::testing::TestWithParam<BadLine> {};

TEST_P(ConsoleErrors, ErrAndNothingChanges) {
  Console c;
  c.run("traj 0 0.2");
  c.run("pos 0.3");
  c.run("tele on");
  const State before = c.s;
  const std::string reply = c.run(GetParam().line);
  EXPECT_FALSE(c.ok) << GetParam().line;
  EXPECT_EQ(reply, GetParam().reply) << GetParam().line;
  EXPECT_TRUE(same_state(before, c.s)) << GetParam().line;
}

INSTANTIATE_TEST_SUITE_P(
    AllClasses, ConsoleErrors,
    ::testing::Values(
        // unknown command (echoed, printable, at most 12 chars)
        BadLine{"frobnicate", "ERR unknown command 'frobnicate' (try help)"},
        BadLine{"POS 0.4", "ERR unknown command 'POS' (try help)"},
        BadLine{"averyveryverylongword", "ERR unknown command 'averyveryver' (try help)"},
        BadLine{"p\x01s", "ERR unknown command 'p?s' (try help)"},
        // missing number
        BadLine{"pos", "ERR pos: missing number <mm>"},
        BadLine{"volt  ", "ERR volt: missing number <V>"},
        BadLine{"gains 1 2", "ERR gains: missing number <kd>"},
        BadLine{"gains", "ERR gains: missing number <kp>"},
        BadLine{"tlim", "ERR tlim: missing number <degC>"},
        BadLine{"traj 1", "ERR traj: missing number <mm>"},
        BadLine{"lead", "ERR lead: missing number <F>"},
        // malformed numbers
        BadLine{"pos abc", "ERR pos: mm is not a number: 'abc'"},
        BadLine{"pos 0.4x", "ERR pos: mm is not a number: '0.4x'"},
        BadLine{"pos 1.2.3", "ERR pos: mm is not a number: '1.2.3'"},
        BadLine{"pos -", "ERR pos: mm is not a number: '-'"},
        BadLine{"pos .", "ERR pos: mm is not a number: '.'"},
        BadLine{"pos +-1", "ERR pos: mm is not a number: '+-1'"},
        BadLine{"pos 1e-1", "ERR pos: mm is not a number: '1e-1'"},
        BadLine{"pos 0x1", "ERR pos: mm is not a number: '0x1'"},
        BadLine{"pos nan", "ERR pos: mm is not a number: 'nan'"},
        BadLine{"pos NaN", "ERR pos: mm is not a number: 'NaN'"},
        BadLine{"pos inf", "ERR pos: mm is not a number: 'inf'"},
        BadLine{"volt -inf", "ERR volt: V is not a number: '-inf'"},
        BadLine{"gains 1 x 3", "ERR gains: ki is not a number: 'x'"},
        BadLine{"lead nan", "ERR lead: F is not a number: 'nan'"},
        BadLine{"pos 0,5", "ERR pos: mm is not a number: '0,5'"},
        // out of range
        BadLine{"pos 0.959", "ERR pos: mm out of range 0.000..0.958"},
        BadLine{"pos -0.001", "ERR pos: mm out of range 0.000..0.958"},
        BadLine{"pos 12345678901", "ERR pos: mm out of range 0.000..0.958"},
        BadLine{"volt 2.01", "ERR volt: V out of range 0.000..2.000"},
        BadLine{"gains -1 0 0", "ERR gains: kp out of range 0.000..999.000"},
        BadLine{"gains 1 2 1000", "ERR gains: kd out of range 0.000..999.000"},
        BadLine{"tlim 29.9", "ERR tlim: degC out of range 30.000..150.000"},
        BadLine{"tlim 151", "ERR tlim: degC out of range 30.000..150.000"},
        BadLine{"traj -1 0.2", "ERR traj: t_s out of range 0.000..3600.000"},
        BadLine{"traj 1 1", "ERR traj: mm out of range 0.000..0.958"},
        BadLine{"lead 2.01", "ERR lead: F out of range 0.000..2.000"},
        BadLine{"lead -0.5", "ERR lead: F out of range 0.000..2.000"},
        BadLine{"lead 1 2", "ERR lead: unexpected extra text"},
        // extra text
        BadLine{"pos 0.4 0.5", "ERR pos: unexpected extra text"},
        BadLine{"step now", "ERR step: unexpected extra text"},
        BadLine{"sine 2", "ERR sine: unexpected extra text"},
        BadLine{"stop please", "ERR stop: unexpected extra text"},
        BadLine{"help me", "ERR help: unexpected extra text"},
        BadLine{"status x", "ERR status: unexpected extra text"},
        BadLine{"gains 1 2 3 4", "ERR gains: unexpected extra text"},
        BadLine{"traj clear now", "ERR traj: unexpected extra text"},
        BadLine{"tele on off", "ERR tele: unexpected extra text"},
        BadLine{"mode pid ff", "ERR mode: unexpected extra text"},
        // keywords
        BadLine{"mode warp", "ERR mode: expected open, pid, ff or ffpid"},
        BadLine{"mode", "ERR mode: expected open, pid, ff or ffpid"},
        BadLine{"mode PID", "ERR mode: expected open, pid, ff or ffpid"},
        BadLine{"tele maybe", "ERR tele: expected on, off or plot"},
        BadLine{"tele", "ERR tele: expected on, off or plot"},
        BadLine{"traj", "ERR traj: expected clear, run or <t_s> <mm>"},
        // trajectory rules
        BadLine{"traj 0 0.3", "ERR traj: t_s must increase"}));

TEST(ConsoleErrorsMore, OverlongLineGivenDirectly) {
  Console c;
  const State before = c.s;
  const std::string longpos = "pos 0." + std::string(300, '1');
  EXPECT_EQ(c.run(longpos.c_str()), "ERR line too long (max 47 chars)");
  EXPECT_TRUE(same_state(before, c.s));
  const std::string justfits = "pos 0." + std::string(con::kLineMax - 6, '1');
  EXPECT_EQ(c.run(justfits.c_str()), "OK pos 0.1111 ffpid");
}

TEST(ConsoleErrorsMore, TrajRunWithoutPoints) {
  Console c;
  const State before = c.s;
  EXPECT_EQ(c.run("traj run"), "ERR traj: no points");
  EXPECT_TRUE(same_state(before, c.s));
}

TEST(ConsoleErrorsMore, HeatingRefusedWhileFaulted) {
  for (const char* line : {"pos 0.3", "step", "sine", "volt 1", "traj run"}) {
    Console c;
    c.run("traj 0 0.1");
    c.fault = Fault::OverTemp;
    const State before = c.s;
    EXPECT_EQ(c.run(line), "ERR fault overtemp: send stop") << line;
    EXPECT_TRUE(same_state(before, c.s)) << line;
  }
  // Everything that does not heat still works, stop included.
  Console c;
  c.fault = Fault::Sensor;
  EXPECT_EQ(c.run("tele on"), "OK tele on");
  EXPECT_EQ(c.run("mode pid"), "OK mode pid (heater off)");
  EXPECT_EQ(c.run("gains 1 1 1"), "OK gains pid 1.0000 1.0000 1.0000");
  EXPECT_EQ(c.run("tlim 100"), "OK tlim 100.0");
  EXPECT_EQ(c.run("traj 1 0.2"), "OK traj point 1");
  EXPECT_EQ(c.run("stop"), "OK stop");
  EXPECT_EQ(c.run("status"), "OK status");
}

// ---- numbers -----------------------------------------------------------------------------------
TEST(ConsoleNumbers, ParseNumber) {
  using con::detail::Num;
  using con::detail::parse_number;
  auto ok = [](const char* s) {
    double v = -99;
    const Num r = parse_number(s, static_cast<uint8_t>(strlen(s)), v);
    EXPECT_EQ(r, Num::Ok) << s;
    return v;
  };
  EXPECT_DOUBLE_EQ(ok("0"), 0.0);
  EXPECT_DOUBLE_EQ(ok("12"), 12.0);
  EXPECT_DOUBLE_EQ(ok("-12.5"), -12.5);
  EXPECT_DOUBLE_EQ(ok("+.25"), 0.25);
  EXPECT_DOUBLE_EQ(ok("5."), 5.0);
  EXPECT_DOUBLE_EQ(ok("000123.4500"), 123.45);
  EXPECT_DOUBLE_EQ(ok("999999999"), 999999999.0);
  EXPECT_NEAR(ok("0.000000001"), 1e-9, 1e-20);
  EXPECT_NEAR(ok("3.14159265358979"), 3.14159265, 1e-12);  // 9 significant digits kept
  double v = 7;
  for (const char* bad : {"", "+", "-", ".", "-.", "1..2", "1e3", "e3", "1-", "--1", " 1", "1 ", "inf", "nan"}) {
    EXPECT_EQ(parse_number(bad, static_cast<uint8_t>(strlen(bad)), v), Num::Bad) << bad;
  }
  EXPECT_EQ(parse_number("1234567890", 10, v), Num::TooLong);
  EXPECT_DOUBLE_EQ(v, 7.0);  // untouched on error
}

TEST(ConsoleNumbers, PutFixed) {
  auto fmt = [](double x, uint8_t d) {
    Reply r;
    r.put_fixed(x, d);
    return std::string(r.text);
  };
  EXPECT_EQ(fmt(0.0, 4), "0.0000");
  EXPECT_EQ(fmt(1.23456, 4), "1.2346");
  EXPECT_EQ(fmt(-0.5, 2), "-0.50");
  EXPECT_EQ(fmt(-0.00001, 4), "0.0000");  // no "-0.0000"
  EXPECT_EQ(fmt(0.99999, 4), "1.0000");
  EXPECT_EQ(fmt(110.0, 0), "110");
  EXPECT_EQ(fmt(3.0, 1), "3.0");
  EXPECT_EQ(fmt(0.16, 5), "0.16000");
  EXPECT_EQ(fmt(1e12, 2), "big");
  EXPECT_EQ(fmt(NAN, 2), "nan");
  EXPECT_EQ(fmt(INFINITY, 2), "inf");
  EXPECT_EQ(fmt(-INFINITY, 2), "inf");
  EXPECT_EQ(fmt(2.5, 9), "2.500000");  // at most 6 decimals
}

TEST(ConsoleNumbers, ReplyIsBoundedAndSanitised) {
  Reply r;
  for (int k = 0; k < 500; ++k) r.put('x');
  EXPECT_EQ(r.len, con::kReplyMax - 1);
  EXPECT_EQ(strlen(r.text), static_cast<size_t>(con::kReplyMax - 1));
  r.clear();
  r.put_s("a\x01\x7f" "b");
  EXPECT_STREQ(r.text, "a??b");
  r.clear();
  r.put_u(0);
  r.put(' ');
  r.put_u(4294967295u);
  EXPECT_STREQ(r.text, "0 4294967295");
}

// ---- telemetry ---------------------------------------------------------------------------------
TEST(ConsoleTelemetry, HeaderAndRowsAreARigLog) {
  EXPECT_STREQ(con::telemetry_header(), "t_s,v_V,d_mm,ref_mm,duty");
  Reply r;
  con::telemetry_row(r, 12345, 100, 1.23456, 0.4, 0.41, 0.0609);
  EXPECT_STREQ(r.text, "123.45,1.2346,0.4000,0.4100,0.06090");
  con::telemetry_row(r, 7, 100, 0.0, -0.0123, 0.0, 0.0);
  EXPECT_STREQ(r.text, "0.07,0.0000,-0.0123,0.0000,0.00000");
  con::telemetry_row(r, 1234, 1000, 2.0, 0.958, 0.958, 0.16);
  EXPECT_STREQ(r.text, "1.234,2.0000,0.9580,0.9580,0.16000");
  // Five fields, times increasing.
  double prev = -1;
  for (uint32_t k = 0; k < 300; ++k) {
    con::telemetry_row(r, k, 100, 1.0, 0.5, 0.5, 0.04);
    const std::string s(r.text);
    EXPECT_EQ(std::count(s.begin(), s.end(), ','), 4);
    const double t = atof(r.text);
    EXPECT_GT(t, prev);
    prev = t;
  }
}

TEST(ConsoleTelemetry, StatusLine) {
  State s;
  s.heat = true;
  s.run_kind = sma::RefKind::Sine;
  con::Live l;
  l.t_ref_s = 12.345;
  l.d_mm = 0.41234;
  l.ref_mm = 0.4;
  l.v = 1.2;
  l.temp_C = 65.44;
  l.fault = Fault::None;
  Reply r;
  con::status_line(r, s, l);
  EXPECT_STREQ(r.text,
               "OK status ffpid sine t=12.35 d=0.4123 r=0.4000 V=1.200 T=65.4 tlim=110 fault=none drop=0 ovr=0");
  s.heat = false;
  l.fault = Fault::OverTemp;
  l.dropped = 3;
  con::status_line(r, s, l);
  EXPECT_NE(std::string(r.text).find("OK status off sine"), std::string::npos);
  EXPECT_NE(std::string(r.text).find("fault=overtemp drop=3 ovr=0"), std::string::npos);
  // The longest status fits.
  l.t_ref_s = 99999.99;
  l.d_mm = -10.0;
  l.ref_mm = 0.958;
  l.temp_C = 149.9;
  l.dropped = 65535;
  l.overruns = 65535;
  s.tlim_C = 150;
  s.heat = true;
  s.run_kind = sma::RefKind::Trajectory;
  con::status_line(r, s, l);
  EXPECT_NE(std::string(r.text).find("ovr=65535"), std::string::npos) << r.text;
}

// ---- line assembly -----------------------------------------------------------------------------
namespace {
std::string feed(con::LineBuffer& lb, const std::string& bytes, std::string* lines_out) {
  std::string statuses;
  for (char ch : bytes) {
    const auto st = lb.push(ch);
    switch (st) {
      case con::LineBuffer::Status::Pending: break;
      case con::LineBuffer::Status::Line:
        statuses += 'L';
        *lines_out += std::string(lb.line()) + "|";
        break;
      case con::LineBuffer::Status::TooLong: statuses += 'T'; break;
      case con::LineBuffer::Status::Binary: statuses += 'B'; break;
    }
  }
  return statuses;
}
}  // namespace

TEST(ConsoleLines, EndingsAndEmptyLines) {
  con::LineBuffer lb;
  std::string lines;
  EXPECT_EQ(feed(lb, "pos 0.4\nstep\r\nsine\rstop\n\n", &lines), "LLLLL");
  EXPECT_EQ(lines, "pos 0.4|step|sine|stop||");
  lines.clear();
  EXPECT_EQ(feed(lb, "\r\n\r\n", &lines), "LL");  // two empty lines, each CRLF counted once
}

TEST(ConsoleLines, TooLongThenRecovers) {
  con::LineBuffer lb;
  std::string lines;
  std::string longline(con::kLineMax, 'a');
  EXPECT_EQ(feed(lb, longline + "\n", &lines), "L");  // exactly the maximum is fine
  EXPECT_EQ(lines, longline + "|");
  lines.clear();
  EXPECT_EQ(feed(lb, longline + "b\n", &lines), "T");
  EXPECT_EQ(feed(lb, std::string(1000, 'z') + "\n", &lines), "T");
  EXPECT_EQ(feed(lb, "status\n", &lines), "L");
  EXPECT_EQ(lines, "status|");
  Reply r;
  con::line_error(con::LineBuffer::Status::TooLong, r);
  EXPECT_STREQ(r.text, "ERR line too long (max 47 chars)");
}

TEST(ConsoleLines, BinaryBytes) {
  con::LineBuffer lb;
  std::string lines;
  EXPECT_EQ(feed(lb, std::string("pos \xff" "0.3\n", 9), &lines), "B");
  EXPECT_EQ(feed(lb, std::string("po\0s 1\n", 7), &lines), "B");
  EXPECT_EQ(feed(lb, "stop\n", &lines), "L");
  Reply r;
  con::line_error(con::LineBuffer::Status::Binary, r);
  EXPECT_STREQ(r.text, "ERR line has a NUL or non-ASCII byte");
}

// ---- fuzz: 100k random and mutated lines --------------------------------------------------------
namespace {
struct Rng {
  uint64_t s = 0x9E3779B97F4A7C15ull;
  uint32_t next() {
    s ^= s << 13;
    s ^= s >> 7;
    s ^= s << 17;
    return static_cast<uint32_t>(s >> 11);
  }
  uint32_t below(uint32_t n) { return next() % n; }
};
}  // namespace

TEST(ConsoleFuzz, HundredThousandLinesNeverBreakTheState) {
  static const char* const kSeeds[] = {
      "pos 0.4", "step", "sine", "traj clear", "traj 1.5 0.3", "traj run", "mode open", "mode pid",
      "mode ff", "mode ffpid", "volt 1.2", "gains 12.8 4 0.09", "tlim 100", "tele on", "tele off",
      "status", "stop", "help", "pos 0.958", "traj 3600 0.958", "volt 2", "gains 0 0 0", "lead 0.5"};
  static const char kAlphabet[] = "0123456789.+- \tabcdefghijklmnopqrstuvwxyz\x01\x7f\xff";
  Rng rng;
  State s;
  Reply r;
  con::LineBuffer lb;
  long n_ok = 0, n_err = 0, n_line_err = 0;
  for (int iter = 0; iter < 100000; ++iter) {
    std::string line;
    const uint32_t kind = rng.below(4);
    if (kind == 0) {  // fully random bytes
      const uint32_t n = rng.below(70);
      for (uint32_t k = 0; k < n; ++k) line.push_back(static_cast<char>(rng.below(256)));
    } else {  // a valid line, mutated
      line = kSeeds[rng.below(sizeof kSeeds / sizeof kSeeds[0])];
      const uint32_t muts = kind == 1 ? 0 : rng.below(4);
      for (uint32_t m = 0; m < muts; ++m) {
        const uint32_t op = rng.below(4);
        const size_t pos = line.empty() ? 0 : rng.below(static_cast<uint32_t>(line.size()));
        const char ch = kAlphabet[rng.below(sizeof kAlphabet - 1)];
        if (op == 0 && !line.empty()) line[pos] = ch;
        else if (op == 1) line.insert(pos, 1, ch);
        else if (op == 2 && !line.empty()) line.erase(pos, 1);
        else line.append(rng.below(60), ch);
      }
    }
    const Fault fault = rng.below(10) == 0 ? Fault::Sensor : Fault::None;
    line.push_back('\n');
    for (char ch : line) {
      const auto st = lb.push(ch);
      if (st == con::LineBuffer::Status::Pending) continue;
      const State before = s;
      if (st == con::LineBuffer::Status::Line) {
        ASSERT_LE(strlen(lb.line()), static_cast<size_t>(con::kLineMax));
        const bool ok = con::execute(lb.line(), s, fault, r);
        const std::string rep(r.text);
        ASSERT_LT(rep.size(), static_cast<size_t>(con::kReplyMax));
        if (ok) {
          ++n_ok;
          ASSERT_TRUE(rep.empty() || starts_with(rep, "OK ")) << lb.line() << " -> " << rep;
        } else {
          ++n_err;
          ASSERT_TRUE(starts_with(rep, "ERR ")) << lb.line() << " -> " << rep;
          ASSERT_TRUE(same_state(before, s)) << lb.line();
        }
        for (char c : rep) ASSERT_TRUE(c >= 32 && c < 127) << rep;
      } else {
        ++n_line_err;
        con::line_error(st, r);
        ASSERT_TRUE(starts_with(r.text, "ERR "));
      }
      // Invariants of the state whatever happened.
      ASSERT_TRUE(s.pos_mm >= 0.0 && s.pos_mm <= 0.958);
      ASSERT_TRUE(s.volt >= 0.0 && s.volt <= 2.0);
      ASSERT_TRUE(s.tlim_C >= 30.0 && s.tlim_C <= 150.0);
      ASSERT_EQ(s.gains_pid.check(), nullptr);
      ASSERT_EQ(s.gains_ffpid.check(), nullptr);
      ASSERT_LE(s.traj.n_points, sma::kMaxPoints);
      ASSERT_NE(s.mode, Mode::Off);
      if (fault != Fault::None && !before.heat) {
        ASSERT_FALSE(s.heat);
      }
    }
  }
  // The mix exercised both paths substantially.
  EXPECT_GT(n_ok, 10000);
  EXPECT_GT(n_err, 10000);
  EXPECT_GT(n_line_err, 1000);
}

// ---- model commands (pbegin pset pget pcommit pabort pinfo) and train --------------------------
namespace {

struct ModelMem {
  uint8_t b[1024];
  ModelMem() { memset(b, 0xFF, sizeof b); }
};
struct ModelEeprom {
  ModelMem* m = nullptr;
  uint8_t read(uint16_t a) const { return m->b[a]; }
  void write(uint16_t a, uint8_t v) { m->b[a] = v; }
};

// The console as the firmware runs it: execute(), then model_command() for the model ops.
struct Board {
  ModelMem mem;
  sma::storage::Store<ModelEeprom> store;
  State s;
  Reply r;
  bool rebuilt = false;
  bool ok = false;
  Board() {
    ModelEeprom e;
    e.m = &mem;
    store = sma::storage::Store<ModelEeprom>(e);
    sma::Params p;
    sma::Effects fx;
    store.load(p, fx);
  }
  std::string run(const char* line) {
    con::Command c;
    ok = con::execute(line, s, Fault::None, r, con::Limits(), &c);
    rebuilt = false;
    if (ok && con::is_model_op(c.op)) {
      sma::Params p;  // the defaults, as the firmware provides them
      sma::Effects fx;
      rebuilt = con::model_command(c, store, p, fx, r);
      ok = r.text[0] == 'O';
    }
    return std::string(r.text);
  }
};

}  // namespace

TEST(ConsoleModel, PinfoAndPgetOnABlankEepromShowTheDefaults) {
  Board b;
  EXPECT_EQ(b.run("pinfo"), "OK pinfo v1 defaults");
  EXPECT_EQ(b.run("pget T_AS"), "OK pget T_AS 50.2 0x4248cccd");
  EXPECT_EQ(b.run("pget d0"), "OK pget d0 0.0005 0x3a03126f");
  EXPECT_EQ(b.run("pget loops"), "OK pget loops 3 0x03");
  EXPECT_EQ(b.run("pget m1"), "OK pget m1 -4.8334 0xc09aab36");
  EXPECT_EQ(b.run("pget sensor_calibration.gain"), "OK pget sensor_calibration.gain 1 0x3f800000");
}

TEST(ConsoleModel, UploadCommitsAndPgetReadsTheNewSet) {
  Board b;
  EXPECT_EQ(b.run("pset T_AS 55"), "ERR pset: no staged set, send pbegin");
  EXPECT_EQ(b.run("pbegin"), "OK pbegin slot 0");
  EXPECT_EQ(b.run("pset T_AS 55.2"), "OK pset T_AS 0x425ccccd");
  EXPECT_EQ(b.run("pset T_AF 84.1"), "OK pset T_AF 0x42a83333");
  EXPECT_EQ(b.run("pset loop1.j 0.25"), "OK pset loop1.j 0x3e800000");
  EXPECT_EQ(b.run("pset loops 2"), "OK pset loops 0x02");
  EXPECT_EQ(b.run("pset sensor_delay.delay_s 0.05"), "OK pset sensor_delay.delay_s 0x3d4ccccd");
  EXPECT_EQ(b.run("pget T_AS"), "OK pget T_AS 50.2 0x4248cccd");  // still the active set
  EXPECT_EQ(b.run("pinfo"), "OK pinfo v1 defaults staging 0");
  const std::string r = b.run("pcommit");
  EXPECT_TRUE(starts_with(r, "OK pcommit v1 slot 0 seq 1 crc 0x")) << r;
  EXPECT_TRUE(b.rebuilt);
  EXPECT_EQ(b.run("pget T_AS"), "OK pget T_AS 55.2 0x425ccccd");
  EXPECT_EQ(b.run("pget loops"), "OK pget loops 2 0x02");
  EXPECT_EQ(b.run("pget loop1.j"), "OK pget loop1.j 0.25 0x3e800000");
  EXPECT_EQ(b.run("pget T_MS"), "OK pget T_MS 28 0x41e00000");  // copied from the defaults
  EXPECT_TRUE(starts_with(b.run("pinfo"), "OK pinfo v1 slot 0 seq 1 crc 0x"));
  // The next set starts as a copy of this one, in the other slot.
  EXPECT_EQ(b.run("pbegin"), "OK pbegin slot 1");
  EXPECT_EQ(b.run("pset g 1.1496"), "OK pset g 0x3f932618");
  EXPECT_TRUE(starts_with(b.run("pcommit"), "OK pcommit v1 slot 1 seq 2"));
  EXPECT_EQ(b.run("pget T_AS"), "OK pget T_AS 55.2 0x425ccccd");
}

TEST(ConsoleModel, CommitOfANonPhysicalSetNamesTheKeyAndKeepsTheActiveSet) {
  Board b;
  b.run("pbegin");
  EXPECT_EQ(b.run("pset T_AF 40"), "OK pset T_AF 0x42200000");
  EXPECT_EQ(b.run("pcommit"), "ERR T_AF: must be > T_AS");
  EXPECT_FALSE(b.rebuilt);
  EXPECT_EQ(b.run("pinfo"), "OK pinfo v1 defaults staging 0");
  b.run("pset T_AF 80.1");
  // pset takes a value only inside its key's range, the one check() holds it to (one table):
  // what pcommit can still refuse is how keys stand to each other.
  EXPECT_EQ(b.run("pset gain 5.01"), "ERR sensor_calibration.gain: value out of range 0.2..5");
  EXPECT_EQ(b.run("pset T_MS 20"), "OK pset T_MS 0x41a00000");
  EXPECT_EQ(b.run("pcommit"), "ERR T_MS: must be > T_MF");
  b.run("pset T_MS 28");
  b.run("pset loop0.T_i 70");
  EXPECT_EQ(b.run("pcommit"), "ERR loops: T_i must increase strictly inside (T_s, T_f)");
  EXPECT_EQ(b.run("pabort"), "OK pabort");
  EXPECT_EQ(b.run("pinfo"), "OK pinfo v1 defaults");
  EXPECT_EQ(b.run("pcommit"), "ERR pcommit: no staged set, send pbegin");
  EXPECT_EQ(b.run("pget loop0.T_i"), "OK pget loop0.T_i 63.1 0x427c6666");
}

TEST(ConsoleModel, BadModelLinesGetOneErrAndChangeNothing) {
  Board b;
  b.run("pbegin");
  const std::vector<std::pair<const char*, const char*>> bad = {
      {"pset", "ERR pset: missing <key>"},
      {"pset rhoo 1", "ERR pset: unknown key 'rhoo'"},
      {"pget m6", "ERR pget: unknown key 'm6'"},
      {"pset rho", "ERR rho: missing number <value>"},
      {"pset rho abc", "ERR rho: value is not a number: 'abc'"},
      {"pset rho 1e3", "ERR rho: value is not a number: '1e3'"},
      {"pset rho 1", "ERR rho: value out of range 100..100000"},
      {"pset d0 0.5", "ERR d0: value out of range 0.000001..0.01"},
      {"pset loop2.j 1.5", "ERR loop2.j: value out of range 0..1"},
      {"pset loops 9", "ERR loops: value out of range 0..8"},
      {"pset loops 2.5", "ERR loops: value must be an integer 0..8"},
      {"pset sensor_delay.delay_s -1", "ERR sensor_delay.delay_s: value out of range 0..5"},
      {"pset sensor_delay.tau_s 1", "ERR pset: unknown key 'sensor_delay.tau_s'"},
      {"pset rho 6500 7", "ERR pset: unexpected extra text"},
      {"pget rho x", "ERR pget: unexpected extra text"},
      {"pinfo x", "ERR pinfo: unexpected extra text"},
      {"train 5", "ERR train: slope out of range 0.000..1.000"},
      {"train x", "ERR train: slope is not a number: 'x'"},
  };
  for (const auto& l : bad) {
    const State before = b.s;
    EXPECT_EQ(b.run(l.first), l.second) << l.first;
    EXPECT_FALSE(b.ok);
    EXPECT_TRUE(same_state(b.s, before)) << l.first;
  }
  EXPECT_EQ(b.run("pget rho"), "OK pget rho 6500 0x45cb2000");
  EXPECT_TRUE(starts_with(b.run("pcommit"), "OK pcommit"));  // nothing bad was staged
  EXPECT_EQ(b.run("pget rho"), "OK pget rho 6500 0x45cb2000");
}

TEST(ConsoleModel, WritingNeedsTheHeaterOff) {
  Board b;
  b.run("pos 0.3");
  ASSERT_TRUE(b.s.heat);
  EXPECT_EQ(b.run("pbegin"), "ERR pbegin: heater on, send stop");
  EXPECT_EQ(b.run("pset rho 6000"), "ERR pset: heater on, send stop");
  EXPECT_EQ(b.run("pcommit"), "ERR pcommit: heater on, send stop");
  EXPECT_EQ(b.run("pinfo"), "OK pinfo v1 defaults");  // reading is fine
  EXPECT_TRUE(starts_with(b.run("pget rho"), "OK pget rho"));
  b.run("stop");
  EXPECT_EQ(b.run("pbegin"), "OK pbegin slot 0");
}

TEST(ConsoleModel, EveryModelLineFitsTheLineLimit) {
  for (uint8_t k = 0; k < sma::storage::kNumKeys; ++k) {
    std::string name;
    struct N {
      std::string* s;
      void put(char ch) { s->push_back(ch); }
    } n{&name};
    sma::storage::put_key_name(n, k);
    // effects: the parameter alone when the long key does not leave room for 12 characters
    const std::string key = name.size() > 28 ? name.substr(name.find('.') + 1) : name;
    const std::string line = "pset " + key + " -1234.5678901";
    EXPECT_LE(line.size(), con::kLineMax) << line;
    Board b;
    b.run("pbegin");
    EXPECT_EQ(b.run(("pset " + key + " 99999999").c_str()).compare(0, 4 + name.size(), "ERR " + name), 0) << key;
  }
}

TEST(ConsoleTrain, StartsOpenLoopAndEndsOnOtherCommands) {
  Console c;
  EXPECT_EQ(c.run("train"), "OK train");
  EXPECT_TRUE(c.s.training);
  EXPECT_TRUE(c.s.heat);
  EXPECT_EQ(c.s.mode, Mode::OpenLoop);
  EXPECT_EQ(c.run("train 0.05"), "OK train");
  con::Command cmd;
  ASSERT_TRUE(con::parse("train 0.05", cmd, c.r));
  EXPECT_DOUBLE_EQ(cmd.a, 0.05);
  ASSERT_TRUE(con::parse("train", cmd, c.r));
  EXPECT_DOUBLE_EQ(cmd.a, 0.0);
  c.run("pos 0.2");
  EXPECT_FALSE(c.s.training);
  c.run("train");
  c.run("stop");
  EXPECT_FALSE(c.s.training);
  EXPECT_FALSE(c.s.heat);
  c.fault = Fault::Sensor;
  EXPECT_EQ(c.run("train"), "ERR fault sensor: send stop");
  EXPECT_FALSE(c.s.training);
}
