// One parameter table: every key of the model (sma::Params, sma::Effects) is listed once, here.
//
// Everything that names, bounds, stores or validates a key comes from these rows:
//   - Params::check() / Effects::check() (param_table_access.hpp): each value in its row's range
//     [lo, hi], the orderings of the transformation temperatures (`above`), the loop rules; they
//     return a Violation (key id + rule), whose message is built from the rows (put_violation);
//   - the board's flat keys (storage.hpp: EEPROM layout, pset/pget names and ranges): the rows in
//     order, `m` expanded to m0..m5, the knot rows to loop<i>.T_i|T_ii|j (i = 0..7, interleaved),
//     `loops` the number of loops; the order is the EEPROM layout of existing boards (pinned by
//     the static_asserts in storage.hpp and by test_storage);
//   - the host's params JSON reader and writer (interfaces.md; sma_tools/params_json.hpp): a
//     name "<group>.<field>" is field <field> of effect <group> under "effects", a plain name a
//     top-level key, `m` the list m0..m5, the knot rows the fields of each "loops" entry;
//   - the fit's and the discrepancy's parameter names and physical bounds (host/sma_host).
//
// Columns of X(id, name, unit, lo, hi, kind, member, above):
//   id      the row's enumerator (Row::id)
//   name    the key as the board and the params JSON spell it
//   unit    SI, temperatures in degC, g in mm ("1": dimensionless); host only
//   lo, hi  the accepted range, closed; written as they are to be shown in messages
//   kind    Table (Table II scalar), List (m0..m5), Knot (a field of each identified minor
//           loop), Count (the number of loops), Effect (a parameter of the effects vocabulary)
//   member  the field of Params (Effects for kind Effect) holding the value (instance 0)
//   above   the row whose value this one must exceed (eqs 2, 3, 7), or none
//
// The Table II ranges hold every wire the project has seen with margin (a NiTi wire's
// temperatures -100..400 degC, d0 1 um..10 mm); the effects' are the physical ones of effects.hpp.
// Header only, AVR-safe: the rows become flash tables on AVR (param_table_access.hpp).
#ifndef SMA_PARAM_TABLE_HPP
#define SMA_PARAM_TABLE_HPP

#include <stdint.h>

// clang-format off
#define SMA_PARAM_TABLE(X) \
  X(rho,    "rho",    "kg/m^3",     100,   1e5,   Table, rho,    none) \
  X(c,      "c",      "J/(kg*K)",   10,    1e4,   Table, c,      none) \
  X(h,      "h",      "W/(m^2*K)",  0.01,  1e5,   Table, h,      none) \
  X(d0,     "d0",     "m",          1e-6,  0.01,  Table, d0,     none) \
  X(L0,     "L0",     "m",          0.001, 10,    Table, L0,     none) \
  X(R,      "R",      "ohm",        0.001, 1000,  Table, R,      none) \
  X(T_amb,  "T_amb",  "degC",       -50,   100,   Table, T_amb,  none) \
  X(T_AS,   "T_AS",   "degC",       -100,  400,   Table, T_AS,   none) \
  X(T_AF,   "T_AF",   "degC",       -100,  400,   Table, T_AF,   T_AS) \
  X(T_MS,   "T_MS",   "degC",       -100,  400,   Table, T_MS,   T_MF) \
  X(T_MF,   "T_MF",   "degC",       -100,  400,   Table, T_MF,   none) \
  X(T_s,    "T_s",    "degC",       -100,  400,   Table, T_s,    none) \
  X(T_f,    "T_f",    "degC",       -100,  400,   Table, T_f,    T_s)  \
  X(T_MSs,  "T_MSs",  "degC",       -100,  400,   Table, T_MSs,  none) \
  X(T_MSf,  "T_MSf",  "degC",       -100,  400,   Table, T_MSf,  none) \
  X(q,      "q",      "degC",       -1e5,  1e5,   Table, q,      none) \
  X(e,      "e",      "degC",       -1e5,  1e5,   Table, e,      none) \
  X(g,      "g",      "mm",         0.001, 100,   Table, g,      none) \
  X(m,      "m",      "1",          -1e5,  1e5,   List,  m[0],   none) \
  X(loop_T_i,  "T_i",  "degC",      -100,  400,   Knot,  loops[0].T_i,  none) \
  X(loop_T_ii, "T_ii", "degC",      -100,  400,   Knot,  loops[0].T_ii, none) \
  X(loop_j,    "j",    "1",         0,     1,     Knot,  loops[0].j,    none) \
  X(delay_s,     "sensor_delay.delay_s",             "s",   0,    5,    Effect, sensor_delay_s,          none) \
  X(tau_s,       "sensor_lag.tau_s",                 "s",   0,    5,    Effect, sensor_lag_s,            none) \
  X(gain,        "sensor_calibration.gain",          "1",   0.2,  5,    Effect, sensor_gain,             none) \
  X(offset_mm,   "sensor_calibration.offset_mm",     "mm",  -100, 100,  Effect, sensor_offset_mm,        none) \
  X(offset_K,    "ambient_offset.offset_K",          "K",   -50,  50,   Effect, ambient_offset_K,        none) \
  X(beta_per_K,  "convection_nonlinear.beta_per_K",  "1/K", 0,    0.1,  Effect, convection_beta_per_K,   none) \
  X(k_R,         "resistance_phase.k_R",             "1",   -0.9, 2,    Effect, resistance_k,            none) \
  X(L_J,         "latent_heat.L_J",                  "J",   0,    100,  Effect, latent_heat_J,           none) \
  X(loops,       "loops",                            "1",   0,    8,    Count,  n_loops,                 none) \
  X(alpha_per_K, "thermal_expansion.alpha_per_K",    "1/K", 0,    1e-4, Effect, thermal_expansion_per_K, none)
