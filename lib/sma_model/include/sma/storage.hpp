// Model parameters (sma::Params + sma::Effects) in EEPROM: two slots, a version, a CRC-16, and a
// one-byte commit mark written last, so that a set is either wholly there or not there at all.
// Pure logic, no STL, no heap, C++14, AVR and host: the EEPROM is a template parameter E with
//   uint8_t read(uint16_t addr) const;   void write(uint16_t addr, uint8_t value);
// (the firmware wraps <avr/eeprom.h>, the tests a byte array that can "lose power").
//
// Slot layout (kSlotSize = 230 bytes, slot s at base + 256 s):
//   [0] magic 0xA5 (the commit mark: written last, cleared first)   [1] version (kVersion)
//   [2] sequence (newer = larger, mod 256)   [3..4] CRC-16/CCITT (LE) of bytes [1..2] + payload
//   [5..] payload: 56 float32 values (LE) in key order (below), then the byte n_loops.
// A slot is valid when magic, version and CRC match and the set passes Params::check() and
// Effects::check(); the newest valid slot is the active set; none valid -> the paper's values
// (sma::Params() / sma::Effects() defaults), the caller builds them.
//
// Writing a new set: begin() clears the magic of the inactive slot and copies the active set
// into it; set_value() writes single values straight into that slot (no second Params in RAM);
// commit() reads the slot back into the caller's scratch Params, validates it, writes version,
// sequence and CRC, then the magic. A power loss anywhere before the last byte leaves the magic
// cleared: the old set stays active (tested at every byte position, test/native/test_storage.cpp).
//
// Keys (the params JSON contract of interfaces.md, flattened), index k:
//   0..17  rho c h d0 L0 R T_amb T_AS T_AF T_MS T_MF T_s T_f T_MSs T_MSf q e g
//   18..23 m0..m5            24..47 loop<i>.T_i, loop<i>.T_ii, loop<i>.j (i = 0..7)
//   48..55 sensor_delay.delay_s sensor_lag.tau_s sensor_calibration.gain
//          sensor_calibration.offset_mm ambient_offset.offset_K convection_nonlinear.beta_per_K
//          resistance_phase.k_R latent_heat.L_J (also accepted: the parameter alone, delay_s ...)
//   56 loops (the number of loops, 0..8)
#ifndef SMA_STORAGE_HPP
#define SMA_STORAGE_HPP

#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "effects.hpp"
#include "params.hpp"
#include "safety.hpp"  // SMA_F, flash_char

