// The command table and the parser built on it (numbers, keywords, help, errors).
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_PARSE_HPP
#define SMA_CONSOLE_PARSE_HPP

#include "../storage.hpp"
#include "line_buffer.hpp"
#include "reply.hpp"
#include "state.hpp"
#include "../trunc_u32.hpp"

namespace sma {
namespace console {

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
// the Op, a value (the Mode of `mode`, off/on/plot of `tele`), properties and up to three numbers.
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
  kSameWord = 128,    // the same command word as the row before (another keyword of it)
};
// The numbers: name (in the errors) and range. The upper bounds of mm and V are the Limits'
// (the stroke g_mm, v_max: arg_bound()), marked -1 and -2 in the table.
enum Arg : uint8_t { kNoArg, kArgMm, kArgV, kArgKp, kArgKi, kArgKd, kArgDegC, kArgTs, kArgSlope, kArgValue, kArgF, kArgW };
namespace detail {
#if SMA_CONSOLE_PREVIEW
inline const char* arg_names() { return SMA_F("- mm V kp ki kd degC t_s slope value F W"); }
#else
inline const char* arg_names() { return SMA_F("- mm V kp ki kd degC t_s slope value F"); }
#endif
static SMA_STORAGE_TABLE double kArgRange[][2] = {
    {0, 0}, {0, -1}, {0, -2}, {0, 999}, {0, 999}, {0, 999}, {30, 150}, {0, kTrajMaxS}, {0.0001, 1}, {0, 0}, {0, 2},
#if SMA_CONSOLE_PREVIEW
    {0, 100},
#endif
};
#if SMA_CONSOLE_PREVIEW
#define SMA_PREVIEW_WORD "mode "
#define SMA_PREVIEW_SUB "preview "
#define SMA_COOL_WORD "cool "
#define SMA_COOL_SUB "- "
#else
#define SMA_PREVIEW_WORD
#define SMA_PREVIEW_SUB
#define SMA_COOL_WORD
#define SMA_COOL_SUB
#endif
#if SMA_CONSOLE_LEAD
#define SMA_LEAD_WORD "lead "
#define SMA_LEAD_SUB "- "
#else
#define SMA_LEAD_WORD
#define SMA_LEAD_SUB
#endif
inline const char* command_words() {
  return SMA_F("pos step sine traj traj traj mode mode mode mode " SMA_PREVIEW_WORD "volt gains tlim tele tele tele status stop help "
               "train " SMA_COOL_WORD SMA_LEAD_WORD "pbegin pset pget pcommit pabort pinfo");
}
inline const char* command_subs() {
  return SMA_F("- - - clear run - open pid ff ffpid " SMA_PREVIEW_SUB "- - - on off plot - - - - " SMA_COOL_SUB SMA_LEAD_SUB "- - - - - -");
}
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
    {Op::TrajRun, 0, kEnds | kSameWord, {0, 0, 0}},
    {Op::TrajPoint, 0, kSameWord, {kArgTs, kArgMm, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::OpenLoop), kEndsTraining, {0, 0, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::Pid), kEndsTraining | kSameWord, {0, 0, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::Feedforward), kEndsTraining | kSameWord, {0, 0, 0}},
    {Op::SetMode, static_cast<uint8_t>(Mode::FeedforwardPid), kEndsTraining | kSameWord, {0, 0, 0}},
#if SMA_CONSOLE_PREVIEW
    {Op::SetMode, static_cast<uint8_t>(Mode::Preview), kEndsTraining | kSameWord, {0, 0, 0}},
#endif
    {Op::Volt, 0, kEnds, {kArgV, 0, 0}},
    {Op::Gains, 0, 0, {kArgKp, kArgKi, kArgKd}},
    {Op::Tlim, 0, 0, {kArgDegC, 0, 0}},
    {Op::Tele, 1, 0, {0, 0, 0}},
    {Op::Tele, 0, kSameWord, {0, 0, 0}},
    {Op::Tele, kTelePlot, kSameWord, {0, 0, 0}},
    {Op::Status, 0, 0, {0, 0, 0}},
    {Op::Stop, 0, kEndsTraining, {0, 0, 0}},
    {Op::Help, 0, 0, {0, 0, 0}},
    {Op::Train, 0, kHeats | kTrainCmd | kOptional, {kArgSlope, 0, 0}},
#if SMA_CONSOLE_PREVIEW
    {Op::Cool, 0, 0, {kArgW, 0, 0}},
#endif
#if SMA_CONSOLE_LEAD
    {Op::Lead, 0, 0, {kArgF, 0, 0}},
#endif
    {Op::PBegin, 0, kModelCmd | kCold, {0, 0, 0}},
    {Op::PSet, 0, kModelCmd | kCold | kKeyed, {kArgValue, 0, 0}},
    {Op::PGet, 0, kModelCmd | kKeyed, {0, 0, 0}},
    {Op::PCommit, 0, kModelCmd | kCold, {0, 0, 0}},
    {Op::PAbort, 0, kModelCmd, {0, 0, 0}},
    {Op::PInfo, 0, kModelCmd, {0, 0, 0}},
};
constexpr uint8_t kCommandCount = sizeof(kCommandRows) / sizeof(kCommandRows[0]);

// Row r of the table into `row` (by reference: a 6-byte struct returned in registers cost ~15 B
// of moves at every call on the AVR).
SMA_TABLE_NOINLINE inline void command_row(uint8_t r, CommandRow& row) {
#if defined(__AVR__)
  memcpy_P(&row, &kCommandRows[r], sizeof(CommandRow));
#else
  row = kCommandRows[r];
#endif
}
inline uint8_t row_props(uint8_t r) {
  CommandRow row;
  command_row(r, row);
  return row.props;
}
inline double arg_bound(uint8_t arg, uint8_t hi, const Limits& lim) {
  // (The two limits by their argument, not by the table's -1/-2: byte compares, not float ones.)
  if (hi && arg == kArgMm) return lim.g_mm;
  if (hi && arg == kArgV) return lim.v_max;
#if defined(__AVR__)
  return pgm_read_float(&kArgRange[arg][hi]);
#else
  return kArgRange[arg][hi];
#endif
}
// Does row r exist in this build?
// (The preview's rows, `mode preview` and `cool`, by their Op: no property bit is left.)
inline bool row_exists(const CommandRow& row, const Limits& lim) {
#if SMA_CONSOLE_PREVIEW
  const bool preview_row = row.op == Op::Cool || (row.op == Op::SetMode && row.value == static_cast<uint8_t>(Mode::Preview));
  if (preview_row && !lim.preview) return false;
#endif
  return !((row.props & kModelCmd) && !lim.model) && !((row.props & kTrainCmd) && !lim.train);
}
inline bool row_exists(uint8_t r, const Limits& lim) {
  CommandRow row;
  command_row(r, row);
  return row_exists(row, lim);
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
inline bool has_sub(uint8_t r) { return !word_is(command_subs(), r, "-", 1); }
}  // namespace detail

// `help`: the words of the commands of this build, '|'-separated; a command that takes one
// number shows its unit (pos mm). One pass over the word and keyword lists: a lookup per row
// scanned the flash lists ~100 times, ~8 ms on the Uno, longer than a reply's slot before a tick.
inline void put_help(Reply& reply, const Limits& lim) {
  using namespace detail;
  const char* w = command_words();  // word of row r
  const char* s = command_subs();   // keyword of row r
  bool first = true;
  for (uint8_t r = 0; r < kCommandCount; ++r) {
    CommandRow row;
    command_row(r, row);
    const bool sub = flash_char(s) != '-';
    if (row_exists(row, lim) && !(row.props & kSameWord)) {
      if (!first) reply.put('|');
      first = false;
      storage::detail::put_word(reply, w, 0);
      if (row.args[0] != kNoArg && row.args[1] == kNoArg && !(row.props & (kKeyed | kOptional)) && !sub) {
        reply.put(' ');
        storage::detail::put_word(reply, arg_names(), row.args[0]);
      }
    }
    // Next words (the last row's step lands one past the lists' ends; nothing reads there).
    while (flash_char(w) != ' ' && flash_char(w) != 0) ++w;
    ++w;
    while (flash_char(s) != ' ' && flash_char(s) != 0) ++s;
    ++s;
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
  while (r < kCommandCount && !(row_exists(r, lim) && word_is(command_words(), r, t0, len0))) ++r;
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
  while (last + 1 < kCommandCount && (row_props(static_cast<uint8_t>(last + 1)) & kSameWord)) ++last;
  if (last > first) {  // keywords: `mode open`, `tele on`, `traj clear` ...
    r = first;
    while (r <= last && has_sub(r) && !word_is(command_subs(), r, tok, len)) ++r;
    // (A keyword row that does not exist in this build is not a keyword: `mode preview`.)
    if (r > last || (len == 0 && !has_sub(r)) || (SMA_CONSOLE_PREVIEW && !row_exists(r, lim))) {
      // "expected a, b or <t_s> <mm>"
      while (SMA_CONSOLE_PREVIEW && !row_exists(last, lim)) --last;  // (the word's first row exists)
      err_head();
      reply.put_f(SMA_F("expected "));
      for (uint8_t k = first; k <= last; ++k) {
        if (SMA_CONSOLE_PREVIEW && !row_exists(k, lim)) continue;
        if (k > first) reply.put_f(k == last ? SMA_F(" or ") : SMA_F(", "));
        if (has_sub(k)) {
          storage::detail::put_word(reply, command_subs(), k);
          continue;
        }
        CommandRow row;
        command_row(k, row);
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
  CommandRow row;
  command_row(r, row);
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
                         v[k] == static_cast<double>(static_cast<uint8_t>(trunc_u32(v[k])));
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
  if (c.op == Op::Help) {
    c.key = static_cast<uint8_t>((lim.model ? kModelCmd : 0) | (lim.train ? kTrainCmd : 0));
#if SMA_CONSOLE_PREVIEW
    c.on = lim.preview;
#endif
  }
  cmd = c;
  return true;
}

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_PARSE_HPP
