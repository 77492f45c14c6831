// libFuzzer target: the serial console (lib/sma_model/include/sma/console.hpp) on arbitrary bytes,
// checked line by line through its pure functions (execute, status_line, line_error,
// model_command), and the same bytes fed to the firmware's own unit, sma::Board (sma/board.hpp,
// what firmware/src/main.cpp runs), ticked twice after every line.
//
// Input: byte 0 = flags (bits 0-2: latched fault at start, mod 6; bit 3: feed the lines to
// execute() directly, bypassing the LineBuffer, so over-long lines reach parse(); bits 4-7:
// the measured displacement), the rest = the serial stream.
//
// Invariants checked after every line (a violation aborts: libFuzzer reports it as a crash):
//   * the reply is 0-terminated, len == strlen, len < kReplyMax, printable ASCII only;
//   * it starts with "OK " (execute() true) or "ERR " (false), or is empty exactly for a blank line;
//   * after an ERR the console State is byte-for-byte unchanged;
//   * a command that heats is refused while a fault is latched; after an OK it heats and restarts;
//   * after an OK the State stays within the documented ranges (pos, volt, gains, tlim, traj);
//   * parse() is deterministic (same line -> same result, same reply);
//   * every number parse_number() accepts equals strtod() of the token to 1e-8 relative;
//   * the controller's output is finite and within 0..V_max (also on NaN measurements), the
//     safety gate's output within 0..V_max, status and telemetry rows fit the reply buffer;
//   * model commands (pbegin/pset/pget/pcommit/pabort/pinfo) run on a 1 KB RAM EEPROM through
//     model_command() as in the firmware: OK/ERR replies, a refused pcommit keeps the active set,
//     an accepted one passes the checks, builds a valid controller and is what a reboot loads;
//   * the Board: every line it writes is printable and starts with OK/ERR/'#' or is a telemetry
//     row; its PWM counts stay within 0..TOP+1 and are 0 while the heater is off or the latch
//     tripped; its latch limit changes only on an OK'd tlim.
// Dictionary: console.dict (the command words and model keys).
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmath>
#include <string>
#include <type_traits>

#include "rig_board.h"
#include "sma/board.hpp"
#include "sma/console.hpp"
#include "sma/controller.hpp"
#include "sma/storage.hpp"

namespace con = sma::console;

namespace {

[[noreturn]] void fail(const char* what, const std::string& line, const con::Reply& r) {
  fprintf(stderr, "fuzz_console: invariant violated: %s\n  line: '", what);
  for (unsigned char c : line) {
    if (c >= 32 && c < 127) fputc(c, stderr);
    else fprintf(stderr, "\\x%02x", c);
  }
  fprintf(stderr, "'\n  reply: '%s'\n", r.text);
  abort();
}

#define CHECK(cond, what) \
  do {                    \
    if (!(cond)) fail(what, line, reply); \
  } while (0)

static_assert(std::is_trivially_copyable<con::State>::value, "State snapshot by memcpy");

bool blank(const std::string& s) {
  for (char c : s)
    if (c != ' ' && c != '\t') return false;
  return true;
}

bool starts(const char* s, const char* p) { return strncmp(s, p, strlen(p)) == 0; }

void check_reply_text(const con::Reply& reply, const std::string& line) {
  CHECK(reply.len < con::kReplyMax, "reply length >= kReplyMax");
  CHECK(reply.text[reply.len] == 0, "reply not 0-terminated at len");
  CHECK(strlen(reply.text) == reply.len, "reply len != strlen");
  for (uint8_t k = 0; k < reply.len; ++k) {
    const unsigned char c = static_cast<unsigned char>(reply.text[k]);
    CHECK(c >= 32 && c < 127, "non-printable byte in reply");
  }
}

bool in(double x, double lo, double hi) { return x >= lo && x <= hi; }

void check_state(const con::State& s, const con::Limits& lim, const std::string& line,
                 const con::Reply& reply) {
  CHECK(s.mode != sma::Mode::Off, "State::mode is Off");
  CHECK(in(s.pos_mm, 0.0, lim.g_mm), "pos_mm out of 0..g");
  CHECK(in(s.volt, 0.0, lim.v_max), "volt out of 0..v_max");
  CHECK(in(s.tlim_C, 30.0, 150.0), "tlim out of 30..150");
  const sma::PidGains* gs[2] = {&s.gains_pid, &s.gains_ffpid};
  for (const sma::PidGains* g : gs) {
    CHECK(in(g->kp, 0.0, 999.0) && in(g->ki, 0.0, 999.0) && in(g->kd, 0.0, 999.0), "gain out of range");
    CHECK(g->check() == nullptr, "gains fail PidGains::check()");
  }
  CHECK(s.traj.n_points <= sma::kMaxPoints, "too many trajectory points");
  for (uint8_t k = 0; k < s.traj.n_points; ++k) {
    CHECK(in(s.traj.point_t[k], 0.0, con::kTrajMaxS), "traj time out of range");
    CHECK(in(s.traj.point_mm[k], 0.0, lim.g_mm), "traj mm out of range");
    if (k) CHECK(s.traj.point_t[k] > s.traj.point_t[k - 1], "traj times not increasing");
  }
}

// Every token that looks like a plain decimal: parse_number() agrees with strtod().
void check_numbers(const std::string& line, const con::Reply& reply) {
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != 0) ++j;
    if (j > i && j - i < 255) {
      const std::string tok = line.substr(i, j - i);
      double v = 0;
      const auto r = con::detail::parse_number(tok.c_str(), static_cast<uint8_t>(tok.size()), v);
      if (r == con::detail::Num::Ok) {
        CHECK(std::isfinite(v), "parse_number gave a non-finite number");
        CHECK(tok.find_first_of("eEnNiIxX") == std::string::npos, "parse_number accepted an exponent/inf/nan/hex");
        char* end = nullptr;
        const double ref = strtod(tok.c_str(), &end);
        CHECK(end == tok.c_str() + tok.size(), "parse_number accepted what strtod does not");
        CHECK(fabs(v - ref) <= 1e-8 * fabs(ref) + 1e-300, "parse_number disagrees with strtod");
      }
    }
    i = j + 1;
  }
}

