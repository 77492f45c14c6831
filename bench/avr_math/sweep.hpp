// A fingerprint of sma::Fixed's results: FNV-1a over the raw outputs of every operation on a fixed
// set of inputs. Computed by the AVR benchmark in simavr and by sweep_host.cpp on the host; the
// two must be equal, which is what lets the host tests stand for the firmware (int is 16 bits on
// the AVR, so a missed integer promotion would show up here). Header-only, no STL.
#ifndef SMA_BENCH_AVR_MATH_SWEEP_HPP
#define SMA_BENCH_AVR_MATH_SWEEP_HPP

#include <stdint.h>

#include "sma/fixed.hpp"

namespace sweep {

class Hash {
 public:
  void add(int32_t v) {
    uint32_t u = static_cast<uint32_t>(v);
    for (uint8_t i = 0; i < 4; ++i) {
      h_ ^= static_cast<uint8_t>(u);
      h_ *= UINT32_C(16777619);
      u >>= 8;
    }
  }
  void add(sma::Fixed x) { add(x.raw()); }
  uint32_t value() const { return h_; }

 private:
  uint32_t h_ = UINT32_C(2166136261);
};

// xorshift32 operands over all magnitudes (random right shift) and both signs.
class Operands {
 public:
  uint32_t word() {
    s_ ^= s_ << 13;
    s_ ^= s_ >> 17;
    s_ ^= s_ << 5;
    return s_;
  }
  int32_t next() {
    const uint32_t w = word();
    const int32_t v = static_cast<int32_t>(w >> (word() & 31u));
    return (word() & 1u) != 0 ? -v : v;
  }

 private:
  uint32_t s_ = UINT32_C(2463534242);
};

inline uint32_t fixed_results_hash() {
  using sma::Fixed;
  Hash h;
  Operands ops;
  for (uint16_t i = 0; i < 2000; ++i) {
    const Fixed a = Fixed::from_raw(ops.next());
    const Fixed b = Fixed::from_raw(ops.next());
    h.add(a + b);
    h.add(a - b);
    h.add(a * b);
    h.add(a / b);
    h.add(sma::cos(a));
    h.add(sma::sin(b));
    h.add(sma::sqrt(a));
    h.add(sma::exp(Fixed::from_raw(b.raw() / 2048)));  // mostly within +-16
  }
  for (int32_t r = 0; r <= 65536; r += 3) {
    h.add(sma::cos_ramp(Fixed::from_raw(r)));
    h.add(sma::cos_ramp_inv(Fixed::from_raw(r)));
  }
  for (int32_t r = -65536; r <= 65536; r += 17) h.add(sma::acos(Fixed::from_raw(r)));
  return h.value();
}

}  // namespace sweep

#endif  // SMA_BENCH_AVR_MATH_SWEEP_HPP
