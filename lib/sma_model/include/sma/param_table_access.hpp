// What comes from the parameter table (param_table.hpp) on the firmware and the host alike: the
// flat keys (names, ranges, where their value lives), Params::check() and Effects::check(), and
// the messages of what they find. AVR: the rows and names are flash tables (safety.hpp's SMA_F,
// flash_char), nothing here allocates.
#ifndef SMA_PARAM_TABLE_ACCESS_HPP
#define SMA_PARAM_TABLE_ACCESS_HPP

#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "codegen.hpp"
#include "effects.hpp"
#include "param_table.hpp"
#include "params.hpp"
#include "safety.hpp"  // SMA_F, flash_char

// Tables that stay in flash on AVR.
#if defined(__AVR__)
#define SMA_FLASH_TABLE const PROGMEM
#else
#define SMA_FLASH_TABLE const
#endif

// One copy of the row reads and the checks, called where the models are built and from the
// console: inlined, each call site had its own (AVR: -300 B of flash, and the checks' locals off
// the frame of Board::construct, the deepest stack: +11 B of stack margin).
#if defined(__AVR__)
#define SMA_TABLE_NOINLINE __attribute__((noinline))
#else
#define SMA_TABLE_NOINLINE
#endif
// Params::check() with the register allocator's default (Chaitin-Briggs) colouring in the Q16.16
// Uno image (codegen.hpp): there it is 534 B with priority colouring, 474 B without.