// The EEPROM of the model commands: 1 KB of RAM (ATmega328P), erased (0xFF).
struct RamEeprom {
  uint8_t mem[1024];
  RamEeprom() { memset(mem, 0xFF, sizeof mem); }
  uint8_t read(uint16_t a) const { return mem[a % sizeof mem]; }
  void write(uint16_t a, uint8_t v) {
    if (a >= sizeof mem) abort();  // a slot past the end of the EEPROM
    mem[a] = v;
  }
};

// The Board's outputs: lines kept for checking, the EEPROM in RAM.
struct FuzzHw {
  RamEeprom* ee;
  std::string* out;
  bool line(const char* s, uint8_t len) {
    out->append(s, len);
    out->push_back('\n');
    return true;
  }
  uint8_t read(uint16_t a) const { return ee->read(a); }
  void write(uint16_t a, uint8_t v) { ee->write(a, v); }
  uint8_t irq_off() { return 0; }
  void irq_restore(uint8_t) {}
};
typedef sma::Board<float, RigBoard, FuzzHw> FuzzBoard;

struct Harness {
  con::State state;
  sma::storage::Store<RamEeprom> store;
  con::Limits lim;
  con::Reply reply;
  sma::Fault fault = sma::Fault::None;
  uint32_t ticks = 0;
  float mm = 0.3f;
  // The firmware's unit on the same bytes.
  RamEeprom board_ee;
  std::string board_out;
  FuzzBoard board;
  double board_tlim = RIG_T_LIMIT_C;

  static sma::ControllerConfig cfg() { return FuzzBoard::controller_config(); }
  Harness() : board(FuzzHw{&board_ee, &board_out}) {
    state.tlim_C = RIG_T_LIMIT_C;
    lim = board.limits();
  }

  // ADC counts of the measured displacement (rig_config.h's calibration inverted); a NaN or huge
  // measurement is a lost sensor.
  uint16_t adc() const {
    const double v = (mm - RIG_SENSOR_OFFSET_MM) / RIG_SENSOR_MM_PER_V;
    if (!(v >= 0.0 && v <= RIG_ADC_VREF)) return 1023;
    return static_cast<uint16_t>(v / RIG_ADC_VREF * (RIG_ADC_COUNTS - 1));
  }

