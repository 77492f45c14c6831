// The firmware's serial console as pure functions: no I/O, no heap, no printf, C++14, AVR-ready.
// One line in -> one reply out, and a change of the console State only when the reply is OK.
//
// Commands (one per line, lower case, fields separated by spaces or tabs; numbers are plain
// decimals such as 0.4, -1, .5, +2.25: no exponent, no inf/nan):
//
// | command              | does                                                    | range      |
// |----------------------|---------------------------------------------------------|------------|
// | pos <mm>             | hold a constant setpoint, heater on                     | 0..g mm    |
// | step                 | run the paper's multi-step (0.2..0.8 mm, 25 s steps)    |            |
// | sine                 | run the paper's sine (0.2..0.7 mm, 50 s, 3 periods)     |            |
// | traj clear           | forget the trajectory points                            |            |
// | traj <t_s> <mm>      | add a point (time increasing, at most 16)               | 0..3600 s  |
// | traj run             | run the trajectory (linear between points, then hold)   |            |
// | mode open|pid|ff|ffpid | select the controller (live if heating)               |            |
// | volt <V>             | open-loop voltage; selects mode open, heater on         | 0..2 V     |
// | gains <kp> <ki> <kd> | PID gains of the selected PID mode (pid or ffpid)       | 0..1000    |
// | tlim <degC>          | wire temperature limit of the safety latch              | 30..150    |
// | tele on|off          | telemetry rows t_s,v_V,d_mm,ref_mm,duty at 100 Hz       |            |
// | status               | one line: mode, reference, measurement, fault           |            |
// | stop                 | heater off (mode off), clears a latched fault           |            |
// | help                 | list the commands                                       |            |
// | train [slope]        | the paper's training signal open loop (sma/training.hpp), then heater off | 0.0001..1 V/s |
// | pbegin               | start a new model set in the inactive EEPROM slot (copy of the active one) | |
// | pset <key> <value>   | write one value of the staged set: `OK pset <key> 0x<float32 bits read back>` | per key |
// | pcommit              | validate the staged set (Params/Effects::check), make it active, rebuild the controller | |
// | pabort               | drop the staged set (the active set stays)              |            |
// | pget <key>           | a value of the active set: `OK pget <key> <value> 0x<float32 bits>` | |
// | pinfo                | `OK pinfo v<version> slot <s> seq <n> crc 0x<crc>` or `... defaults` | |
//
// pbegin, pset and pcommit need the heater off (`ERR pset: heater on, send stop`). Keys are the
// params JSON contract's (interfaces.md) flattened: rho c h d0 L0 R T_amb T_AS T_AF T_MS T_MF
// T_s T_f T_MSs T_MSf q e g, m0..m5, loop<i>.T_i|T_ii|j (i 0..7), loops (count 0..8) and the
// effects as <effect>.<param> (sensor_delay.delay_s, ...). A value out of the key's range gets
// `ERR <key>: value out of range lo..hi`; a set check() refuses at pcommit gets `ERR <key>: <why>`
// with storage::CheckValidator (host), `ERR pcommit: <why>` with a validator that gives no key
// (the firmware's: reading check()'s messages on AVR would keep them in RAM).
// An effect's parameter alone is accepted as its key too (beta_per_K): a long key and a precise
// value must fit 47 characters. The model commands only parse here: the firmware runs them on
// its EEPROM with model_command(). train and the model commands exist where Limits::train /
// Limits::model say so (a firmware variant without them answers `ERR unknown command`).
//
// Replies: `OK <what changed>` or `ERR <problem>`; an ERR changes nothing. While a safety fault
// is latched, commands that would heat (pos, step, sine, traj run, volt) answer
// `ERR fault <name>: send stop`. When telemetry starts, the header `t_s,v_V,d_mm,ref_mm,duty` is
// sent once, then one row per tick, so the captured rows are a rig log (interfaces.md); reply
// lines start with OK/ERR and comments with '#', which log readers skip or report.
//
// Heater off at boot: State::heat is false until pos/step/sine/traj run/volt.
#ifndef SMA_CONSOLE_HPP
#define SMA_CONSOLE_HPP

#include <stddef.h>
#include <stdint.h>
#include "controller.hpp"
#include "pid.hpp"
#include "reference.hpp"
#include "safety.hpp"
#include "scalar.hpp"
#include "storage.hpp"