namespace sma {
namespace storage {

constexpr uint8_t kVersion = 1;
constexpr uint8_t kMagic = 0xA5;
constexpr uint8_t kFirstM = 18;
constexpr uint8_t kFirstLoop = 24;
constexpr uint8_t kFirstEffect = 48;
constexpr uint8_t kNumValues = 56;  // float32 values
constexpr uint8_t kKeyLoops = 56;   // the byte n_loops
constexpr uint8_t kNumKeys = 57;
constexpr uint8_t kNoKey = 255;
constexpr uint16_t kHeader = 5;
constexpr uint16_t kPayload = 4u * kNumValues + 1u;
constexpr uint16_t kSlotSize = kHeader + kPayload;  // 230
constexpr uint16_t kSlotStride = 256;

// ---- CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) ---------------------------------------------
inline uint16_t crc16(uint16_t crc, uint8_t b) {
  crc = static_cast<uint16_t>(crc ^ static_cast<uint16_t>(b << 8));
  for (uint8_t i = 0; i < 8; ++i)
    crc = (crc & 0x8000u) ? static_cast<uint16_t>((crc << 1) ^ 0x1021u) : static_cast<uint16_t>(crc << 1);
  return crc;
}

// ---- keys --------------------------------------------------------------------------------------
namespace detail {
inline const char* table_names() { return SMA_F("rho c h d0 L0 R T_amb T_AS T_AF T_MS T_MF T_s T_f T_MSs T_MSf q e g"); }
inline const char* effect_names() {
  return SMA_F("sensor_delay.delay_s sensor_lag.tau_s sensor_calibration.gain "
               "sensor_calibration.offset_mm ambient_offset.offset_K convection_nonlinear.beta_per_K "
               "resistance_phase.k_R latent_heat.L_J");
}
inline const char* loop_fields() { return SMA_F("T_i T_ii j"); }

// Index of tok[0..len) in a space-separated flash list, or kNoKey.
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

// Writes word n of a flash list to o.
template <class Out>
inline void put_word(Out& o, const char* list_f, uint8_t n) {
  for (const char* p = list_f;; ++p) {
    const char c = flash_char(p);
    if (c == 0) return;
    if (c == ' ') {
      if (n == 0) return;
      --n;
    } else if (n == 0) {
      o.put(c);
    }
  }
}
}  // namespace detail

// Key index of a name, or kNoKey.
inline uint8_t key_index(const char* tok, uint8_t len) {
  if (len == 2 && tok[0] == 'm' && tok[1] >= '0' && tok[1] <= '5') return static_cast<uint8_t>(kFirstM + (tok[1] - '0'));
  if (len == 5 && detail::find_word(SMA_F("loops"), tok, len) == 0) return kKeyLoops;
  if (len > 6 && tok[0] == 'l' && tok[1] == 'o' && tok[2] == 'o' && tok[3] == 'p' && tok[4] >= '0' && tok[4] <= '7' && tok[5] == '.') {
    const uint8_t f = detail::find_word(detail::loop_fields(), tok + 6, static_cast<uint8_t>(len - 6));
    if (f == kNoKey) return kNoKey;
    return static_cast<uint8_t>(kFirstLoop + 3 * (tok[4] - '0') + f);
  }
  uint8_t k = detail::find_word(detail::table_names(), tok, len);
  if (k != kNoKey) return k;
  k = detail::find_word(detail::effect_names(), tok, len);
  // The effect parameter alone is accepted too (each is unique): a long key plus a precise value
  // would not fit a 47-char console line (pset convection_nonlinear.beta_per_K ...).
  if (k == kNoKey) k = detail::find_word(SMA_F("delay_s tau_s gain offset_mm offset_K beta_per_K k_R L_J"), tok, len);
  return k == kNoKey ? kNoKey : static_cast<uint8_t>(kFirstEffect + k);
}

// Writes the name of key k (as accepted by key_index) to o (anything with put(char)).
template <class Out>
inline void put_key_name(Out& o, uint8_t k) {
  if (k < kFirstM) {
    detail::put_word(o, detail::table_names(), k);
  } else if (k < kFirstLoop) {
    o.put('m');
    o.put(static_cast<char>('0' + (k - kFirstM)));
  } else if (k < kFirstEffect) {
    const uint8_t i = static_cast<uint8_t>(k - kFirstLoop);
    o.put('l'); o.put('o'); o.put('o'); o.put('p');
    o.put(static_cast<char>('0' + i / 3));
    o.put('.');
    detail::put_word(o, detail::loop_fields(), static_cast<uint8_t>(i % 3));
  } else if (k < kKeyLoops) {
    detail::put_word(o, detail::effect_names(), static_cast<uint8_t>(k - kFirstEffect));
  } else {
    detail::put_word(o, SMA_F("loops"), 0);
  }
}

// Range the console accepts for key k (Params::check / Effects::check then judge the whole set).
// One byte per key selects a pair of bounds: tables in flash on AVR.
namespace detail {
#if defined(__AVR__)
#define SMA_STORAGE_TABLE const PROGMEM
inline uint8_t table_byte(const uint8_t* p) { return pgm_read_byte(p); }
inline float table_float(const float* p) { return pgm_read_float(p); }
#else
#define SMA_STORAGE_TABLE const
inline uint8_t table_byte(const uint8_t* p) { return *p; }
inline float table_float(const float* p) { return *p; }
#endif
static SMA_STORAGE_TABLE float kBounds[][2] = {
    {-100000.0f, 100000.0f},  // 0: m0..m5, q, e, h (upper)
    {100.0f, 100000.0f},      // 1: rho
    {10.0f, 10000.0f},        // 2: c
    {0.01f, 100000.0f},       // 3: h
    {0.000001f, 0.01f},       // 4: d0
    {0.001f, 10.0f},          // 5: L0
    {0.001f, 1000.0f},        // 6: R
    {-50.0f, 100.0f},         // 7: T_amb
    {-100.0f, 400.0f},        // 8: temperatures, loop T_i / T_ii
    {0.001f, 100.0f},         // 9: g
    {0.0f, 1.0f},             // 10: loop j
    {0.0f, 5.0f},             // 11: delay_s, tau_s
    {0.2f, 5.0f},             // 12: gain
    {-100.0f, 100.0f},        // 13: offset_mm
    {-50.0f, 50.0f},          // 14: offset_K
    {0.0f, 0.1f},             // 15: beta_per_K
    {-0.9f, 2.0f},            // 16: k_R
    {0.0f, 100.0f},           // 17: L_J
    {0.0f, 8.0f}};            // 18: loops (kMaxLoopKnots)
static SMA_STORAGE_TABLE uint8_t kBoundOf[kNumKeys] = {
    1, 2, 3, 4, 5, 6, 7, 8, 8, 8, 8, 8, 8, 8, 8, 0, 0, 9,  // Table II
    0, 0, 0, 0, 0, 0,                                      // m
    8, 8, 10, 8, 8, 10, 8, 8, 10, 8, 8, 10, 8, 8, 10, 8, 8, 10, 8, 8, 10, 8, 8, 10,  // loops
    11, 11, 12, 13, 14, 15, 16, 17,                        // effects
    18};                                                   // loops count
// Position of key k among the doubles of Params (memory order: rho..T_MSf, m0..m5, q, e, g,
// loops) or of Effects (from sensor_delay_s on).
inline uint8_t params_slot(uint8_t k) {
  return static_cast<uint8_t>(k < 15 ? k : k < kFirstM ? k + 6 : k < kFirstLoop ? k - 3 : k);
}
}  // namespace detail

inline void key_range(uint8_t k, double& lo, double& hi) {
  const float* b = detail::kBounds[detail::table_byte(&detail::kBoundOf[k < kNumKeys ? k : 0])];
  lo = static_cast<double>(detail::table_float(b));
  hi = static_cast<double>(detail::table_float(b + 1));
}

// The value of key k in (p, fx); nullptr for kKeyLoops (a byte: p.n_loops) or an unknown key.
inline double* value_ptr(Params& p, Effects& fx, uint8_t k) {
  static_assert(offsetof(Params, m) == offsetof(Params, rho) + 15 * sizeof(double), "Params layout");
  static_assert(offsetof(Params, q) == offsetof(Params, rho) + 21 * sizeof(double), "Params layout");
  static_assert(offsetof(Params, loops) == offsetof(Params, rho) + 24 * sizeof(double), "Params layout");
  static_assert(sizeof(LoopKnot) == 3 * sizeof(double), "LoopKnot layout");
  static_assert(offsetof(Effects, latent_heat_J) == offsetof(Effects, sensor_delay_s) + 7 * sizeof(double),
                "Effects layout");
  if (k < kFirstEffect)
    return reinterpret_cast<double*>(reinterpret_cast<char*>(&p) + offsetof(Params, rho) +
                                     detail::params_slot(k) * sizeof(double));
  if (k < kKeyLoops)
    return reinterpret_cast<double*>(reinterpret_cast<char*>(&fx) + offsetof(Effects, sensor_delay_s) +
                                     (k - kFirstEffect) * sizeof(double));
  return nullptr;
}
inline double get_value(const Params& p, const Effects& fx, uint8_t k) {
  if (k == kKeyLoops) return p.n_loops;
  const double* v = value_ptr(const_cast<Params&>(p), const_cast<Effects&>(fx), k);
  return v ? *v : 0.0;
}

// float32 <-> 4 little-endian bytes (the stored format on AVR and host alike).
inline uint32_t float_bits(double x) {
  const float f = static_cast<float>(x);
  uint32_t u;
  memcpy(&u, &f, 4);
  return u;
}
inline double bits_float(uint32_t u) {
  float f;
  memcpy(&f, &u, 4);
  return static_cast<double>(f);
}

// Which key a check() message is about: "T_AF must be > T_AS" -> T_AF, "loops: ..." -> loops,
// "delay_s must be ..." (Effects) -> sensor_delay.delay_s. kNoKey if none matches.
inline uint8_t key_of_message(const char* msg, bool effects) {
  uint8_t n = 0;
  while (msg[n] != 0 && msg[n] != ' ' && msg[n] != ':') ++n;
  if (!effects) return key_index(msg, n);
  // Effects messages name the parameter: find "<effect>.<param>" ending with it.
  for (uint8_t k = kFirstEffect; k < kKeyLoops; ++k) {
    struct Buf {
      char s[40];
      uint8_t n = 0;
      void put(char c) { if (n < 39) s[n++] = c; }
    } b;
    put_key_name(b, k);
    if (b.n > n && b.s[b.n - n - 1] == '.' && memcmp(b.s + b.n - n, msg, n) == 0) return k;
  }
  return kNoKey;
}

// ---- validation ------------------------------------------------------------------------------------
// A validator: const char* operator()(const Params&, const Effects&, uint8_t& bad_key) returning
// nullptr for a valid set, else a message (read with flash_char) and the key it is about.
// CheckValidator runs Params::check() and Effects::check(). On AVR their messages are RAM
// strings, and any code that reads them keeps ~600 B of them in RAM: there it only tests for
// nullptr (the firmware validates by building its controller, Controller::valid(), which calls
// the same checks) and answers with a message in flash, without the key.
struct CheckValidator {
  const char* operator()(const Params& p, const Effects& fx, uint8_t& bad_key) const {
    bad_key = kNoKey;
#if defined(__AVR__)
    if (p.check() != nullptr || fx.check() != nullptr) return SMA_F("set fails Params/Effects check()");
#else
    if (const char* m = p.check()) {
      bad_key = key_of_message(m, false);
      return m;
    }
    if (const char* m = fx.check()) {
      bad_key = key_of_message(m, true);
      return m;
    }
#endif
    return nullptr;
  }
};

// ---- the two-slot store --------------------------------------------------------------------------
template <class E>
class Store {
 public:
  explicit Store(E e = E(), uint16_t base = 0) : e_(e), base_(base) {}

