// pbegin pset pget pcommit pabort pinfo on a storage::Store.
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_MODEL_COMMANDS_HPP
#define SMA_CONSOLE_MODEL_COMMANDS_HPP

#include "../storage.hpp"
#include "reply.hpp"
#include "state.hpp"
#include "../trunc_u32.hpp"

namespace sma {
namespace console {

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

// `OK pget <key> <value> <bits>`: the value and its stored bits (hex; loops: the count).
inline void pget_line(Reply& r, uint8_t key, double v, uint32_t bits) {
  r.put_f(SMA_F("OK pget "));
  storage::put_key_name(r, key);
  r.put(' ');
  r.put_num(v);
  r.put(' ');
  r.put_hex(bits, key == storage::kKeyLoops ? 2 : 8);
}
// pget with no active set: the default `v` as it would be stored (float32).
__attribute__((always_inline)) inline void pget_default_line(Reply& r, uint8_t key, double v) {
  if (key != storage::kKeyLoops) v = storage::bits_float(storage::float_bits(v));
  pget_line(r, key, v, key == storage::kKeyLoops ? trunc_u32(v) : storage::float_bits(v));
}

// pcommit refused by check() (storage::CheckValidator): `ERR <key>: <why>`, the message of the
// parameter table (param::put_violation) for the staged set, now in (p, fx).
inline void put_refused(Reply& r, const storage::CheckValidator&, const char*, const Params& p,
                        const Effects& fx) {
  param::Violation v = p.check();
  if (v.ok()) v = fx.check();
  r.put_f(SMA_F("ERR "));
  param::put_violation(r, v);
}
// By another validator (the firmware's: the controller built from the set): `ERR pcommit: <why>`.
template <class V>
inline void put_refused(Reply& r, const V&, const char* msg, const Params&, const Effects&) {
  r.put_f(SMA_F("ERR pcommit: "));
  r.put_f(msg);
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
    case Op::PGet:
      if (st.active() >= 0) {
        const uint8_t a = static_cast<uint8_t>(st.active());
        pget_line(r, c.key, st.read_value(a, c.key), st.read_bits(a, c.key));
      } else {
        pget_default_line(r, c.key, storage::get_value(scratch, fxs, c.key));
      }
      return false;
    case Op::PCommit: {
      if (st.staging() < 0) {
        r.put_f(SMA_F("ERR pcommit: no staged set, send pbegin"));
        return false;
      }
      uint8_t bad = storage::kNoKey;
      if (const char* msg = st.commit(scratch, fxs, bad, valid)) {
        put_refused(r, valid, msg, scratch, fxs);
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

#endif  // SMA_CONSOLE_MODEL_COMMANDS_HPP