namespace sma {
namespace console {

constexpr uint8_t kLineMax = 47;    // longest accepted line, without the newline
constexpr uint8_t kReplyMax = 120;  // longest reply, with the terminating 0
constexpr double kTrajMaxS = 3600.0;

// Default gains: each mode tuned for its own best result on the paper's sine in rig-like
// conditions (host/include/sma_host/tune.hpp; bench_tracking prints them).
// (Constants, so that the console's initial State is a constant the AVR copies from flash.)
constexpr PidGains kGainsPid = {12.5, 5.12, 0.25, 0.05, 0.05};
constexpr PidGains kGainsFfpid = {12.1, 3.13, 0.0, 0.05, 0.05};
// (Field by field into the return value: a copy of the whole constant would add a temporary to
// Board::construct's frame, the deepest of the firmware.)
inline PidGains default_gains(Mode m) {
  const PidGains& k = m == Mode::Pid ? kGainsPid : kGainsFfpid;
  PidGains g;
  g.kp = k.kp;
  g.ki = k.ki;
  g.kd = k.kd;
  g.d_filter_s = k.d_filter_s;
  g.i_zone_mm = k.i_zone_mm;
  return g;
}

// mode_name() as an SMA_F (flash) string.
inline const char* mode_name_f(Mode m) {
  switch (m) {
    case Mode::OpenLoop: return SMA_F("open");
    case Mode::Pid: return SMA_F("pid");
    case Mode::Feedforward: return SMA_F("ff");
    case Mode::FeedforwardPid: return SMA_F("ffpid");
    default: return SMA_F("off");
  }
}

// Limits of the numbers the console accepts.
struct Limits {
  double g_mm = 0.958;  // stroke: pos and traj points in 0..g
  double v_max = 2.0;   // volt in 0..v_max
  bool model = true;    // the model commands (pbegin ...) exist in this build
  bool train = true;    // train exists in this build
  bool single = false;  // numbers in float arithmetic (sma::Board: as on the AVR)
};

// What the console controls. The firmware applies it to the controller and the safety latch.
struct State {
  Mode mode = Mode::FeedforwardPid;  // selected controller (never Off; `stop` clears heat)
  bool heat = false;                 // heater allowed: false at boot and after stop or a trip
  double volt = 0.0;                 // open-loop voltage
  PidGains gains_pid = kGainsPid;
  PidGains gains_ffpid = kGainsFfpid;
  double tlim_C = 110.0;
  bool tele = false;
  RefKind run_kind = RefKind::Constant;  // the reference being run (reference())
  double pos_mm = 0.0;                    // its setpoint if constant
  Reference traj = {RefKind::Trajectory};  // trajectory points (edited by traj, run by traj run)
  uint16_t run = 0;  // incremented at every (re)start of a reference: restart its clock
  bool training = false;  // the training signal is playing (train), open loop

  // The reference being run (a trajectory as it was at `traj run`: the firmware copies it into
  // its generator then, so editing the points does not disturb a running trajectory).
  Reference reference() const {
    switch (run_kind) {
      case RefKind::MultiStep: return Reference::multi_step();
      case RefKind::Sine: return Reference::sine();
      case RefKind::Trajectory: return traj;
      default: return Reference::constant(pos_mm);
    }
  }

  // The controller mode to run now.
  Mode active_mode() const { return heat ? mode : Mode::Off; }
  // Gains of the selected PID mode (ffpid's for open and ff).
  const PidGains& gains() const { return mode == Mode::Pid ? gains_pid : gains_ffpid; }

