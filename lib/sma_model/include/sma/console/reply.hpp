// A bounded reply line (no printf: avr-libc has no %f by default) and the telemetry row.
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_REPLY_HPP
#define SMA_CONSOLE_REPLY_HPP

#include "state.hpp"
#include "../trunc_u32.hpp"

namespace sma {
namespace console {

// ---- a small bounded text buffer ---------------------------------------------------------------
struct Reply {
  // (len before text: on the AVR a load reaches 63 bytes past the reply's address.)
  uint8_t len = 0;
  char text[kReplyMax];
  Reply() { text[0] = 0; }
  // (Out of line: one copy for its callers instead of one each, flash on the Uno.)
  __attribute__((noinline)) void clear() {
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
  void put_u(uint32_t v) { put_scaled(v, 0); }
  // v / 10^dec with `dec` decimals (0..9): put_scaled(12345, 2) -> "123.45", (7, 2) -> "0.07".
  // The one digit loop of put_u, put_fixed and the telemetry's time; 16-bit divisions once the
  // rest fits (a 32-bit division costs ~600 AVR cycles, a 16-bit one ~200: telemetry formats
  // 5 numbers every tick).
  void put_scaled(uint32_t v, uint8_t dec) {
    char d[10];
    uint8_t n = 0;
    do {
      uint8_t digit;
      if (v > 0xFFFFu) {
        digit = static_cast<uint8_t>(v % 10u);
        v /= 10u;
      } else {
        const uint16_t w = static_cast<uint16_t>(v);
        digit = static_cast<uint8_t>(w % 10u);
        v = static_cast<uint16_t>(w / 10u);
      }
      d[n++] = static_cast<char>('0' + digit);
    } while ((v != 0 || n <= dec) && n < 10);
    while (n > 0) {
      put(d[--n]);
      if (n == dec && n != 0) put('.');
    }
  }
  // Fixed-point decimal with `dec` decimals (0..6), rounded; "nan"/"inf" for non-finite and
  // "big" beyond 2e9 units of the last digit (so no printf("%f"), which avr-libc lacks by default).
  void put_fixed(double x, uint8_t dec) {
    if (!is_finite(x)) {
      put_f(x != x ? SMA_F("nan") : SMA_F("inf"));
      return;
    }
    if (dec > 6) dec = 6;
    // 10^dec in floating point directly (exact: 10^6 < 2^24), no integer-to-float conversion.
    double scale = 1.0;
    for (uint8_t k = 0; k < dec; ++k) scale *= 10.0;
    if (x < 0.0) {
      x = -x;
      // "-0.0000" would read oddly: only print the sign if something non-zero follows.
      if (x * scale >= 0.5) put('-');
    }
    const double scaled = x * scale + 0.5;
    if (!(scaled < 2.0e9)) {
      put_f(SMA_F("big"));
      return;
    }
    put_scaled(trunc_u32(scaled), dec);
  }
  // A short decimal, about 6-7 significant digits, trailing zeros trimmed: 0.000001, 0.2,
  // -4.8334, 50.2, 100000 (range bounds, and pget/pset echoes next to the exact float bits).
  // (At least 2 decimals: the number has a point, or is nan/inf/big, which end in no '0'.)
  void put_num(double x) {
    const double a = x < 0.0 ? -x : x;
    const uint8_t start = len;
    put_fixed(x, a >= 1000.0 ? 2 : a >= 10.0 ? 4 : a >= 1.0 ? 5 : 6);
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
// `plot`: the same values as Teleplot lines instead, one per column (Teleplot's serial format
// `>name:value`, the names of the header; the receiver's clock is the time axis), in one reply:
//   >v_V:0.8123 CR LF >d_mm:0.4012 CR LF >ref_mm:0.4000 CR LF >duty:0.16000
inline void telemetry_row(Reply& r, uint32_t ticks, uint16_t ticks_per_s, double v, double d_mm,
                          double ref_mm, double duty, bool plot = false) {
  r.clear();
  const double value[4] = {v, d_mm, ref_mm, duty};
  if (plot) {
    const char* name = telemetry_header();
    for (uint8_t k = 0; k < 4; ++k) {
      if (k > 0) {
        r.put('\r');
        r.put('\n');
      }
      r.put('>');
      while (flash_char(name) != ',') ++name;  // the header's next name
      for (++name; flash_char(name) != ',' && flash_char(name) != 0; ++name) r.put(flash_char(name));
      r.put(':');
      r.put_fixed(value[k], k == 3 ? 5 : 4);
    }
    return;
  }
  // Two decimals for up to 100 ticks/s (at 100 Hz the ticks are the hundredths), three for up
  // to 1000.
  if (ticks_per_s == 100) {
    r.put_scaled(ticks, 2);
  } else {
    const uint32_t unit = ticks_per_s <= 100 ? 100u : 1000u;
    r.put_u(ticks / ticks_per_s);
    const uint8_t point = r.len;  // the fraction's digits with their leading zeros: unit + frac,
    r.put_u(unit + ticks % ticks_per_s * unit / ticks_per_s);  // its leading 1 becomes the point
    if (point < r.len) r.text[point] = '.';
  }
  for (uint8_t k = 0; k < 4; ++k) {
    r.put(',');
    r.put_fixed(value[k], k == 3 ? 5 : 4);
  }
}

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_REPLY_HPP
