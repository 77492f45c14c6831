// int32 / uint32 -> float rounded to nearest, ties to even: the result of static_cast<float>.
// The Q16.16 Uno image defines libgcc's two conversion entries (__floatunsisf, __floatsisf) with
// the assembly below instead of avr-libc's 122-B member, so every conversion the compiler emits
// (the tick count's time, the counts the console prints) runs it, and `Fixed::operator float`
// its third entry (102 B in all; issue 12 item 4). bench/avr_math runs it under its own names
// against avr-libc's on every exponent; the native tests check the portable version against the
// host's cast.
#ifndef SMA_FLOAT_FROM_INT_HPP
#define SMA_FLOAT_FROM_INT_HPP

#include <stdint.h>

namespace sma {
namespace fixed_detail {

// The algorithm of the assembly: u shifted up until its top bit is set (e counts down from
// 127 + 31), the low byte rounded away (more than half up, exactly half up when the kept
// 24 bits are odd), the implicit bit then overlapping the exponent's field ((e - 1) 2^23 + m:
// a rounding that carries to 2^24 moves to the next exponent by itself).
inline uint32_t float_bits_from_u32(uint32_t u) {
  if (u == 0) return 0;
  uint32_t e = 127u + 31u;
  while ((u & 0x80000000u) == 0) {
    u <<= 1;
    --e;
  }
  const uint32_t low = u & 0xFFu;
  uint32_t m = u >> 8;
  if (low > 0x80u || (low == 0x80u && (m & 1u) != 0)) ++m;
  return ((e - 1u) << 23) + m;
}

inline uint32_t float_bits_from_i32(int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  return v < 0 ? 0x80000000u | float_bits_from_u32(0u - u) : float_bits_from_u32(u);
}

}  // namespace fixed_detail
}  // namespace sma

#if defined(__AVR__)
// The AVR entries U (uint32_t), S (int32_t) and Q (int32_t, a Q16.16 raw value: the float of
// raw 2^-16, exactly as float_bits_from_raw) in r25..r22 -> float in r25..r22, as a top-level
// assembly block for one translation unit (the firmware's main.cpp names the first two
// __floatunsisf and __floatsisf; the linker then takes no member of the library for them).
// Clobbers r18..r20 and T (call-used). S and Q: the magnitude, T the sign; r19 the exponent's
// scale (16 for Q). Whole bytes first while the top byte is 0 (a tick count is below 2^24: ~60
// cycles instead of ~200 bit by bit), three of them at most (a fourth means 0, returned as it
// is). The rounding adds 0x7F, or 0x80 when the kept bits are odd, to the low byte and carries
// through the exponent (r18). 51 instructions.
#define SMA_FLOAT_FROM_INT_ASM(U, S, Q)                              \
  ".pushsection .text." U ",\"ax\",@progbits\n"                      \
  ".global " U "\n"                                                  \
  ".type " U ", @function\n"                                         \
  ".global " S "\n"                                                  \
  ".type " S ", @function\n"                                         \
  ".global " Q "\n"                                                  \
  ".type " Q ", @function\n" U ":\n"                                 \
  "  clt\n"                                                          \
  "  clr  r19\n"                                                     \
  "  rjmp 1f\n" Q ":\n"                                              \
  "  ldi  r19, 16\n"                                                 \
  "  rjmp 0f\n" S ":\n"                                              \
  "  clr  r19\n"                                                     \
  "0: bst r25, 7\n"                                                  \
  "  brtc 1f\n"                                                      \
  "  com  r25\n"                                                     \
  "  com  r24\n"                                                     \
  "  com  r23\n"                                                     \
  "  neg  r22\n"                                                     \
  "  sbci r23, 0xFF\n"                                               \
  "  sbci r24, 0xFF\n"                                               \
  "  sbci r25, 0xFF\n"                                               \
  "1: ldi r18, 158\n"                                                \
  "2: tst r25\n"                                                     \
  "  brne 3f\n"                                                      \
  "  cpi  r18, 134\n"                                                \
  "  breq 9f\n"                                                      \
  "  mov  r25, r24\n"                                                \
  "  mov  r24, r23\n"                                                \
  "  mov  r23, r22\n"                                                \
  "  ldi  r22, 0\n"                                                  \
  "  subi r18, 8\n"                                                  \
  "  rjmp 2b\n"                                                      \
  "3: brmi 4f\n"                                                     \
  "  dec  r18\n"                                                     \
  "  lsl  r22\n"                                                     \
  "  rol  r23\n"                                                     \
  "  rol  r24\n"                                                     \
  "  rol  r25\n"                                                     \
  "  rjmp 3b\n"                                                      \
  "4: ldi r20, 0x7F\n"                                               \
  "  sbrc r23, 0\n"                                                  \
  "  ldi  r20, 0x80\n"                                               \
  "  add  r22, r20\n"                                                \
  "  adc  r23, r1\n"                                                 \
  "  adc  r24, r1\n"                                                 \
  "  adc  r25, r1\n"                                                 \
  "  adc  r18, r1\n"                                                 \
  "  sub  r18, r19\n"                                                \
  "  mov  r22, r23\n"                                                \
  "  mov  r23, r24\n"                                                \
  "  lsl  r25\n"                                                     \
  "  mov  r24, r25\n"                                                \
  "  mov  r25, r18\n"                                                \
  "  lsr  r25\n"                                                     \
  "  ror  r24\n"                                                     \
  "  bld  r25, 7\n"                                                  \
  "9: ret\n"                                                         \
  ".size " U ", . - " U "\n"                                         \
  ".popsection\n"
#endif

#endif  // SMA_FLOAT_FROM_INT_HPP