  int8_t active() const { return active_; }    // slot in use, -1: the paper's defaults
  int8_t staging() const { return staging_; }  // slot being written, -1: none
  uint8_t seq() const { return seq_; }
  uint16_t crc() const { return crc_; }
  E& eeprom() { return e_; }

  // Selects the active set and reads it into (p, fx). Returns the slot, or -1 when no slot
  // holds a valid set: (p, fx) are then unspecified and the caller uses the defaults.
  int8_t load(Params& p, Effects& fx) { return load(p, fx, CheckValidator()); }
  template <class V>
  int8_t load(Params& p, Effects& fx, const V& valid) {
    active_ = -1;  // (a staged set stays staged: its commit mark is cleared, never a candidate)
    uint16_t crc[2];
    const bool ok0 = crc_ok(0, crc[0]), ok1 = crc_ok(1, crc[1]);
    int8_t first = ok0 ? 0 : (ok1 ? 1 : -1);
    if (ok0 && ok1 && static_cast<int8_t>(seq_of(1) - seq_of(0)) > 0) first = 1;
    for (uint8_t pass = 0; pass < 2 && first >= 0; ++pass) {
      const uint8_t s = static_cast<uint8_t>(pass == 0 ? first : 1 - first);
      if (!(s == 0 ? ok0 : ok1)) continue;
      read_set(s, p, fx);
      uint8_t bad = kNoKey;
      if (valid(p, fx, bad) == nullptr) {
        active_ = static_cast<int8_t>(s);
        seq_ = seq_of(s);
        crc_ = crc[s];
        return active_;
      }
    }
    return -1;
  }

