// floor(y) of a setting, a tick count or a scaled figure held in double (float on the AVR),
// 0 <= y < 2^32: static_cast<uint32_t>, except in the Q16.16 Uno image, where Fixed's integer
// shifts do it (fixed_detail::trunc_u32_from_float_bits: the same value for every such y, 0 for
// y < 1), so that the image links no __fixunssfsi / __fixsfsi (98 B; issue 12 item 4).
#ifndef SMA_TRUNC_U32_HPP
#define SMA_TRUNC_U32_HPP

#include <stdint.h>
#if defined(__AVR__) && defined(SMA_FIRMWARE_FIXED)
#include "fixed.hpp"
#endif

namespace sma {

#if defined(__AVR__) && defined(SMA_FIRMWARE_FIXED)
inline uint32_t trunc_u32(float y) {
  uint32_t bits;
  __builtin_memcpy(&bits, &y, 4);
  return fixed_detail::trunc_u32_from_float_bits(bits);
}
#else
inline uint32_t trunc_u32(double y) { return static_cast<uint32_t>(y); }
#endif

}  // namespace sma

#endif  // SMA_TRUNC_U32_HPP
