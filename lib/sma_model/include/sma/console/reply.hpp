// A bounded reply line (no printf: avr-libc has no %f by default) and the telemetry row.
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_REPLY_HPP
#define SMA_CONSOLE_REPLY_HPP

#include "state.hpp"

namespace sma {
namespace console {

// ---- a small bounded text buffer ---------------------------------------------------------------
struct Reply {
  char text[kReplyMax];
  uint8_t len = 0;
  Reply() { text[0] = 0; }
  void clear() {
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
  void put_u(uint32_t v) {
    char d[10];
    uint8_t n = 0;
    while (v > 0xFFFFu && n < 10) {  // 32-bit digits only while needed
      d[n++] = static_cast<char>('0' + v % 10u);
      v /= 10u;
    }
    uint16_t w = static_cast<uint16_t>(v);
    do {
      d[n++] = static_cast<char>('0' + w % 10u);
      w = static_cast<uint16_t>(w / 10u);
    } while (w != 0 && n < 10);
    while (n > 0) put(d[--n]);
  }
  // Fixed-point decimal with `dec` decimals (0..6), rounded; "nan"/"inf" for non-finite and
  // "big" beyond 2e9 units of the last digit (so no printf("%f"), which avr-libc lacks by default).
  void put_fixed(double x, uint8_t dec) {
    if (!is_finite(x)) {
      put_f(x != x ? SMA_F("nan") : SMA_F("inf"));
      return;
    }
    if (dec > 6) dec = 6;
    uint32_t scale = 1;
    for (uint8_t k = 0; k < dec; ++k) scale *= 10u;
    if (x < 0.0) {
      x = -x;
      // "-0.0000" would read oddly: only print the sign if something non-zero follows.
      if (x * static_cast<double>(scale) >= 0.5) put('-');
    }
    const double scaled = x * static_cast<double>(scale) + 0.5;
    if (!(scaled < 2.0e9)) {
      put_f(SMA_F("big"));
      return;
    }
    const uint32_t v = static_cast<uint32_t>(scaled);
    const uint32_t ip = v / scale;
    put_u(ip);
    if (dec == 0) return;
    put('.');
    const uint32_t frac = v - ip * scale;
    // Digits right to left; 16-bit arithmetic when it fits (a 32-bit division costs ~600 AVR
    // cycles, a 16-bit one ~200: telemetry formats 4 numbers every tick).
    char d[6];
    if (scale <= 10000u) {
      uint16_t f = static_cast<uint16_t>(frac);
      for (uint8_t k = dec; k > 0; --k) {
        d[k - 1] = static_cast<char>('0' + f % 10u);
        f = static_cast<uint16_t>(f / 10u);
      }
    } else {
      uint32_t f = frac;
      for (uint8_t k = dec; k > 0; --k) {
        d[k - 1] = static_cast<char>('0' + f % 10u);
        f /= 10u;
      }
    }
    for (uint8_t k = 0; k < dec; ++k) put(d[k]);
  }
  // A short decimal, about 6-7 significant digits, trailing zeros trimmed: 0.000001, 0.2,
  // -4.8334, 50.2, 100000 (range bounds, and pget/pset echoes next to the exact float bits).
  void put_num(double x) {
    const double a = x < 0.0 ? -x : x;
    const uint8_t start = len;
    put_fixed(x, a >= 1000.0 ? 2 : a >= 10.0 ? 4 : a >= 1.0 ? 5 : 6);
    bool point = false;
    for (uint8_t k = start; k < len; ++k) point = point || text[k] == '.';
    if (!point) return;
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
  r.put_u(ticks / ticks_per_s);
  r.put('.');
  uint32_t frac = ticks % ticks_per_s;
  // two decimals for 100 Hz; three for up to 1000 ticks/s.
  const uint8_t digits = ticks_per_s <= 100 ? 2 : 3;
  uint32_t unit = digits == 2 ? 100u : 1000u;
  frac = frac * unit / ticks_per_s;
  for (uint32_t s = unit / 10u; s > 0; s /= 10u) {
    r.put(static_cast<char>('0' + frac / s));
    frac %= s;
  }
  for (uint8_t k = 0; k < 4; ++k) {
    r.put(',');
    r.put_fixed(value[k], k == 3 ? 5 : 4);
  }
}

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_REPLY_HPP