  // Reads slot s's payload into (p, fx) (no validation).
  void read_set(uint8_t s, Params& p, Effects& fx) const {
    for (uint8_t k = 0; k < kNumKeys; ++k) set_in(p, fx, k, read_value(s, k));
  }

  // The stored value of key k in slot s.
  double read_value(uint8_t s, uint8_t k) const {
    const uint16_t a = addr(s, k);
    if (k == kKeyLoops) return e_.read(a);
    return bits_float(read_bits(s, k));
  }
  uint32_t read_bits(uint8_t s, uint8_t k) const {
    const uint16_t a = addr(s, k);
    if (k == kKeyLoops) return e_.read(a);
    uint32_t u = 0;
    for (uint8_t b = 4; b > 0; --b) u = (u << 8) | e_.read(static_cast<uint16_t>(a + b - 1));
    return u;
  }

  // Starts a new set in the inactive slot: clears its commit mark, then copies the active
  // slot into it (EEPROM to EEPROM, no RAM). With no active slot, use begin_from(defaults).
  void begin_copy() {
    const uint8_t s = target();
    e_.write(slot(s), 0);
    staging_ = static_cast<int8_t>(s);
    for (uint16_t i = kHeader; i < kSlotSize; ++i)
      e_.write(static_cast<uint16_t>(slot(s) + i), e_.read(static_cast<uint16_t>(slot(static_cast<uint8_t>(1 - s)) + i)));
  }
  // Starts a new set initialised from (p, fx).
  void begin_from(const Params& p, const Effects& fx) {
    const uint8_t s = target();
    e_.write(slot(s), 0);
    staging_ = static_cast<int8_t>(s);
    for (uint8_t k = 0; k < kNumKeys; ++k) set_value(k, get_value(p, fx, k));
  }
  // Writes one value of the staged set (false without a staged set or for an unknown key).
  bool set_value(uint8_t k, double v) {
    if (staging_ < 0 || k >= kNumKeys) return false;
    const uint16_t a = addr(static_cast<uint8_t>(staging_), k);
    if (k == kKeyLoops) {
      e_.write(a, static_cast<uint8_t>(v));
      return true;
    }
    uint32_t u = float_bits(v);
    for (uint8_t b = 0; b < 4; ++b, u >>= 8) e_.write(static_cast<uint16_t>(a + b), static_cast<uint8_t>(u));
    return true;
  }
  void abort() { staging_ = -1; }