  static Reference trajectory() {
    Reference r;
    r.kind = RefKind::Trajectory;
    return r;
  }
};

enum class Op : uint8_t {
  Empty, Pos, Step, Sine, TrajClear, TrajPoint, TrajRun, SetMode, Volt, Gains, Tlim, Tele,
  Status, Stop, Help, Train, PBegin, PSet, PGet, PCommit, PAbort, PInfo
};

// Model commands: executed by the firmware on its EEPROM (model_command()), not by apply().
inline bool is_model_op(Op op) { return op >= Op::PBegin; }

// A parsed line.
struct Command {
  Op op = Op::Empty;
  double a = 0.0, b = 0.0, c = 0.0;
  Mode mode = Mode::Off;
  bool on = false;
  uint8_t key = 0;    // model commands: the key (sma/storage.hpp); help: the build's kModelCmd/kTrainCmd
  uint8_t row = 0;    // its row of the command table (below)
  uint8_t props = 0;  // the row's properties (Prop)
  // Would this command turn the heater on?
  bool heats() const { return (props & 1u) != 0; }  // kHeats
};

// ---- a small bounded text buffer ---------------------------------------------------------------
struct Reply {
  char text[kReplyMax];
  uint8_t len = 0;
  Reply() { text[0] = 0; }
  void clear() {
    len = 0;
    text[0] = 0;
  }
  void put(char c) {
    if (len + 1 < kReplyMax) {
      text[len] = c;
      len = static_cast<uint8_t>(len + 1);
      text[len] = 0;
    }
  }
  // Append an SMA_F (flash) string.
  void put_f(const char* s) {
    for (char c = flash_char(s); c != 0; c = flash_char(++s)) put(c);
  }
  // Append a RAM string (at most n chars); non-printable characters become '?'.
  void put_s(const char* s, uint8_t n = 255) {
    for (uint8_t k = 0; k < n && s[k] != 0; ++k) put(s[k] >= 32 && s[k] < 127 ? s[k] : '?');
  }
  void put_u(uint32_t v) {
    char d[10];
    uint8_t n = 0;
    while (v > 0xFFFFu && n < 10) {  // 32-bit digits only while needed
      d[n++] = static_cast<char>('0' + v % 10u);
      v /= 10u;
    }
    uint16_t w = static_cast<uint16_t>(v);
    do {
      d[n++] = static_cast<char>('0' + w % 10u);
      w = static_cast<uint16_t>(w / 10u);
    } while (w != 0 && n < 10);
    while (n > 0) put(d[--n]);
  }
  // Fixed-point decimal with `dec` decimals (0..6), rounded; "nan"/"inf" for non-finite and
  // "big" beyond 2e9 units of the last digit (so no printf("%f"), which avr-libc lacks by default).
  void put_fixed(double x, uint8_t dec) {
    if (!is_finite(x)) {
      put_f(x != x ? SMA_F("nan") : SMA_F("inf"));
      return;
    }
    if (dec > 6) dec = 6;
    uint32_t scale = 1;
    for (uint8_t k = 0; k < dec; ++k) scale *= 10u;
    if (x < 0.0) {
      x = -x;
      // "-0.0000" would read oddly: only print the sign if something non-zero follows.
      if (x * static_cast<double>(scale) >= 0.5) put('-');
    }
    const double scaled = x * static_cast<double>(scale) + 0.5;
    if (!(scaled < 2.0e9)) {
      put_f(SMA_F("big"));
      return;
    }
    const uint32_t v = static_cast<uint32_t>(scaled);
    const uint32_t ip = v / scale;
    put_u(ip);
    if (dec == 0) return;
    put('.');
    const uint32_t frac = v - ip * scale;
    // Digits right to left; 16-bit arithmetic when it fits (a 32-bit division costs ~600 AVR
    // cycles, a 16-bit one ~200: telemetry formats 4 numbers every tick).
    char d[6];
    if (scale <= 10000u) {
      uint16_t f = static_cast<uint16_t>(frac);
      for (uint8_t k = dec; k > 0; --k) {
        d[k - 1] = static_cast<char>('0' + f % 10u);
        f = static_cast<uint16_t>(f / 10u);
      }
    } else {
      uint32_t f = frac;
      for (uint8_t k = dec; k > 0; --k) {
        d[k - 1] = static_cast<char>('0' + f % 10u);
        f /= 10u;
      }
    }
    for (uint8_t k = 0; k < dec; ++k) put(d[k]);
  }
  // A short decimal, about 6-7 significant digits, trailing zeros trimmed: 0.000001, 0.2,
  // -4.8334, 50.2, 100000 (range bounds, and pget/pset echoes next to the exact float bits).
  void put_num(double x) {
    const double a = x < 0.0 ? -x : x;
    const uint8_t start = len;
    put_fixed(x, a >= 1000.0 ? 2 : a >= 10.0 ? 4 : a >= 1.0 ? 5 : 6);
    bool point = false;
    for (uint8_t k = start; k < len; ++k) point = point || text[k] == '.';
    if (!point) return;
    while (len > start && text[len - 1] == '0') --len;
    if (len > start && text[len - 1] == '.') --len;
    text[len] = 0;
  }
  void put_hex(uint32_t v, uint8_t digits) {
    put('0');
    put('x');
    for (uint8_t k = digits; k > 0; --k) {
      const uint8_t d = static_cast<uint8_t>((v >> (4 * (k - 1))) & 0xFu);
      put(static_cast<char>(d < 10 ? '0' + d : 'a' + d - 10));
    }
  }
};

// ---- telemetry ---------------------------------------------------------------------------------
inline const char* telemetry_header() { return SMA_F("t_s,v_V,d_mm,ref_mm,duty"); }

// One row `t_s,v_V,d_mm,ref_mm,duty`; t from the tick count (exact, 100 Hz -> 2 decimals).
inline void telemetry_row(Reply& r, uint32_t ticks, uint16_t ticks_per_s, double v, double d_mm,
                          double ref_mm, double duty) {
  r.clear();
  r.put_u(ticks / ticks_per_s);
  r.put('.');
  uint32_t frac = ticks % ticks_per_s;
  // two decimals for 100 Hz; three for up to 1000 ticks/s.
  const uint8_t digits = ticks_per_s <= 100 ? 2 : 3;
  uint32_t unit = digits == 2 ? 100u : 1000u;
  frac = frac * unit / ticks_per_s;
  for (uint32_t s = unit / 10u; s > 0; s /= 10u) {
    r.put(static_cast<char>('0' + frac / s));
    frac %= s;
  }
  r.put(',');
  r.put_fixed(v, 4);
  r.put(',');
  r.put_fixed(d_mm, 4);
  r.put(',');
  r.put_fixed(ref_mm, 4);
  r.put(',');
  r.put_fixed(duty, 5);
}

// ---- line assembly -----------------------------------------------------------------------------
// Bytes in, complete lines out. A line ends at '\n' or '\r' ("\r\n" gives one line: the empty
// line between them is ignored). An over-long line, or one with a NUL or a byte >= 128, is
// reported once, at its end, as `overflow` / `binary`, and its bytes are dropped.
class LineBuffer {
 public:
  enum class Status : uint8_t { Pending, Line, TooLong, Binary };

  Status push(char c) {
    if (c == '\n' || c == '\r') {
      const Status s = too_long_ ? Status::TooLong : (binary_ ? Status::Binary : Status::Line);
      const bool empty = len_ == 0 && !too_long_ && !binary_;
      buf_[len_] = 0;
      done_len_ = len_;
      len_ = 0;
      too_long_ = false;
      binary_ = false;
      if (empty && last_was_cr_ && c == '\n') {
        last_was_cr_ = false;
        return Status::Pending;  // the \n of \r\n
      }
      last_was_cr_ = c == '\r';
      return s;
    }
    last_was_cr_ = false;
    const uint8_t u = static_cast<uint8_t>(c);
    if (u == 0 || u >= 128) binary_ = true;
    if (len_ >= kLineMax) {
      too_long_ = true;
      return Status::Pending;
    }
    buf_[len_] = c;
    len_ = static_cast<uint8_t>(len_ + 1);
    return Status::Pending;
  }
  // The completed line (valid after push() returned Line, until the next push()).
  const char* line() const { return buf_; }
  uint8_t length() const { return done_len_; }