  // What the firmware does with one complete line: the console's functions, checked.
  void line(const std::string& text) {
    const std::string& line = text;
    con::State before;
    memcpy(static_cast<void*>(&before), &state, sizeof state);
    con::Command c;
    const bool ok = con::execute(text.c_str(), state, fault, reply, lim, &c);
    check_reply_text(reply, line);
    if (!ok) {
      CHECK(starts(reply.text, "ERR "), "execute() false but reply does not start with 'ERR '");
      CHECK(memcmp(&before, &state, sizeof state) == 0, "State changed by a line answered ERR");
    } else if (con::is_model_op(c.op)) {
      CHECK(reply.len == 0, "apply() wrote a reply to a model command");
      CHECK(memcmp(&before, &state, sizeof state) == 0, "a model command changed the console State");
      model_command(c, line);
    } else if (reply.len == 0) {
      CHECK(blank(text), "OK without a reply for a non-blank line");
      CHECK(c.op == con::Op::Empty, "empty reply for a command");
    } else {
      CHECK(starts(reply.text, "OK "), "execute() true but reply does not start with 'OK '");
      CHECK(!blank(text), "reply to a blank line");
      CHECK(!(c.heats() && fault != sma::Fault::None), "a heating command accepted while faulted");
      if (c.heats()) {
        const bool open = c.op == con::Op::Volt || c.op == con::Op::Train;
        CHECK(state.heat, "a heating command left the heater off");
        CHECK(static_cast<uint16_t>(before.run + (open ? 0 : 1)) == state.run,
              "a reference (re)start did not bump State::run exactly once");
        CHECK(open == (state.mode == sma::Mode::OpenLoop),
              "volt/train vs open-loop mode mismatch after a heating command");
        CHECK((c.op == con::Op::Train) == state.training, "training flag wrong after a heating command");
      } else if (c.op != con::Op::Stop) {
        CHECK(state.heat == before.heat, "a non-heating command changed heat");
      }
      if (c.op == con::Op::Stop) CHECK(!state.heat, "stop left the heater on");
      if (c.op != con::Op::Tlim) CHECK(state.tlim_C == before.tlim_C, "a command other than tlim changed tlim");
    }
    check_state(state, lim, line, reply);
    // Same line, parsed again: same answer.
    {
      con::Command c2;
      con::Reply r2;
      con::Command c3;
      con::Reply r3;
      const bool p2 = con::parse(text.c_str(), c2, r2, lim);
      const bool p3 = con::parse(text.c_str(), c3, r3, lim);
      CHECK(p2 == p3 && strcmp(r2.text, r3.text) == 0, "parse() not deterministic");
      if (p2) CHECK(c2.op == c.op || !ok, "parse() and execute() disagree on the op");
    }
    if (text.size() < 200) check_numbers(text, reply);
    if (ok && c.op == con::Op::Status) {
      con::Live live;
      live.ticks = ticks;
      live.d_mm = mm;
      live.v = 2.0;
      live.temp_C = 1e12;
      live.fault = fault;
      live.dropped = 0xFFFF;
      live.overruns = 0xFFFF;
      live.t_ref_s = 1e12;  // "big"
      con::status_line(reply, state, live);
      check_reply_text(reply, line);
      CHECK(starts(reply.text, "OK status "), "status_line does not start with 'OK status '");
    }
    if (ok && c.op == con::Op::Stop) fault = sma::Fault::None;
  }

  // The same line through the Board (bytes in), then two ticks.
  void board_line(const std::string& bytes, const std::string& line) {
    for (char ch : bytes) {
      if (!board.rx(ch)) continue;
      board.handle_line();
      if (board.model_pending()) board.run_model_op();
      board.poll();
    }
    // The Board ends a line at '\r' as well as '\n' (a direct-mode line "tlim 80\r" is two
    // Board lines), so what its latch may follow is its own OK'd tlim, not execute()'s verdict.
    for (size_t i = 0; (i = board_out.find("OK tlim ", i)) != std::string::npos; ++i)
      if (i == 0 || board_out[i - 1] == '\n') board_tlim = board.state().tlim_C;
    tick(line);
    tick(line);
    check_board_out(line);
  }

  void check_board_out(const std::string& line) {
    size_t i = 0;
    while (i < board_out.size()) {
      size_t j = board_out.find('\n', i);
      if (j == std::string::npos) j = board_out.size();
      const std::string l = board_out.substr(i, j - i);
      CHECK(l.size() < con::kReplyMax, "Board line too long");
      for (char c : l) CHECK(static_cast<unsigned char>(c) >= 32 && static_cast<unsigned char>(c) < 127, "Board line not printable");
      const bool row = !l.empty() && (l[0] >= '0' && l[0] <= '9');
      CHECK(row || starts(l.c_str(), "OK ") || starts(l.c_str(), "ERR ") || starts(l.c_str(), "#") ||
                l == "t_s,v_V,d_mm,ref_mm,duty",
            "Board line neither OK/ERR/#/header nor a telemetry row");
      i = j + 1;
    }
    board_out.clear();
  }