  // Validates the staged set (read into the scratch p, fx) and makes it the active one.
  // Returns nullptr on success, else the check() message (bad_key: its key, or kNoKey); the
  // staged set stays open (fix it with set_value, or abort) and the active set is unchanged.
  const char* commit(Params& p, Effects& fx, uint8_t& bad_key) {
    return commit(p, fx, bad_key, CheckValidator());
  }
  template <class V>
  const char* commit(Params& p, Effects& fx, uint8_t& bad_key, const V& valid) {
    bad_key = kNoKey;
    if (staging_ < 0) return SMA_F("no staged set");
    const uint8_t s = static_cast<uint8_t>(staging_);
    read_set(s, p, fx);
    if (const char* m = valid(p, fx, bad_key)) return m;
    const uint8_t seq = static_cast<uint8_t>(active_ < 0 ? 1 : seq_ + 1);
    e_.write(static_cast<uint16_t>(slot(s) + 1), kVersion);
    e_.write(static_cast<uint16_t>(slot(s) + 2), seq);
    const uint16_t c = compute_crc(s);
    e_.write(static_cast<uint16_t>(slot(s) + 3), static_cast<uint8_t>(c & 0xFF));
    e_.write(static_cast<uint16_t>(slot(s) + 4), static_cast<uint8_t>(c >> 8));
    e_.write(slot(s), kMagic);  // the commit: one byte
    uint16_t back = 0;
    if (!crc_ok(s, back)) return SMA_F("eeprom write failed");
    active_ = static_cast<int8_t>(s);
    staging_ = -1;
    seq_ = seq;
    crc_ = c;
    return nullptr;
  }

  uint16_t slot(uint8_t s) const { return static_cast<uint16_t>(base_ + s * kSlotStride); }

 private:
  uint8_t target() const { return static_cast<uint8_t>(active_ == 0 ? 1 : 0); }
  uint16_t addr(uint8_t s, uint8_t k) const {
    return static_cast<uint16_t>(slot(s) + kHeader + (k == kKeyLoops ? 4u * kNumValues : 4u * k));
  }
  uint8_t seq_of(uint8_t s) const { return e_.read(static_cast<uint16_t>(slot(s) + 2)); }
  uint16_t compute_crc(uint8_t s) const {
    uint16_t c = 0xFFFF;
    for (uint16_t i = 1; i < kSlotSize; ++i) {
      if (i == 3) i = kHeader;  // skip the CRC itself
      c = crc16(c, e_.read(static_cast<uint16_t>(slot(s) + i)));
    }
    return c;
  }
  bool crc_ok(uint8_t s, uint16_t& crc) const {
    if (e_.read(slot(s)) != kMagic || e_.read(static_cast<uint16_t>(slot(s) + 1)) != kVersion) return false;
    crc = compute_crc(s);
    const uint16_t stored = static_cast<uint16_t>(e_.read(static_cast<uint16_t>(slot(s) + 3)) |
                                                  (e_.read(static_cast<uint16_t>(slot(s) + 4)) << 8));
    return crc == stored;
  }
  static void set_in(Params& p, Effects& fx, uint8_t k, double v) {
    if (k == kKeyLoops) {
      p.n_loops = static_cast<uint8_t>(v);
      return;
    }
    if (double* d = value_ptr(p, fx, k)) *d = v;
  }

  E e_;
  uint16_t base_;
  int8_t active_ = -1, staging_ = -1;
  uint8_t seq_ = 0;
  uint16_t crc_ = 0;
};

}  // namespace storage
}  // namespace sma

#endif  // SMA_STORAGE_HPP
