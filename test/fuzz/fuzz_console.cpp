// libFuzzer target: the serial console (lib/sma_model/include/sma/console.hpp) on arbitrary bytes,
// wired like the firmware (firmware/src/main.cpp): LineBuffer -> execute -> status_line /
// line_error, then the controller, reference generator and safety latch the firmware syncs after
// an OK, stepped for a few ticks.
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
//     an accepted one passes the checks, builds a valid controller and is what a reboot loads.
// Dictionary: console.dict (the command words and model keys).
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmath>
#include <string>
#include <type_traits>

#include "sma/console.hpp"
#include "sma/controller.hpp"
#include "sma/reference.hpp"
#include "sma/safety.hpp"
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

struct Harness {
  con::State state;
  sma::storage::Store<RamEeprom> store;
  con::Limits lim;
  con::Reply reply;
  sma::Fault fault = sma::Fault::None;
  sma::Controller<float> ctl;
  sma::ReferenceGen<float> gen;
  sma::Safety safety;
  uint16_t run_seen = 0;
  uint32_t ticks = 0, run_start = 0;
  float mm = 0.3f;

  static sma::ControllerConfig cfg() {
    sma::ControllerConfig c;
    c.dt = 0.01;
    c.v_max = 2.0;
    c.gains = con::default_gains(sma::Mode::FeedforwardPid);
    return c;
  }
  Harness() : ctl(sma::Params(), sma::Effects(), cfg()), gen(sma::Reference::constant(0.0)) {}

  // What the firmware does with one complete line.
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

    if (ok) {
      if (c.op == con::Op::Status) {
        con::Live live;
        live.ticks = ticks;
        live.d_mm = mm;
        live.v = ctl.voltage();
        live.temp_C = ctl.wire_temperature();
        live.fault = fault;
        live.dropped = 0xFFFF;
        live.overruns = 0xFFFF;
        live.t_ref_s = 1e12;  // "big"
        con::status_line(reply, state, live);
        check_reply_text(reply, line);
        CHECK(starts(reply.text, "OK status "), "status_line does not start with 'OK status '");
      }
      // sync_state() of the firmware.
      if (c.op == con::Op::Stop) {
        fault = sma::Fault::None;
        safety.clear();
      }
      CHECK(safety.set_limit(state.tlim_C), "Safety refused the console's tlim");
      ctl.set_voltage(static_cast<float>(state.volt));
      if (state.active_mode() != ctl.mode()) ctl.set_mode(state.active_mode(), mm);
      if (c.op == con::Op::Gains || c.op == con::Op::SetMode) ctl.set_gains(state.gains());
      if (state.run != run_seen) {
        run_seen = state.run;
        gen = sma::ReferenceGen<float>(state.reference());
        run_start = ticks;
      }
    }
    tick(line);
    tick(line);
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

  void tick(const std::string& line) {
    // A trajectory/sine/step far into its run as well as at its start.
    const double t_ref = (ticks - run_start) * 0.01 * (ticks % 7 == 0 ? 997.0 : 1.0);
    const float ref = gen.at(t_ref);
    CHECK(std::isfinite(ref), "reference not finite");
    const float v = ctl.step(ref, mm);
    CHECK(std::isfinite(v) && v >= 0.0f && v <= 2.0f + 1e-6f, "controller output outside 0..V_max");
    sma::SafetyInput si;
    si.sensor_v = std::isfinite(mm) ? (mm + 0.5) / 0.4 : NAN;
    si.measured_mm = mm;
    si.wire_temp_C = ctl.wire_temperature();
    si.command_v = v;
    si.heating = state.heat;
    const double g = safety.gate(si);
    CHECK(g >= 0.0 && g <= 2.0 + 1e-6, "safety gate output outside 0..V_max");
    if (safety.tripped()) CHECK(g == 0.0, "heating through a tripped latch");
    if (safety.tripped() && state.heat) {
      state.heat = false;
      ctl.set_mode(sma::Mode::Off, mm);
      if (fault == sma::Fault::None) fault = safety.fault();
    }
    con::telemetry_row(reply, ticks, 100, g, mm, ref, (g / 5.0) * (g / 5.0));
    check_reply_text(reply, line);
    ++ticks;
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
  if (h.fault != sma::Fault::None) {
    sma::SafetyInput bad;
    bad.sensor_v = 99.0;  // latch something so that the gate agrees with the console's fault
    bad.heating = true;
    h.safety.gate(bad);
  }
  const uint8_t* p = data + 1;
  const size_t n = size - 1;
  if (direct) {
    // Lines straight into execute(): no length limit, NULs end a line early (C string).
    std::string cur;
    for (size_t i = 0; i <= n; ++i) {
      if (i == n || p[i] == '\n') {
        h.line(std::string(cur.c_str()));
        cur.clear();
      } else {
        cur.push_back(static_cast<char>(p[i]));
      }
    }
    return 0;
  }
  con::LineBuffer lb;
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
  }
  return 0;
}