  // What the firmware does with a model command (model_op(): defaults in the scratch set), and
  // what must hold afterwards: an OK/ERR reply; after a successful pcommit a set that passes the
  // checks, builds a valid controller and is what a reboot (Store::load) finds.
  void model_command(const con::Command& c, const std::string& line) {
    sma::Params scratch;
    sma::Effects fx;
    const int8_t active_before = store.active();
    const bool committed = con::model_command(c, store, scratch, fx, reply);
    check_reply_text(reply, line);
    CHECK(starts(reply.text, "OK ") || starts(reply.text, "ERR "), "model command reply not OK/ERR");
    if (c.op == con::Op::PCommit) {
      CHECK(committed == starts(reply.text, "OK "), "pcommit result and reply disagree");
      if (!committed) CHECK(store.active() == active_before, "a refused pcommit changed the active set");
    } else {
      CHECK(!committed, "a model command other than pcommit asked for a rebuild");
    }
    if (committed) {
      CHECK(scratch.check() == nullptr && fx.check() == nullptr, "pcommit accepted a set that fails check()");
      sma::Controller<float> fresh(scratch, fx, cfg());
      CHECK(fresh.valid(), "pcommit accepted a set the controller refuses");
      // A reboot reads back the same set.
      sma::storage::Store<RamEeprom> reboot(store.eeprom());
      sma::Params p2;
      sma::Effects fx2;
      CHECK(reboot.load(p2, fx2) == store.active(), "after pcommit a reboot loads another slot");
      for (uint8_t k = 0; k < sma::storage::kNumKeys; ++k)
        CHECK(sma::storage::get_value(p2, fx2, k) == sma::storage::get_value(scratch, fx, k),
              "after pcommit a reboot reads other values");
    }
  }

  // One tick of the Board: ~96 ADC samples of the measurement (a lost sensor if it is not one).
  void tick(const std::string& line) {
    const uint16_t a = adc();
    const uint16_t n = board.control(static_cast<uint32_t>(a) * 96u, 96, a >= 1023 ? 96 : 0);
    CHECK(n <= RIG_PWM_TOP + 1u, "PWM counts above TOP + 1");
    if (!board.state().heat || board.safety().tripped()) CHECK(n == 0, "PWM on with the heater off or the latch tripped");
    CHECK(board.safety().t_limit_C() == board_tlim, "the latch limit changed without tlim");
    const float v = board.controller().voltage();
    CHECK(std::isfinite(v) && v >= 0.0f && v <= RIG_V_MAX + 1e-6f, "controller output outside 0..V_max");
    board.report();
    board.poll();
    ++ticks;
    (void)line;
  }

  void line_error(con::LineBuffer::Status st, const std::string& line) {
    con::line_error(st, reply);
    check_reply_text(reply, line);
    CHECK(starts(reply.text, "ERR "), "line_error reply does not start with 'ERR '");
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  Harness h;
  const uint8_t flags = data[0];
  h.fault = static_cast<sma::Fault>((flags & 7) % 6);
  const bool direct = (flags & 8) != 0;
  const uint8_t m = flags >> 4;
  h.mm = m == 15 ? NAN : m == 14 ? 1e30f : -0.5f + 0.13f * m;
  h.board.boot(false, "# fuzz");
  if (h.fault != sma::Fault::None) {
    // Latch a fault in the Board too: heat, lose the sensor for a tick.
    const float mm = h.mm;
    h.board_line("volt 1\n", "volt 1");
    h.mm = NAN;
    h.tick("");
    h.mm = mm;
    h.board_out.clear();
  }
  const uint8_t* p = data + 1;
  const size_t n = size - 1;
  if (direct) {
    // Lines straight into execute(): no length limit, NULs end a line early (C string).
    std::string cur;
    for (size_t i = 0; i <= n; ++i) {
      if (i == n || p[i] == '\n') {
        const std::string l(cur.c_str());
        h.line(l);
        h.board_line(l + "\n", l);
        cur.clear();
      } else {
        cur.push_back(static_cast<char>(p[i]));
      }
    }
    return 0;
  }
  con::LineBuffer lb;
  size_t from = 0;  // the bytes of the line in progress, for the Board
  for (size_t i = 0; i < n; ++i) {
    const auto st = lb.push(static_cast<char>(p[i]));
    if (st == con::LineBuffer::Status::Pending) continue;
    const std::string line(lb.line(), lb.length());
    if (st == con::LineBuffer::Status::Line) {
      con::Reply& reply = h.reply;
      CHECK(lb.length() <= con::kLineMax, "LineBuffer passed a line longer than kLineMax");
      CHECK(strlen(lb.line()) == lb.length(), "LineBuffer line has a NUL or a wrong length");
      for (char c : line) CHECK(static_cast<unsigned char>(c) < 128 && c != '\r' && c != '\n', "LineBuffer passed a binary byte or a newline");
      h.line(line);
    } else {
      h.line_error(st, line);
    }
    h.board_line(std::string(reinterpret_cast<const char*>(p + from), i + 1 - from), line);
    from = i + 1;
  }
  return 0;
}
