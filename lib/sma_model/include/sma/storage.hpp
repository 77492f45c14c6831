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
// Keys: the flat keys of the parameter table (param_table.hpp), index k:
//   0..17  rho c h d0 L0 R T_amb T_AS T_AF T_MS T_MF T_s T_f T_MSs T_MSf q e g
//   18..23 m0..m5            24..47 loop<i>.T_i, loop<i>.T_ii, loop<i>.j (i = 0..7)
//   48..55 sensor_delay.delay_s ... latent_heat.L_J (also accepted: the parameter alone)
//   56 loops (the number of loops, 0..8); thermal_expansion.alpha_per_K (57) is not stored
#ifndef SMA_STORAGE_HPP
#define SMA_STORAGE_HPP

#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "effects.hpp"
#include "codegen.hpp"
#include "param_table_access.hpp"
#include "params.hpp"
#include "safety.hpp"  // SMA_F, flash_char
#include "trunc_u32.hpp"

namespace sma {
namespace storage {

constexpr uint8_t kVersion = 1;
constexpr uint8_t kMagic = 0xA5;
// The flat keys of the parameter table (param_table.hpp) the board stores, in its order.
constexpr uint8_t kFirstM = param::key_of<param::Row::m>();
constexpr uint8_t kFirstLoop = param::key_of<param::Row::loop_T_i>();
constexpr uint8_t kFirstEffect = param::key_of<param::Row::delay_s>();
constexpr uint8_t kKeyLoops = param::key_of<param::Row::loops>();  // the byte n_loops
constexpr uint8_t kNumValues = kKeyLoops;                         // float32 values
constexpr uint8_t kNumKeys = kKeyLoops + 1;  // thermal_expansion (after it) is not stored
constexpr uint8_t kNoKey = param::kNoKey;
// The layout of the boards in the field (kVersion 1): changing it needs a new version.
static_assert(kFirstM == 18 && kFirstLoop == 24 && kFirstEffect == 48 && kKeyLoops == 56,
              "EEPROM layout of kVersion 1");
static_assert(param::key_of<param::Row::L_J>() == kKeyLoops - 1, "the stored effects end before loops");
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

// ---- keys: the parameter table's (param_table_access.hpp), those the board stores -------------
namespace detail {
using param::find_word;
using param::put_word;
}  // namespace detail
#define SMA_STORAGE_TABLE SMA_FLASH_TABLE

// Key index of a name, or kNoKey (also for a key the board does not store).
inline uint8_t key_index(const char* tok, uint8_t len) {
  const uint8_t k = param::key_index(tok, len);
  return k < kNumKeys ? k : kNoKey;
}
using param::get_value;
using param::key_range;
using param::put_key_name;
using param::value_ptr;

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

// ---- validation ------------------------------------------------------------------------------------
// A validator: const char* operator()(const Params&, const Effects&, uint8_t& bad_key) returning
// nullptr for a valid set, else a message (read with flash_char) and the key it is about (or
// kNoKey). CheckValidator runs Params::check() and Effects::check(); the console writes the
// message of what they found (param::put_violation).
struct CheckValidator {
  const char* operator()(const Params& p, const Effects& fx, uint8_t& bad_key) const {
    param::Violation v = p.check();
    if (v.ok()) v = fx.check();
    bad_key = v.key;
    return v.ok() ? nullptr : SMA_F("set fails Params/Effects check()");
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
    for (uint8_t k = 0; k < kNumKeys; ++k) set_in(p, fx, k, read_bits(s, k));
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
  SMA_OWN_OPTIONS bool set_value(uint8_t k, double v) {
    if (staging_ < 0 || k >= kNumKeys) return false;
    const uint16_t a = addr(static_cast<uint8_t>(staging_), k);
    if (k == kKeyLoops) {
      e_.write(a, static_cast<uint8_t>(trunc_u32(v)));
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
  // (Out of line: one copy for its callers instead of one each, flash on the Uno.)
  __attribute__((noinline)) uint16_t addr(uint8_t s, uint8_t k) const {
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
  SMA_OWN_OPTIONS bool crc_ok(uint8_t s, uint16_t& crc) const {
    if (e_.read(slot(s)) != kMagic || e_.read(static_cast<uint16_t>(slot(s) + 1)) != kVersion) return false;
    crc = compute_crc(s);
    const uint16_t stored = static_cast<uint16_t>(e_.read(static_cast<uint16_t>(slot(s) + 3)) |
                                                  (e_.read(static_cast<uint16_t>(slot(s) + 4)) << 8));
    return crc == stored;
  }
  // The stored bits of key k (the loop count's byte, read as an integer) into (p, fx).
  static void set_in(Params& p, Effects& fx, uint8_t k, uint32_t bits) {
    if (k == kKeyLoops) {
      p.n_loops = static_cast<uint8_t>(bits);
      return;
    }
    if (double* d = value_ptr(p, fx, k)) *d = bits_float(bits);
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