namespace sma {
namespace param {

// ---- the rows as data ------------------------------------------------------------------------
struct RowInfo {
  double lo, hi;   // the accepted range (a float on AVR)
  uint8_t slot;    // the member's position among the doubles of its owner (Params, Effects)
  Kind kind;
  Row above;
};

namespace detail {
// Position, in doubles, of a member in its owner: Effects for an effect, else Params.
#define SMA_PARAM_OWNER_Table Params
#define SMA_PARAM_OWNER_List Params
#define SMA_PARAM_OWNER_Knot Params
#define SMA_PARAM_OWNER_Count Params
#define SMA_PARAM_OWNER_Effect Effects
#define SMA_PARAM_ROW_INFO(id, name, unit, lo, hi, kind, member, above)                        \
  {lo, hi,                                                                                        \
   static_cast<uint8_t>(Kind::kind == Kind::Count ? 255                                           \
                                                  : offsetof(SMA_PARAM_OWNER_##kind, member) / sizeof(double)), \
   Kind::kind, Row::above},
static SMA_FLASH_TABLE RowInfo kRows[] = {SMA_PARAM_TABLE(SMA_PARAM_ROW_INFO)};
#undef SMA_PARAM_ROW_INFO

// The names, one word each, in row order (a flash string on AVR).
#define SMA_PARAM_ROW_NAME(id, name, unit, lo, hi, kind, member, above) name " "
inline const char* names() { return SMA_F(SMA_PARAM_TABLE(SMA_PARAM_ROW_NAME)); }
#undef SMA_PARAM_ROW_NAME
// The ranges as written in the table ("0.2..5"), one word each.
#define SMA_PARAM_ROW_RANGE(id, name, unit, lo, hi, kind, member, above) #lo ".." #hi " "
inline const char* ranges() { return SMA_F(SMA_PARAM_TABLE(SMA_PARAM_ROW_RANGE)); }
#undef SMA_PARAM_ROW_RANGE

static_assert(sizeof(kRows) / sizeof(kRows[0]) == static_cast<uint8_t>(Row::count), "one info per row");
static_assert(offsetof(Params, loops[0].T_ii) == offsetof(Params, loops[0].T_i) + sizeof(double) &&
                  offsetof(Params, loops[0].j) == offsetof(Params, loops[0].T_i) + 2 * sizeof(double) &&
                  sizeof(LoopKnot) == kKnotFields * sizeof(double) && kMaxLoopKnots == kKnots,
              "the knot rows are the fields of LoopKnot, in order");
static_assert(static_cast<uint8_t>(Row::loop_T_ii) == static_cast<uint8_t>(Row::loop_T_i) + 1 &&
                  static_cast<uint8_t>(Row::loop_j) == static_cast<uint8_t>(Row::loop_T_i) + 2,
              "the knot rows are consecutive");
static_assert(sizeof(Params::m) == kListSize * sizeof(double), "m is the list m0..m5");
}  // namespace detail

SMA_TABLE_NOINLINE inline RowInfo row(uint8_t r) {
  RowInfo i;
#if defined(__AVR__)
  memcpy_P(&i, &detail::kRows[r], sizeof(RowInfo));
#else
  i = detail::kRows[r];
#endif
  return i;
}
inline RowInfo row(Row r) { return row(static_cast<uint8_t>(r)); }

// ---- words of a space-separated flash list ------------------------------------------------------
// Index of tok[0..len) in the list, or kNoKey.
inline uint8_t find_word(const char* list_f, const char* tok, uint8_t len) {
  uint8_t idx = 0, k = 0;
  bool match = true;
  for (const char* p = list_f;; ++p) {
    const char c = flash_char(p);
    if (c == ' ' || c == 0) {
      if (match && k == len) return idx;
      if (c == 0) return kNoKey;
      ++idx;
      k = 0;
      match = true;
    } else {
      if (k >= len || c != tok[k]) match = false;
      if (k < 255) ++k;
    }
  }
}
// The start of word n of the list.
inline const char* word(const char* list_f, uint8_t n) {
  const char* p = list_f;
  for (; n > 0; ++p)
    if (flash_char(p) == ' ') --n;
  return p;
}
// Writes word n of a flash list to o (anything with put(char)); from its dot on: `after_dot`.
template <class Out>
inline void put_word(Out& o, const char* list_f, uint8_t n, bool after_dot = false) {
  const char* p = word(list_f, n);
  if (after_dot) {
    const char* q = p;
    while (flash_char(q) != ' ' && flash_char(q) != 0 && flash_char(q) != '.') ++q;
    if (flash_char(q) == '.') p = q + 1;
  }
  for (char c; (c = flash_char(p)) != ' ' && c != 0; ++p) o.put(c);
}
template <class Out>
inline void put_f(Out& o, const char* s_f) {
  for (char c; (c = flash_char(s_f)) != 0; ++s_f) o.put(c);
}

// ---- flat keys -------------------------------------------------------------------------------
// The row of flat key k and which instance of it (m<i>, loop<i>); row = Row::count if none.
struct Place {
  uint8_t row;
  uint8_t index;
};
inline Place locate(uint8_t k) {
  for (uint8_t r = 0; r < static_cast<uint8_t>(Row::count); ++r) {
    const Kind kind = row(r).kind;
    if (kind == Kind::Knot) {
      if (k < kKnots * kKnotFields) return {static_cast<uint8_t>(r + k % kKnotFields), static_cast<uint8_t>(k / kKnotFields)};
      k = static_cast<uint8_t>(k - kKnots * kKnotFields);
      r = static_cast<uint8_t>(r + kKnotFields - 1);
      continue;
    }
    const uint8_t w = width(kind);
    if (k < w) return {r, k};
    k = static_cast<uint8_t>(k - w);
  }
  return {static_cast<uint8_t>(Row::count), 0};
}
// The flat key of instance i of row R (a template: the firmware gets a constant, never the
// row walk of first_key()).
template <Row R>
constexpr uint8_t key_of(uint8_t i = 0) {
  constexpr bool knot = R == Row::loop_T_i || R == Row::loop_T_ii || R == Row::loop_j;
  constexpr uint8_t base = knot ? static_cast<uint8_t>(first_key(Row::loop_T_i) + static_cast<uint8_t>(R) -
                                                       static_cast<uint8_t>(Row::loop_T_i))
                                : first_key(R);
  return static_cast<uint8_t>(base + (knot ? kKnotFields * i : i));
}

// Writes the name of flat key k: rho, m3, loop2.T_ii, sensor_delay.delay_s, loops ...
template <class Out>
inline void put_key_name(Out& o, uint8_t k) {
  const Place at = locate(k);
  if (at.row >= static_cast<uint8_t>(Row::count)) return;
  const Kind kind = row(at.row).kind;
  if (kind == Kind::Knot) {
    put_f(o, SMA_F("loop"));
    o.put(static_cast<char>('0' + at.index));
    o.put('.');
  }
  put_word(o, detail::names(), at.row);
  if (kind == Kind::List) o.put(static_cast<char>('0' + at.index));
}

// Whether the flash word w (n characters) is tok[0..len).
inline bool same_word(const char* w, uint8_t n, const char* tok, uint8_t len) {
  if (n != len) return false;
  for (uint8_t i = 0; i < len; ++i)
    if (flash_char(w + i) != tok[i]) return false;
  return true;
}

// Flat key of a name, or kNoKey: a row's name; m<i> (a List row); loop<i>.<field> (a Knot row);
// an effect's parameter alone too (each is unique): a long key plus a precise value would not
// fit a 47-character console line.
// (Always inlined: its one call on the firmware, the console's parser, then goes with the model
// commands where an image has none.)
__attribute__((always_inline)) inline uint8_t key_index(const char* tok, uint8_t len) {
  const bool loop = len > 6 && tok[0] == 'l' && tok[1] == 'o' && tok[2] == 'o' && tok[3] == 'p' &&
                    tok[4] >= '0' && tok[4] < '0' + kKnots && tok[5] == '.';
  const uint8_t last = len > 0 ? static_cast<uint8_t>(tok[len - 1] - '0') : 255;
  uint8_t key = 0;
  const char* w = detail::names();
  for (uint8_t r = 0; r < static_cast<uint8_t>(Row::count); ++r) {
    const Kind kind = row(r).kind;
    uint8_t n = 0, dot = 0;
    for (char c; (c = flash_char(w + n)) != ' ' && c != 0; ++n)
      if (c == '.') dot = static_cast<uint8_t>(n + 1);
    if (kind == Kind::Knot) {
      if (loop && same_word(w, n, tok + 6, static_cast<uint8_t>(len - 6)))
        return static_cast<uint8_t>(key_of<Row::loop_T_i>(static_cast<uint8_t>(tok[4] - '0')) + r -
                                    static_cast<uint8_t>(Row::loop_T_i));
    } else if (kind == Kind::List) {
      if (last < kListSize && same_word(w, n, tok, static_cast<uint8_t>(len - 1))) return static_cast<uint8_t>(key + last);
    } else if (same_word(w, n, tok, len) ||
               (kind == Kind::Effect && dot > 0 && same_word(w + dot, static_cast<uint8_t>(n - dot), tok, len))) {
      return key;
    }
    key = static_cast<uint8_t>(key + width(kind));
    w += n + 1;
  }
  return kNoKey;
}

// The accepted range of flat key k.
inline void key_range(uint8_t k, double& lo, double& hi) {
  const Place at = locate(k);
  const RowInfo i = row(at.row < static_cast<uint8_t>(Row::count) ? at.row : 0);
  lo = i.lo;
  hi = i.hi;
}

// The value of flat key k in (p, fx); nullptr for the loop count (a byte: p.n_loops) or an
// unknown key.
inline double* value_ptr(Params& p, Effects& fx, uint8_t k) {
  const Place at = locate(k);
  if (at.row >= static_cast<uint8_t>(Row::count)) return nullptr;
  const RowInfo i = row(at.row);
  if (i.kind == Kind::Count) return nullptr;
  const uint8_t stride = i.kind == Kind::Knot ? kKnotFields : 1;
  char* base = i.kind == Kind::Effect ? reinterpret_cast<char*>(&fx) : reinterpret_cast<char*>(&p);
  return reinterpret_cast<double*>(base + (i.slot + stride * at.index) * sizeof(double));
}
// ... of an effect's key in fx alone (nullptr for any other key).
inline double* value_ptr(Effects& fx, uint8_t k) {
  const Place at = locate(k);
  if (at.row >= static_cast<uint8_t>(Row::count) || row(at.row).kind != Kind::Effect) return nullptr;
  return reinterpret_cast<double*>(reinterpret_cast<char*>(&fx) + row(at.row).slot * sizeof(double));
}
inline double get_value(const Params& p, const Effects& fx, uint8_t k) {
  if (k == key_of<Row::loops>()) return p.n_loops;
  const double* v = value_ptr(const_cast<Params&>(p), const_cast<Effects&>(fx), k);
  return v ? *v : 0.0;
}
// Value of a row (instance 0) of a Params / an Effects.
inline double value_of(const Params& p, const RowInfo& i) {
  return *reinterpret_cast<const double*>(reinterpret_cast<const char*>(&p) + i.slot * sizeof(double));
}
inline double value_of(const Effects& fx, const RowInfo& i) {
  return *reinterpret_cast<const double*>(reinterpret_cast<const char*>(&fx) + i.slot * sizeof(double));
}

SMA_TABLE_NOINLINE inline bool in_range(const RowInfo& i, double v) { return v >= i.lo && v <= i.hi; }  // false for NaN

// ---- the message of a violation ------------------------------------------------------------------
// "<key>: <rule>", e.g. "T_AF: must be > T_AS", "sensor_calibration.gain: must be in 0.2..5",
// "loops: T_i must increase strictly inside (T_s, T_f)".
template <class Out>
inline void put_violation(Out& o, Violation v) {
  put_key_name(o, v.key);
  put_f(o, SMA_F(": "));
  switch (v.rule) {
    case Rule::range:
      put_f(o, SMA_F("must be in "));
      put_word(o, detail::ranges(), locate(v.key).row);
      break;
    case Rule::above:
      put_f(o, SMA_F("must be > "));
      put_word(o, detail::names(), static_cast<uint8_t>(row(locate(v.key).row).above));
      break;
    case Rule::loop_order: put_f(o, SMA_F("T_i must increase strictly inside (T_s, T_f)")); break;
    case Rule::loop_below: put_f(o, SMA_F("T_ii must be <= T_i")); break;
    default: break;
  }
}

}  // namespace param

// ---- the checks ----------------------------------------------------------------------------------
// Every Table and List row in its range, above its `above`; then the loops (eqs 7-10): at most
// kMaxLoopKnots, their peaks T_i increasing strictly inside (T_s, T_f), each T_ii <= its T_i,
// T_ii and j in their ranges.
SMA_TABLE_NOINLINE SMA_OWN_OPTIONS inline param::Violation Params::check() const {
  using namespace param;
  uint8_t key = 0;
  for (uint8_t r = 0; r < static_cast<uint8_t>(Row::count); ++r) {
    const RowInfo i = row(r);
    const uint8_t w = width(i.kind);
    if (i.kind == Kind::Table || i.kind == Kind::List) {
      for (uint8_t n = 0; n < w; ++n) {
        const uint8_t k = static_cast<uint8_t>(key + n);
        const double v = *reinterpret_cast<const double*>(reinterpret_cast<const char*>(this) + (i.slot + n) * sizeof(double));
        if (!in_range(i, v)) return {k, Rule::range};
        if (i.above != Row::none && !(v > value_of(*this, row(i.above)))) return {k, Rule::above};
      }
    }
    key = static_cast<uint8_t>(key + w);
  }
  constexpr uint8_t kLoops = key_of<Row::loops>();
  if (!in_range(row(Row::loops), n_loops)) return {kLoops, Rule::range};
  const RowInfo ii = row(Row::loop_T_ii), jj = row(Row::loop_j);
  double prev = T_s;
  for (uint8_t k = 0; k < n_loops; ++k) {
    const LoopKnot& L = loops[k];
    if (!(L.T_i > prev) || !(L.T_i < T_f)) return {kLoops, Rule::loop_order};
    if (!in_range(ii, L.T_ii)) return {key_of<Row::loop_T_ii>(k), Rule::range};
    if (L.T_ii > L.T_i) return {kLoops, Rule::loop_below};
    if (!in_range(jj, L.j)) return {key_of<Row::loop_j>(k), Rule::range};
    prev = L.T_i;
  }
  return {};
}

// Every effect row in its range (thermal_expansion only where the model has it).
inline param::Violation Effects::check() const {
  using namespace param;
  uint8_t key = 0;
  for (uint8_t r = 0; r < static_cast<uint8_t>(Row::count); ++r) {
    const RowInfo i = row(r);
    if (i.kind == Kind::Effect && (kThermalExpansion || r != static_cast<uint8_t>(Row::alpha_per_K)) &&
        !in_range(i, value_of(*this, i)))
      return {key, Rule::range};
    key = static_cast<uint8_t>(key + width(i.kind));
  }
  return {};
}

}  // namespace sma

#endif  // SMA_PARAM_TABLE_ACCESS_HPP