// clang-format on

namespace sma {
namespace param {

#define SMA_PARAM_ROW_ID(id, name, unit, lo, hi, kind, member, above) id,
enum class Row : uint8_t { SMA_PARAM_TABLE(SMA_PARAM_ROW_ID) count, none = 255 };
#undef SMA_PARAM_ROW_ID

enum class Kind : uint8_t { Table, List, Knot, Count, Effect };

constexpr uint8_t kNoKey = 255;
constexpr uint8_t kListSize = 6;   // m0..m5 (eq 8)
constexpr uint8_t kKnots = 8;      // sma::kMaxLoopKnots
constexpr uint8_t kKnotFields = 3; // T_i, T_ii, j of one loop (sma::LoopKnot)

// Flat keys a row stands for: a List its coefficients; the knot rows together kKnots x
// kKnotFields, interleaved by loop (loop0.T_i loop0.T_ii loop0.j loop1.T_i ...): each counts
// kKnots here and key_of() interleaves them.
constexpr uint8_t width(Kind k) { return k == Kind::List ? kListSize : k == Kind::Knot ? kKnots : 1; }

#define SMA_PARAM_ROW_KIND(id, name, unit, lo, hi, kind, member, above) Kind::kind,
// The first flat key of row r (compile time only: the firmware reads the flash rows instead).
constexpr uint8_t first_key(Row r) {
  const Kind kinds[] = {SMA_PARAM_TABLE(SMA_PARAM_ROW_KIND)};
  uint8_t k = 0;
  for (uint8_t i = 0; i < static_cast<uint8_t>(r); ++i) k = static_cast<uint8_t>(k + width(kinds[i]));
  return k;
}
#undef SMA_PARAM_ROW_KIND

constexpr uint8_t kKeys = first_key(Row::count);  // every flat key (the board stores the first ones)

// What check() found: the flat key a set breaks and the rule; a set that breaks none is ok.
enum class Rule : uint8_t {
  none,
  range,       // outside its row's [lo, hi]
  above,       // not above its row's `above`
  loop_order,  // (key loops) the loops' T_i do not increase strictly inside (T_s, T_f)
  loop_below,  // (key loops) a loop's T_ii is above its T_i
};
struct Violation {
  uint8_t key = kNoKey;
  Rule rule = Rule::none;
  bool ok() const { return rule == Rule::none; }
  explicit operator bool() const { return !ok(); }  // true: the set breaks a rule
  // `check() == nullptr` reads as before: no rule broken.
  friend bool operator==(Violation v, decltype(nullptr)) { return v.ok(); }
  friend bool operator!=(Violation v, decltype(nullptr)) { return !v.ok(); }
};

}  // namespace param
}  // namespace sma

#endif  // SMA_PARAM_TABLE_HPP