 private:
  // Not zeroed at construction (48 stores of flash on AVR): line() is read only after a Line,
  // which 0-terminates it.
  char buf_[kLineMax + 1];
  uint8_t len_ = 0, done_len_ = 0;
  bool too_long_ = false, binary_ = false, last_was_cr_ = false;
};

// ---- parsing -----------------------------------------------------------------------------------
namespace detail {

inline bool is_space(char c) { return c == ' ' || c == '\t'; }

// Next token of the line: skips blanks, returns its start and length (0 at the end).
inline const char* next_token(const char*& p, uint8_t& len) {
  while (is_space(*p)) ++p;
  const char* start = p;
  len = 0;
  while (*p != 0 && !is_space(*p)) {
    ++p;
    if (len < 255) len = static_cast<uint8_t>(len + 1);
  }
  return start;
}

// Token equals the flash string?
inline bool token_is(const char* tok, uint8_t len, const char* word_f) {
  uint8_t k = 0;
  for (; k < len; ++k) {
    const char w = flash_char(word_f + k);
    if (w == 0 || w != tok[k]) return false;
  }
  return flash_char(word_f + k) == 0;
}

enum class Num : uint8_t { Ok, Bad, TooLong };

// A plain decimal: [+-] digits [. digits] | [+-] . digits. At most 9 significant digits before
// the point, extra fraction digits are dropped (truncated). No exponent, no inf, no nan.
// `single`: computed in float as on the AVR (a host model of the board answers a number on a
// range limit as the board does).
inline Num parse_number(const char* tok, uint8_t len, double& out, bool single = false) {
  uint8_t k = 0;
  bool neg = false;
  if (k < len && (tok[k] == '+' || tok[k] == '-')) {
    neg = tok[k] == '-';
    ++k;
  }
  uint32_t mant = 0;
  uint8_t sig = 0, frac_digits = 0, digits = 0;
  bool point = false;
  for (; k < len; ++k) {
    const char c = tok[k];
    if (c == '.') {
      if (point) return Num::Bad;
      point = true;
      continue;
    }
    if (c < '0' || c > '9') return Num::Bad;
    ++digits;
    if (mant == 0 && c == '0' && !point) continue;  // leading zeros
    if (sig >= 9) {
      if (!point) return Num::TooLong;  // > 999999999: out of every range anyway
      continue;                         // fraction digits past 9 significant ones
    }
    mant = mant * 10u + static_cast<uint32_t>(c - '0');
    if (mant != 0) ++sig;
    if (point) ++frac_digits;
  }
  if (digits == 0) return Num::Bad;  // "", "+", ".", "-."
  if (single) {  // the AVR's arithmetic (double is float there), step by step
    float f = static_cast<float>(mant);
    for (uint8_t d = 0; d < frac_digits; ++d) f /= 10.0f;
    out = static_cast<double>(neg ? -f : f);
    return Num::Ok;
  }
  double v = static_cast<double>(mant);
  for (uint8_t f = 0; f < frac_digits; ++f) v /= 10.0;
  out = neg ? -v : v;
  return Num::Ok;
}

}  // namespace detail

// The reply to a bad line from the LineBuffer.
inline void line_error(LineBuffer::Status st, Reply& reply) {
  reply.clear();
  if (st == LineBuffer::Status::TooLong) {
    reply.put_f(SMA_F("ERR line too long (max "));
    reply.put_u(kLineMax);
    reply.put_f(SMA_F(" chars)"));
  }
  else reply.put_f(SMA_F("ERR line has a NUL or non-ASCII byte"));
}

// ---- the command table -------------------------------------------------------------------------
// One row per operation: the command word, the keyword after it ("-": numbers follow instead),
// the Op, a value (the Mode of `mode`, on/off of `tele`), properties and up to three numbers.
// The parser, `help`, the error messages and the properties (Command::heats ...) come from it.
// Rows of one word are consecutive; a keyword row comes before the word's "-" row.
enum Prop : uint8_t {
  kHeats = 1,         // turns the heater on (refused while a fault is latched)
  kEndsTraining = 2,  // replaces a running training signal
  kCold = 4,          // needs the heater off (writes the EEPROM)
  kModelCmd = 8,      // exists where Limits::model (pbegin ...)
  kTrainCmd = 16,     // exists where Limits::train
  kOptional = 32,     // its number may be omitted
  kKeyed = 64,        // a storage key comes first (pset, pget); its number has the key's range
};
// The numbers: name (in the errors) and range. Upper bound -1: the stroke (Limits::g_mm), -2:
// Limits::v_max.
enum Arg : uint8_t { kNoArg, kArgMm, kArgV, kArgKp, kArgKi, kArgKd, kArgDegC, kArgTs, kArgSlope, kArgValue };
namespace detail {
inline const char* arg_names() { return SMA_F("- mm V kp ki kd degC t_s slope value"); }
static SMA_STORAGE_TABLE double kArgRange[][2] = {
    {0, 0}, {0, -1}, {0, -2}, {0, 999}, {0, 999}, {0, 999}, {30, 150}, {0, kTrajMaxS}, {0.0001, 1}, {0, 0}};
inline const char* command_words() {
  return SMA_F("pos step sine traj traj traj mode mode mode mode volt gains tlim tele tele status stop help "
               "train pbegin pset pget pcommit pabort pinfo");
}
inline const char* command_subs() { return SMA_F("- - - clear run - open pid ff ffpid - - - on off - - - - - - - - - -"); }
struct CommandRow {
  Op op;
  uint8_t value;
  uint8_t props;
  uint8_t args[3];
};
constexpr uint8_t kEnds = kHeats | kEndsTraining;
static SMA_STORAGE_TABLE CommandRow kCommandRows[] = {
    {Op::Pos, 0, kEnds, {kArgMm, 0, 0}},
    {Op::Step, 0, kEnds, {0, 0, 0}},
    {Op::Sine, 0, kEnds, {0, 0, 0}},
    {Op::TrajClear, 0, 0, {0, 0, 0}},
    {Op::TrajRun, 0, kEnds, {0, 0, 0}},
    {Op::TrajPoint, 0, 0, {kArgTs, kArgMm, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::OpenLoop), kEndsTraining, {0, 0, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::Pid), kEndsTraining, {0, 0, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::Feedforward), kEndsTraining, {0, 0, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::FeedforwardPid), kEndsTraining, {0, 0, 0}},
    {Op::Volt, 0, kEnds, {kArgV, 0, 0}},
    {Op::Gains, 0, 0, {kArgKp, kArgKi, kArgKd}},
    {Op::Tlim, 0, 0, {kArgDegC, 0, 0}},
    {Op::Tele, 1, 0, {0, 0, 0}},
    {Op::Tele, 0, 0, {0, 0, 0}},
    {Op::Status, 0, 0, {0, 0, 0}},
    {Op::Stop, 0, kEndsTraining, {0, 0, 0}},
    {Op::Help, 0, 0, {0, 0, 0}},
    {Op::Train, 0, kHeats | kTrainCmd | kOptional, {kArgSlope, 0, 0}},
    {Op::PBegin, 0, kModelCmd | kCold, {0, 0, 0}},
    {Op::PSet, 0, kModelCmd | kCold | kKeyed, {kArgValue, 0, 0}},
    {Op::PGet, 0, kModelCmd | kKeyed, {0, 0, 0}},
    {Op::PCommit, 0, kModelCmd | kCold, {0, 0, 0}},
    {Op::PAbort, 0, kModelCmd, {0, 0, 0}},
    {Op::PInfo, 0, kModelCmd, {0, 0, 0}},
};
constexpr uint8_t kCommandCount = sizeof(kCommandRows) / sizeof(kCommandRows[0]);

inline CommandRow command_row(uint8_t r) {
  CommandRow row;
#if defined(__AVR__)
  memcpy_P(&row, &kCommandRows[r], sizeof(CommandRow));
#else
  row = kCommandRows[r];
#endif
  return row;
}
inline double arg_bound(uint8_t arg, uint8_t hi, const Limits& lim) {
#if defined(__AVR__)
  const double b = pgm_read_float(&kArgRange[arg][hi]);
#else
  const double b = kArgRange[arg][hi];
#endif
  return b == -1.0 ? lim.g_mm : b == -2.0 ? lim.v_max : b;
}
// Does row r exist in this build?
inline bool row_exists(const CommandRow& row, const Limits& lim) {
  return !((row.props & kModelCmd) && !lim.model) && !((row.props & kTrainCmd) && !lim.train);
}
// Word n of a flash list equals tok[0..len)?
inline bool word_is(const char* list_f, uint8_t n, const char* tok, uint8_t len) {
  struct Cmp {
    const char* tok;
    uint8_t len, k;
    bool same;
    void put(char c) {
      same = same && k < len && tok[k] == c;
      ++k;
    }
  } cmp = {tok, len, 0, true};
  storage::detail::put_word(cmp, list_f, n);
  return cmp.same && cmp.k == len;
}
inline bool same_word(uint8_t r1, uint8_t r2) {
  struct Buf {
    char t[8];
    uint8_t n;
    void put(char c) {
      if (n < 8) t[n++] = c;
    }
  } b = {{0}, 0};
  storage::detail::put_word(b, command_words(), r1);
  return word_is(command_words(), r2, b.t, b.n);
}
inline bool has_sub(uint8_t r) { return !word_is(command_subs(), r, "-", 1); }
}  // namespace detail

// `help`: the words of the commands of this build, '|'-separated; a command that takes one
// number shows its unit (pos mm).
inline void put_help(Reply& reply, const Limits& lim) {
  using namespace detail;
  bool first = true;
  for (uint8_t r = 0; r < kCommandCount; ++r) {
    const CommandRow row = command_row(r);
    if (!row_exists(row, lim) || (r > 0 && same_word(r, static_cast<uint8_t>(r - 1)))) continue;
    if (!first) reply.put('|');
    first = false;
    storage::detail::put_word(reply, command_words(), r);
    if (row.args[0] != kNoArg && row.args[1] == kNoArg && !(row.props & (kKeyed | kOptional)) && !has_sub(r)) {
      reply.put(' ');
      storage::detail::put_word(reply, arg_names(), row.args[0]);
    }
  }
}

// Parses one line (no newline) into `cmd`. On error returns false, writes `ERR <problem>` into
// `reply` and leaves `cmd` untouched. On success returns true (reply untouched).
inline bool parse(const char* line, Command& cmd, Reply& reply, const Limits& lim = Limits()) {
  using namespace detail;
  // The LineBuffer never passes more than kLineMax chars; a caller that bypasses it gets the
  // same answer (and the 8-bit token lengths below stay exact).
  for (uint8_t n = 0; line[n] != 0; ++n) {
    if (n >= kLineMax) {
      line_error(LineBuffer::Status::TooLong, reply);
      return false;
    }
  }
  const char* p = line;
  uint8_t len0 = 0;
  const char* t0 = next_token(p, len0);
  Command c;
  if (len0 == 0) {
    cmd = c;  // Op::Empty
    return true;
  }
  uint8_t r = 0;
  while (r < kCommandCount && !(row_exists(command_row(r), lim) && word_is(command_words(), r, t0, len0))) ++r;
  if (r == kCommandCount) {
    reply.clear();
    reply.put_f(SMA_F("ERR unknown command '"));
    reply.put_s(t0, len0 > 12 ? 12 : len0);
    reply.put_f(SMA_F("' (try help)"));
    return false;
  }
  const uint8_t first = r;
  auto err_head = [&]() {
    reply.clear();
    reply.put_f(SMA_F("ERR "));
    storage::detail::put_word(reply, command_words(), first);
    reply.put_f(SMA_F(": "));
  };
  auto err = [&](const char* msg_f) {
    err_head();
    reply.put_f(msg_f);
    return false;
  };

  // The keyword: the row among the word's rows that names it, else the word's "-" row.
  uint8_t len = 0;
  const char* save = p;
  const char* tok = next_token(p, len);
  uint8_t last = first;
  while (last + 1 < kCommandCount && same_word(first, static_cast<uint8_t>(last + 1))) ++last;
  if (last > first) {  // keywords: `mode open`, `tele on`, `traj clear` ...
    r = first;
    while (r <= last && has_sub(r) && !word_is(command_subs(), r, tok, len)) ++r;
    if (r > last || (len == 0 && !has_sub(r))) {  // "expected a, b or <t_s> <mm>"
      err_head();
      reply.put_f(SMA_F("expected "));
      for (uint8_t k = first; k <= last; ++k) {
        if (k > first) reply.put_f(k == last ? SMA_F(" or ") : SMA_F(", "));
        if (has_sub(k)) {
          storage::detail::put_word(reply, command_subs(), k);
          continue;
        }
        const CommandRow row = command_row(k);
        for (uint8_t a = 0; a < 3 && row.args[a] != kNoArg; ++a) {
          if (a > 0) reply.put(' ');
          reply.put('<');
          storage::detail::put_word(reply, arg_names(), row.args[a]);
          reply.put('>');
        }
      }
      return false;
    }
    if (!has_sub(r)) p = save;  // numbers follow
  } else {
    p = save;
  }
  const CommandRow row = command_row(r);
  c.op = row.op;
  c.row = r;
  c.props = row.props;
  c.mode = static_cast<Mode>(row.value);
  c.on = row.value != 0;

  uint8_t nargs = 0;
  while (nargs < 3 && row.args[nargs] != kNoArg) ++nargs;
  double klo = 0.0, khi = 0.0;  // the key's range (pset)
  // (lim.model first: a build without the model commands drops the keys' code.)
  const bool keyed = lim.model && (row.props & kKeyed) != 0;
  if (keyed) {
    tok = next_token(p, len);
    if (len == 0) return err(SMA_F("missing <key>"));
    c.key = storage::key_index(tok, len);
    if (c.key == storage::kNoKey) {
      err(SMA_F("unknown key '"));
      reply.put_s(tok, len > 32 ? 32 : len);
      reply.put('\'');
      return false;
    }
    if (nargs) storage::key_range(c.key, klo, khi);
  }
  if (row.props & kOptional) {
    save = p;
    next_token(p, len);
    p = save;
    if (len == 0) nargs = 0;
  }

  double v[3] = {0, 0, 0};
  for (uint8_t k = 0; k < nargs; ++k) {
    tok = next_token(p, len);
    // pset: `ERR <key>: value ...`; others: `ERR <command>: <what> ...`
    const double lo = keyed ? klo : arg_bound(row.args[k], 0, lim);
    const double hi = keyed ? khi : arg_bound(row.args[k], 1, lim);
    const Num n = len == 0 ? Num::Bad : parse_number(tok, len, v[k], lim.single);
    const bool in_range = v[k] >= lo && v[k] <= hi;
    // The loop count must be a whole number; cast only once it is known to fit a uint8_t
    // (converting an out-of-range double is undefined behaviour: found by fuzz_console).
    const bool integer = !keyed || c.key != storage::kKeyLoops || !in_range ||
                         v[k] == static_cast<double>(static_cast<uint8_t>(v[k]));
    if (len == 0 || n != Num::Ok || !in_range || !integer) {
      if (keyed) {
        reply.clear();
        reply.put_f(SMA_F("ERR "));
        storage::put_key_name(reply, c.key);
        reply.put_f(SMA_F(": "));
      } else {
        err_head();
      }
      if (len == 0) reply.put_f(SMA_F("missing number <"));
      storage::detail::put_word(reply, arg_names(), row.args[k]);
      if (len == 0) {
        reply.put('>');
      } else if (n == Num::Bad) {
        reply.put_f(SMA_F(" is not a number: '"));
        reply.put_s(tok, len > 12 ? 12 : len);
        reply.put('\'');
      } else {
        reply.put_f(integer ? SMA_F(" out of range ") : SMA_F(" must be an integer "));
        if (keyed) {
          reply.put_num(lo);
          reply.put_f(SMA_F(".."));
          reply.put_num(hi);
        } else {
          reply.put_fixed(lo, 3);
          reply.put_f(SMA_F(".."));
          reply.put_fixed(hi, 3);
        }
      }
      return false;
    }
  }
  tok = next_token(p, len);
  if (len != 0) return err(SMA_F("unexpected extra text"));
  c.a = v[0];
  c.b = v[1];
  c.c = v[2];
  if (c.op == Op::Help) c.key = static_cast<uint8_t>((lim.model ? kModelCmd : 0) | (lim.train ? kTrainCmd : 0));
  cmd = c;
  return true;
}

// ---- execution ---------------------------------------------------------------------------------
// Applies a parsed command to the state and writes the reply. `fault` is the latched safety
// fault (Fault::None if none). Returns false (ERR, state untouched) if the command is refused.
// Status and Help only write their reply here; the firmware appends live values to status
// (status_line()).
inline bool apply(const Command& c, State& s, Fault fault, Reply& reply) {
  reply.clear();
  if (c.heats() && fault != Fault::None) {
    reply.put_f(SMA_F("ERR fault "));
    reply.put_f(fault_name(fault));
    reply.put_f(SMA_F(": send stop"));
    return false;
  }
  const char* why = nullptr;  // refused: `ERR <command>: <why>`
  if (is_model_op(c.op)) {
    if (!(s.heat && (c.props & kCold))) return true;  // the firmware runs it (model_command) and replies
    why = SMA_F("heater on, send stop");
  } else if (c.op == Op::Empty) {
    return true;  // nothing, no reply
  } else if (c.op == Op::TrajPoint) {
    if (s.traj.n_points >= kMaxPoints) {
      why = SMA_F("full (16 points)");
    } else if (s.traj.n_points > 0 && !(c.a > s.traj.point_t[s.traj.n_points - 1])) {
      why = SMA_F("t_s must increase");
    } else {
      s.traj.add_point(c.a, c.b);
      reply.put_f(SMA_F("OK traj point "));
      reply.put_u(s.traj.n_points);
      return true;
    }
  } else if (c.op == Op::TrajRun && s.traj.n_points == 0) {
    why = SMA_F("no points");
  }
  if (why) {
    reply.put_f(SMA_F("ERR "));
    storage::detail::put_word(reply, detail::command_words(), c.row);
    reply.put_f(SMA_F(": "));
    reply.put_f(why);
    return false;
  }
  reply.put_f(SMA_F("OK "));
  if (c.props & kEndsTraining) s.training = false;
  // `OK <command> [<keyword>]` from the table (mode pid, tele on, traj run ...), then the values.
  if (c.op != Op::Help) {
    storage::detail::put_word(reply, detail::command_words(), c.row);
    if (detail::has_sub(c.row)) {
      reply.put(' ');
      storage::detail::put_word(reply, detail::command_subs(), c.row);
    }
  }
  switch (c.op) {
    case Op::Train:
      s.training = true;
      s.mode = Mode::OpenLoop;
      s.volt = 0.0;
      s.heat = true;
      break;
    case Op::Pos:
    case Op::Step:
    case Op::Sine:
    case Op::TrajRun:
      if (c.op == Op::Pos) {
        s.run_kind = RefKind::Constant;
        s.pos_mm = c.a;
      } else {
        s.run_kind = c.op == Op::Step ? RefKind::MultiStep
                     : c.op == Op::Sine ? RefKind::Sine : RefKind::Trajectory;
      }
      if (s.mode == Mode::OpenLoop) s.mode = Mode::FeedforwardPid;  // a reference needs a loop
      s.heat = true;
      ++s.run;
      reply.put(' ');
      if (c.op == Op::Pos) {
        reply.put_fixed(c.a, 4);
        reply.put(' ');
      } else if (c.op == Op::TrajRun) {
        reply.put_fixed(s.traj.duration(), 2);
        reply.put_f(SMA_F(" s "));
      }
      reply.put_f(mode_name_f(s.mode));
      break;
    case Op::TrajClear:
      s.traj.n_points = 0;  // (no Reference temporary: 185 B of stack on AVR)
      break;
    case Op::SetMode:
      s.mode = c.mode;
      if (!s.heat) reply.put_f(SMA_F(" (heater off)"));
      break;
    case Op::Volt:
      s.volt = c.a;
      s.mode = Mode::OpenLoop;
      s.heat = true;
      reply.put(' ');
      reply.put_fixed(c.a, 4);
      reply.put_f(SMA_F(" open"));
      break;
    case Op::Gains: {
      PidGains& g = s.mode == Mode::Pid ? s.gains_pid : s.gains_ffpid;
      g.kp = c.a;
      g.ki = c.b;
      g.kd = c.c;
      reply.put_f(s.mode == Mode::Pid ? SMA_F(" pid") : SMA_F(" ffpid"));
      for (uint8_t k = 0; k < 3; ++k) {
        reply.put(' ');
        reply.put_fixed(k == 0 ? c.a : k == 1 ? c.b : c.c, 4);
      }
      break;
    }
    case Op::Tlim:
      s.tlim_C = c.a;
      reply.put(' ');
      reply.put_fixed(c.a, 1);
      break;
    case Op::Tele: s.tele = c.on; break;
    case Op::Stop: s.heat = false; break;
    case Op::Help:
      {
        Limits lim;
        lim.model = (c.key & kModelCmd) != 0;
        lim.train = (c.key & kTrainCmd) != 0;
        put_help(reply, lim);
      }
      break;
    default: break;
  }
  return true;
}

// parse + apply. Returns true for OK (or an empty line: reply empty), false for ERR.
inline bool execute(const char* line, State& s, Fault fault, Reply& reply,
                    const Limits& lim = Limits(), Command* parsed = nullptr) {
  Command c;
  if (!parse(line, c, reply, lim)) return false;
  if (parsed) *parsed = c;
  return apply(c, s, fault, reply);
}

// Live values for `status`.
struct Live {
  uint32_t ticks = 0;     // since boot
  // (t_ref_s .. temp_C consecutive: status_line() reads them in a loop)
  double t_ref_s = 0.0;   // time in the running reference
  double d_mm = 0.0, ref_mm = 0.0, v = 0.0, temp_C = 0.0;
  Fault fault = Fault::None;
  uint16_t dropped = 0;   // replies or rows dropped for lack of serial buffer
  uint16_t overruns = 0;  // ticks lost because the previous one was still running
};

static_assert(offsetof(Live, temp_C) == offsetof(Live, t_ref_s) + 4 * sizeof(double), "Live: t_ref_s..temp_C consecutive");

// `OK status <mode> <ref kind> t=<s> d=<mm> r=<mm> V=<V> T=<C> tlim=<C> fault=<name> drop=<n> ovr=<n>`
inline void status_line(Reply& r, const State& s, const Live& l) {
  r.clear();
  r.put_f(SMA_F("OK status "));
  r.put_f(mode_name_f(s.active_mode()));
  r.put(' ');
  switch (s.training ? RefKind::Constant : s.run_kind) {
    case RefKind::MultiStep: r.put_f(SMA_F("step")); break;
    case RefKind::Sine: r.put_f(SMA_F("sine")); break;
    case RefKind::Trajectory: r.put_f(SMA_F("traj")); break;
    default: r.put_f(s.training ? SMA_F("train") : SMA_F("pos")); break;
  }
  // t d r V T: Live's consecutive values t_ref_s .. temp_C, with 2 4 4 3 1 decimals; then tlim.
  const double* value = &l.t_ref_s;
  for (uint8_t k = 0; k < 6; ++k) {
    r.put(' ');
    storage::detail::put_word(r, SMA_F("t d r V T tlim"), k);
    r.put('=');
    r.put_fixed(k < 5 ? value[k] : s.tlim_C, static_cast<uint8_t>(flash_char(SMA_F("244310") + k) - '0'));
  }
  r.put_f(SMA_F(" fault="));
  r.put_f(fault_name(l.fault));
  r.put_f(SMA_F(" drop="));
  r.put_u(l.dropped);
  r.put_f(SMA_F(" ovr="));
  r.put_u(l.overruns);
}

// ---- model commands (pbegin pset pget pcommit pabort pinfo) on a storage::Store -----------------
// `scratch`/`fxs`: a Params/Effects the command may use. When the store has no active set
// (st.active() < 0) they must hold the defaults (sma::Params(), sma::Effects()) for pbegin and
// pget; pcommit overwrites them with the staged set. Returns true when pcommit made a new set
// active (then in scratch/fxs): the caller rebuilds its controller from it.
inline void pinfo_line(Reply& r, const char* head_f, int8_t active, int8_t staging, uint8_t seq,
                       uint16_t crc) {
  r.clear();
  r.put_f(head_f);
  r.put_u(storage::kVersion);
  if (active < 0) {
    r.put_f(SMA_F(" defaults"));
  } else {
    r.put_f(SMA_F(" slot "));
    r.put_u(static_cast<uint8_t>(active));
    r.put_f(SMA_F(" seq "));
    r.put_u(seq);
    r.put_f(SMA_F(" crc "));
    r.put_hex(crc, 4);
  }
  if (staging >= 0) {
    r.put_f(SMA_F(" staging "));
    r.put_u(static_cast<uint8_t>(staging));
  }
}

template <class E>
inline bool model_command(const Command& c, storage::Store<E>& st, Params& scratch, Effects& fxs,
                          Reply& r) {
  return model_command(c, st, scratch, fxs, r, storage::CheckValidator());
}
// With a validator (storage.hpp): the firmware's builds its controller from the set.
template <class E, class V>
inline bool model_command(const Command& c, storage::Store<E>& st, Params& scratch, Effects& fxs,
                          Reply& r, const V& valid) {
  r.clear();
  switch (c.op) {
    case Op::PInfo:
      pinfo_line(r, SMA_F("OK pinfo v"), st.active(), st.staging(), st.seq(), st.crc());
      return false;
    case Op::PAbort:
      st.abort();
      r.put_f(SMA_F("OK pabort"));
      return false;
    case Op::PBegin:
      if (st.active() < 0) st.begin_from(scratch, fxs);
      else st.begin_copy();
      r.put_f(SMA_F("OK pbegin slot "));
      r.put_u(static_cast<uint8_t>(st.staging()));
      return false;
    case Op::PSet:
      if (st.staging() < 0) {
        r.put_f(SMA_F("ERR pset: no staged set, send pbegin"));
        return false;
      }
      st.set_value(c.key, c.a);
      r.put_f(SMA_F("OK pset "));
      storage::put_key_name(r, c.key);
      r.put(' ');  // the bits as written, read back from the EEPROM
      r.put_hex(st.read_bits(static_cast<uint8_t>(st.staging()), c.key), c.key == storage::kKeyLoops ? 2 : 8);
      return false;
    case Op::PGet: {
      double v;
      uint32_t bits;
      if (st.active() >= 0) {
        v = st.read_value(static_cast<uint8_t>(st.active()), c.key);
        bits = st.read_bits(static_cast<uint8_t>(st.active()), c.key);
      } else {
        v = storage::get_value(scratch, fxs, c.key);
        if (c.key != storage::kKeyLoops) v = storage::bits_float(storage::float_bits(v));
        bits = c.key == storage::kKeyLoops ? static_cast<uint32_t>(v) : storage::float_bits(v);
      }
      r.put_f(SMA_F("OK pget "));
      storage::put_key_name(r, c.key);
      r.put(' ');
      r.put_num(v);
      r.put(' ');
      r.put_hex(bits, c.key == storage::kKeyLoops ? 2 : 8);
      return false;
    }
    case Op::PCommit: {
      if (st.staging() < 0) {
        r.put_f(SMA_F("ERR pcommit: no staged set, send pbegin"));
        return false;
      }
      uint8_t bad = storage::kNoKey;
      const char* msg = st.commit(scratch, fxs, bad, valid);
      if (msg) {
        // `ERR <key>: <why>`: the check() message starts with its key (Effects: the parameter).
        // Without a key (AVR): `ERR pcommit: <message>`.
        r.put_f(SMA_F("ERR "));
        uint8_t n = 0;
        if (bad != storage::kNoKey) {
          storage::put_key_name(r, bad);
          while (flash_char(msg + n) != 0 && flash_char(msg + n) != ' ' && flash_char(msg + n) != ':') ++n;
          while (flash_char(msg + n) == ' ' || flash_char(msg + n) == ':') ++n;
        } else {
          r.put_f(SMA_F("pcommit"));
        }
        r.put_f(SMA_F(": "));
        r.put_f(msg + n);
        return false;
      }
      pinfo_line(r, SMA_F("OK pcommit v"), st.active(), st.staging(), st.seq(), st.crc());
      return true;
    }
    default: return false;
  }
}

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_HPP
