// vrig: the virtual rig. Runs the firmware ELF, unchanged, on simavr's cycle-accurate ATmega328P
// at 16 MHz and closes the loop through a simulated wire: the library's plant (sma::Plant) or,
// with --plant b, plant B, written apart from the library (rig_wire.hpp):
//
//   every 1 ms of simulated time:
//     OCR1A / ICR1 / TCCR1A (data space) -> duty -> V = Vs sqrt(duty) -> plant.step(V, 1 ms)
//     plant.measure() (mm) -> rig_config.h calibration, inverted -> millivolts on ADC0
//   UART0 <-> a script of timed commands (--script), stdin (default), or a pseudo-terminal (--pty)
//   GPIOR0 markers written by the firmware -> exact cycles of the control section, tick jitter
//
// --native runs the firmware's own logic, sma::Board (sma/board.hpp), natively (float) instead of
// the ELF, with the same plant and the same script: the reference the FIL tests compare against.
//
// Usage: vrig FIRMWARE.elf [options]   (see usage() below)
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "rig_board.h"
#include "sma_host/board_loop.hpp"
#include "rig_wire.hpp"
#include "sma_host/plant.hpp"
#include "sma_host/progress.hpp"
#include "sma_tools/params_json.hpp"

extern "C" {
#include "avr_adc.h"
#include "avr_eeprom.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_cycle_timers.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_irq.h"
}
#ifdef VRIG_HAVE_PTY
extern "C" {
#include "parts/uart_pty.h"
}
#endif

namespace {

constexpr uint32_t kFreq = 16000000u;
constexpr uint32_t kPlantCycles = kFreq / 1000u;  // plant step: 1 ms
constexpr double kPlantDt = 1e-3;
constexpr uint64_t kAdcFaultCycles = 2u * 13u * 128u;  // two conversions at prescaler 128
// ATmega328P data-space addresses (the same on the ATmega2560).
constexpr uint16_t kGPIOR0 = 0x3E;
constexpr uint16_t kGPIOR2 = 0x4B;  // the preview image's plan_short count (main.cpp)
constexpr uint16_t kTCCR1A = 0x80;
constexpr uint16_t kICR1L = 0x86;
constexpr uint16_t kOCR1AL = 0x88;

struct ScriptLine {
  double t;
  std::string text;
};

struct Options {
  std::string elf;
  std::string mcu = "atmega328p";  // --mcu: the Uno's, or atmega2560 (the Mega image)
  std::string script, log, cycles_json;
  std::string pass_trace;  // --pass-trace FILE
  std::string tick_trace;  // --tick-trace FILE
  double duration = 10.0;
  double speed = 1.0;  // --realtime pacing: simulated seconds per wall-clock second
  bool pty = false, native = false, quiet = false, stamp = false, realtime = false;
  bool use_stdin = true;
  double noise_mm = 0.0;
  uint64_t seed = 1;
  sma::Effects fx;
  std::string params;                   // --params FILE.json: the plant's wire (interfaces.md)
  std::vector<std::string> effect_args;  // --effect, applied after --params
  std::string eeprom;                   // --eeprom FILE: the AVR's EEPROM, loaded and saved
  std::string truth;                    // --truth FILE: t_s,true_mm of the plant every 10 ms
  std::string plant = "library";        // --plant library | b | b-rpm
  double fault_at = -1.0, fault_mv = 5000.0;  // sensor loss injection
  double flood_from = -1.0, flood_to = -1.0;  // input flood
  bool wdrf = false;                          // start as after a watchdog reset
};

void usage() {
  fprintf(stderr,
          "usage: vrig FIRMWARE.elf [options]\n"
          "  --duration S        simulated seconds (default 10)\n"
          "  --script FILE       timed commands, lines '<t_s> <command>' ('#' comments)\n"
          "  --pty               expose UART0 on a pseudo-terminal (/tmp/simavr-uart0); implies --realtime\n"
          "  --realtime          do not run faster than wall-clock time\n"
          "  --speed X           with --realtime/--pty: run X times faster than wall-clock time\n"
          "                      (a long training run through the console in minutes; the\n"
          "                      firmware's own timing is simulated time, unaffected)\n"
          "  (neither --script nor --pty: stdin lines are sent as they come)\n"
          "  --log FILE          write the telemetry (header + rows) received to a CSV rig log\n"
          "  --cycles-json FILE  cycles of the control section (GPIOR0 markers), tick rate and jitter\n"
          "  --tick-trace FILE   one line per tick: tick, simulated s, control section cycles\n"
          "  --pass-trace FILE   (preview image) one line per plan pass: tick, pass, start and length\n"
          "                      in cycles from the tick's start, 1 if it finished the tick's planning\n"
          "  --noise-mm X        RMS displacement noise of the simulated sensor (mm)\n"
          "  --seed N            noise seed\n"
          "  --params FILE.json  the simulated wire: Table II keys, m, loops and hidden effects\n"
          "                      (the params JSON of interfaces.md; default: the paper's)\n"
          "  --effect NAME.PARAM=V  hidden plant effect, vocabulary names, e.g.\n"
          "                      sensor_delay.delay_s=0.05, or the parameter alone: delay_s=0.05\n"
          "                      (after --params)\n"
          "  --plant NAME        the simulated wire's code: library (default, sma::Plant), b (plant B,\n"
          "                      written apart from the library from model.md: RK4, its own\n"
          "                      hysteresis, a new loop at every reversal as model.md reads;\n"
          "                      --params and --effect in its own terms) or b-rpm (plant B with\n"
          "                      the library's return-point memory)\n"
          "  --truth FILE        the wire's true displacement (t_s,true_mm every 10 ms: no sensor\n"
          "                      effect, no noise), for tracking metrics under sensor effects\n"
          "  --eeprom FILE       the AVR's 1 KB EEPROM: read at start if FILE exists, written at\n"
          "                      the end (model parameters survive between runs)\n"
          "  --sensor-fault T[:MV]  from T s on, drive ADC0 to MV millivolts (default 5000)\n"
          "  --flood T1:T2       flood UART input with random bytes between T1 and T2 s\n"
          "  --wdrf              start as after a watchdog reset (MCUSR.WDRF set)\n"
          "  --mcu NAME          atmega328p (default, the Uno) or atmega2560 (sma_firmware_mega)\n"
          "  --native            run the console+controller natively instead of the ELF\n"
          "                      (FIRMWARE.elf is then ignored, pass '-')\n"
          "  --stamp             prefix each printed line with the simulated time\n"
          "  --quiet             do not print the firmware's lines\n");
}

// "name.param=V" (the vocabulary, interfaces.md) or "param=V" (the parameter alone, as the
// board's pset takes it: delay_s=0.05). Returns "" or the problem.
std::string set_effect(sma::Effects& fx, const char* arg) {
  const char* eq = strchr(arg, '=');
  const uint8_t k = eq && eq - arg < 255 ? sma::param::key_index(arg, static_cast<uint8_t>(eq - arg)) : sma::param::kNoKey;
  if (k == sma::param::kNoKey || sma_tools::key_kind(k) != sma::param::Kind::Effect)
    return std::string("--effect '") + arg +
           "': expected name.param=value or param=value, e.g. sensor_delay.delay_s=0.05 (known: " +
           sma_tools::effect_names_list() + ")";
  char* end = nullptr;
  const double v = strtod(eq + 1, &end);
  if (end == eq + 1 || *end != 0 || !std::isfinite(v)) return std::string("--effect '") + arg + "': not a number";
  sma_host::value(fx, k) = v;
  return "";
}

bool read_script(const std::string& path, std::vector<ScriptLine>& out) {
  FILE* f = fopen(path.c_str(), "r");
  if (!f) {
    fprintf(stderr, "vrig: cannot open script %s: %s\n", path.c_str(), strerror(errno));
    return false;
  }
  char buf[512];
  int lineno = 0;
  double prev = -1e30;
  while (fgets(buf, sizeof buf, f)) {
    ++lineno;
    size_t n = strlen(buf);
    while (n && (buf[n - 1] == '\n' || buf[n - 1] == '\r')) buf[--n] = 0;
    const char* p = buf;
    while (*p == ' ' || *p == '\t') ++p;
    if (*p == 0 || *p == '#') continue;
    char* end = nullptr;
    const double t = strtod(p, &end);
    if (end == p || !std::isfinite(t) || t < 0) {
      fprintf(stderr, "vrig: %s:%d: expected '<t_s> <command>'\n", path.c_str(), lineno);
      fclose(f);
      return false;
    }
    if (t < prev) {
      fprintf(stderr, "vrig: %s:%d: time goes backwards\n", path.c_str(), lineno);
      fclose(f);
      return false;
    }
    prev = t;
    if (*end == ' ' || *end == '\t') ++end;
    // "\x.." escapes let a script send raw bytes (binary-line tests).
    std::string text;
    for (const char* q = end; *q; ++q) {
      if (q[0] == '\\' && q[1] == 'x' && isxdigit((unsigned char)q[2]) && isxdigit((unsigned char)q[3])) {
        char hex[3] = {q[2], q[3], 0};
        text.push_back(static_cast<char>(strtol(hex, nullptr, 16)));
        q += 3;
      } else {
        text.push_back(*q);
      }
    }
    out.push_back({t, text});
  }
  fclose(f);
  return true;
}

// ---- shared between both modes: output lines, log, stats --------------------------------------
struct Output {
  const Options* opt = nullptr;
  FILE* log = nullptr;
  bool header_written = false;
  std::string line;
  long rows = 0;

  // Five fields, none empty (a line cut off by the end of the run is not a row).
  static bool is_row(const std::string& s) {
    int commas = 0;
    bool digit = false;
    for (char c : s) {
      if (c == ',') {
        if (!digit) return false;
        ++commas;
        digit = false;
      } else if (isdigit((unsigned char)c)) {
        digit = true;
      } else if (c != '.' && c != '-') {
        return false;
      }
    }
    return commas == 4 && digit;
  }
  void complete(double t) {
    if (!opt->quiet) {
      if (opt->stamp) printf("[%.3f] %s\n", t, line.c_str());
      else printf("%s\n", line.c_str());
    }
    if (log) {
      if (line == "t_s,v_V,d_mm,ref_mm,duty") {
        if (!header_written) fprintf(log, "%s\n", line.c_str());
        header_written = true;
      } else if (is_row(line)) {
        if (!header_written) {
          fprintf(log, "t_s,v_V,d_mm,ref_mm,duty\n");
          header_written = true;
        }
        fprintf(log, "%s\n", line.c_str());
        ++rows;
      }
    }
    line.clear();
  }
  void byte(uint8_t b, double t) {
    if (b == '\n') complete(t);
    else if (b != '\r') line.push_back(static_cast<char>(b));
  }
};

struct Stats {
  uint64_t ticks = 0;
  uint64_t t_start = 0, t_prev_start = 0;
  uint64_t ctl_max = 0, ctl_sum = 0, ctl_n = 0;
  uint64_t tick_max = 0, tick_sum = 0;
  // The preview's plan passes between ticks (GPIOR0 4 before a pass, 5 after, 6 after the one that
  // finished the tick's planning): the longest first pass (the lead sample) and other pass, and
  // the latest end of a tick's planning, from the tick's start.
  uint64_t pass_start = 0, pass_first_max = 0, pass_other_max = 0, plan_done_max = 0;
  unsigned pass_n = 0;  // passes since the tick
  bool plan_done = false;  // this tick's planning is done (later calls do nothing: not counted)
  uint64_t iv_min = UINT64_MAX, iv_max = 0;
  double iv_max_s = 0;
  double first_tick_s = -1, last_tick_s = -1;
  // Within the flood window.
  uint64_t flood_ticks = 0, flood_iv_max = 0;
  // Sensor fault. The firmware can only react to a faulted sample it has summed: a tick whose
  // samples were all taken before the fault reached the ADC may still heat. A tick counts as
  // "after the fault" when it starts two conversions (13 ADC clocks of 128 cycles each: one may
  // have latched the old input) after the plant step that raised the faulted voltage.
  double heater_off_s = -1;
  uint64_t fault_visible_cycle = UINT64_MAX;
  bool tick_sees_fault = false;
  uint64_t ticks_after_fault_with_heat = 0;
  // Serial.
  uint64_t bytes_in = 0, bytes_out = 0;
  unsigned wdtcsr = 0;       // WDTCSR at the end of the run (ELF): the watchdog's setting
  unsigned plan_short = 0;   // ticks that cut the preview's plan passes short (Board::plan_short, ELF: <= 255)
  uint32_t stack_free = 0;  // never-touched SRAM bytes (painted), ELF only
  uint16_t sp_min = 0xFFFF; // lowest SP set by a frame allocation (out SPL/SPH), ELF only
  uint32_t sp_min_pc = 0;
  uint16_t sp_min_run = 0xFFFF;  // after the first tick (setup excluded)
  uint16_t sp_pending = 0xFFFF;
  uint64_t sp_pending_cycle = 0;
  uint32_t sp_pending_pc = 0;
  double sp_min_s = 0;
};

// Millivolts on the sensor pin for a displacement (the harness's: rig_config.h calibration, inverted).
double sensor_mv(double mm) { return sma_host::BoardLoop<RigBoard, vrig::RigWire>::sensor_mv(mm); }

// Deterministic flood bytes: mostly printable garbage, some newlines, some binary.
struct Flood {
  uint32_t s = 12345;
  uint8_t next() {
    s = s * 1664525u + 1013904223u;
    const uint32_t r = s >> 24;
    if (r < 8) return '\n';
    if (r < 12) return static_cast<uint8_t>(s >> 8);  // any byte
    return static_cast<uint8_t>(32 + (s >> 9) % 95);
  }
};

void write_json(const Options& o, const Stats& st, const char* variant, double sim_s) {
  if (o.cycles_json.empty()) return;
  FILE* f = fopen(o.cycles_json.c_str(), "w");
  if (!f) {
    fprintf(stderr, "vrig: cannot write %s\n", o.cycles_json.c_str());
    return;
  }
  const double span = st.last_tick_s - st.first_tick_s;
  const double rate = (st.ticks > 1 && span > 0) ? (st.ticks - 1) / span : 0.0;
  const double cyc_us = 1e6 / kFreq;
  const double ivmin = st.iv_min == UINT64_MAX ? 0.0 : st.iv_min * cyc_us;
  const double ivmax = st.iv_max * cyc_us;
  double jitter = 0;
  if (st.ticks > 1) jitter = sma::max(fabs(ivmin - 1e6 / RIG_TICK_HZ), fabs(ivmax - 1e6 / RIG_TICK_HZ));
  const double flood_len = o.flood_to - o.flood_from;
  fprintf(f,
          "{\n  \"variant\": \"%s\",\n  \"sim_s\": %.3f,\n  \"ticks\": %llu,\n"
          "  \"tick_rate_hz\": %.4f,\n"
          "  \"control_cycles_max\": %llu,\n  \"control_cycles_mean\": %.1f,\n"
          "  \"tick_cycles_max\": %llu,\n  \"tick_cycles_mean\": %.1f,\n"
          "  \"cycles_per_tick_budget\": %u,\n"
          "  \"tick_interval_min_us\": %.3f,\n  \"tick_interval_max_us\": %.3f,\n"
          "  \"tick_interval_max_s\": %.4f,\n"
          "  \"tick_jitter_us\": %.3f,\n"
          "  \"flood_tick_rate_hz\": %.4f,\n  \"flood_tick_interval_max_us\": %.3f,\n"
          "  \"sensor_fault_s\": %.4f,\n  \"sensor_fault_visible_s\": %.6f,\n  \"heater_off_s\": %.4f,\n"
          "  \"ticks_heating_after_fault\": %llu,\n"
          "  \"uart_bytes_in\": %llu,\n  \"uart_bytes_out\": %llu,\n"
          "  \"wdtcsr\": %u,\n  \"plan_short_ticks\": %u,\n"
          "  \"plan_first_pass_cycles_max\": %llu,\n  \"plan_pass_cycles_max\": %llu,\n"
          "  \"plan_done_cycles_max\": %llu,\n"
          "  \"sram_never_touched_bytes\": %u,\n  \"sp_min\": %u,\n  \"sp_min_after_setup\": %u,\n  \"sp_min_pc\": %u,\n"
          "  \"sp_min_s\": %.4f\n}\n",
          variant, sim_s, (unsigned long long)st.ticks, rate, (unsigned long long)st.ctl_max,
          st.ctl_n ? (double)st.ctl_sum / st.ctl_n : 0.0, (unsigned long long)st.tick_max,
          st.ctl_n ? (double)st.tick_sum / st.ctl_n : 0.0, kFreq / RIG_TICK_HZ, ivmin, ivmax,
          st.iv_max_s, jitter, flood_len > 0 ? st.flood_ticks / flood_len : 0.0, st.flood_iv_max * cyc_us,
          o.fault_at,
          st.fault_visible_cycle == UINT64_MAX ? -1.0 : st.fault_visible_cycle / static_cast<double>(kFreq),
          st.heater_off_s, (unsigned long long)st.ticks_after_fault_with_heat,
          (unsigned long long)st.bytes_in, (unsigned long long)st.bytes_out, st.wdtcsr, st.plan_short,
          (unsigned long long)st.pass_first_max, (unsigned long long)st.pass_other_max,
          (unsigned long long)st.plan_done_max, st.stack_free, st.sp_min, st.sp_min_run, st.sp_min_pc, st.sp_min_s);
  fclose(f);
}

// An output file with its first line, or nullptr (said on stderr).
FILE* open_out(const std::string& path, const char* first_line) {
  FILE* f = fopen(path.c_str(), "w");
  if (!f) {
    fprintf(stderr, "vrig: cannot write %s\n", path.c_str());
    return nullptr;
  }
  fprintf(f, "%s\n", first_line);
  return f;
}

// Non-blocking stdin lines (when neither --script nor --pty).
struct StdinLines {
  std::string buf;
  bool eof = false;
  void poll_into(std::string& out) {
    if (eof) return;
    struct pollfd p = {0, POLLIN, 0};
    while (::poll(&p, 1, 0) > 0 && (p.revents & (POLLIN | POLLHUP))) {
      char tmp[256];
      const ssize_t n = read(0, tmp, sizeof tmp);
      if (n <= 0) {
        eof = true;
        return;
      }
      out.append(tmp, static_cast<size_t>(n));
    }
  }
};

// ---- the simulated AVR -------------------------------------------------------------------------
struct Rig {
  Options opt;
  avr_t* avr = nullptr;
  vrig::RigWire* plant = nullptr;
  FILE* truth = nullptr;  // --truth
  FILE* pass_trace = nullptr;  // --pass-trace: one line per plan pass
  FILE* tick_trace = nullptr;  // --tick-trace: one line per tick (which tick is the worst, and why)
  long plant_ms = 0;
  // The wire's true displacement (no sensor effect, no noise) every 10 ms of plant time.
  void write_truth(double t) {
    if (truth && plant_ms++ % 10 == 0) fprintf(truth, "%.3f,%.6f\n", t, plant->displacement());
  }
  avr_irq_t* adc0 = nullptr;
  avr_irq_t* uart_in = nullptr;
  bool xon = true;
  std::string tx;  // bytes waiting to go to the AVR
  size_t tx_pos = 0;
  std::vector<ScriptLine> script;
  size_t script_pos = 0;
  StdinLines in;
  Output out;
  Stats st;
  Flood flood;
#ifdef VRIG_HAVE_PTY
  uart_pty_t pty;
#endif
  struct timespec wall0;

  double now() const { return static_cast<double>(avr->cycle) / kFreq; }

  double duty() const {
    const uint8_t* d = avr->data;
    if (!(d[kTCCR1A] & 0x80)) return 0.0;  // COM1A1 off: pin low
    const unsigned icr = d[kICR1L] | (d[kICR1L + 1] << 8);
    const unsigned ocr = d[kOCR1AL] | (d[kOCR1AL + 1] << 8);
    if (icr == 0) return 0.0;
    return sma::min(1.0, (ocr + 1.0) / (icr + 1.0));
  }

  void feed() {
    // Nothing is sent before the firmware's first line (its banner, after Serial.begin): bytes
    // sent earlier would be lost, and script times count from power-on anyway.
    if (opt.pty || st.bytes_out == 0) return;
    bool flooding = opt.flood_from >= 0 && now() >= opt.flood_from && now() < opt.flood_to;
    while (xon) {
      uint8_t b;
      if (tx_pos < tx.size()) {
        b = static_cast<uint8_t>(tx[tx_pos++]);
        if (tx_pos == tx.size()) {
          tx.clear();
          tx_pos = 0;
        }
      } else if (flooding) {
        b = flood.next();
      } else {
        break;
      }
      ++st.bytes_in;
      avr_raise_irq(uart_in, b);
    }
  }

  void plant_tick() {
    const double t = now();
    const double v = RIG_V_SUPPLY * sqrt(duty());
    plant->step(v, kPlantDt);
    write_truth(t + kPlantDt);
    double mv = sensor_mv(plant->measure());
    if (opt.fault_at >= 0 && t >= opt.fault_at) {
      mv = opt.fault_mv;
      if (st.fault_visible_cycle == UINT64_MAX) st.fault_visible_cycle = avr->cycle;
    }
    avr_raise_irq(adc0, static_cast<uint32_t>(mv + 0.5));
    while (script_pos < script.size() && script[script_pos].t <= t) {
      tx += script[script_pos].text;
      tx += '\n';
      ++script_pos;
    }
    if (!opt.pty && script.empty()) in.poll_into(tx);
    feed();
    if (opt.realtime) {
      struct timespec w;
      clock_gettime(CLOCK_MONOTONIC, &w);
      const double wall = (w.tv_sec - wall0.tv_sec) + 1e-9 * (w.tv_nsec - wall0.tv_nsec);
      if (t > wall * opt.speed) usleep(static_cast<useconds_t>((t / opt.speed - wall) * 1e6));
    }
  }

  void marker(uint8_t v) {
    const uint64_t c = avr->cycle;
    if (v == 1) {
      if (st.ticks > 0) {
        const uint64_t iv = c - st.t_start;
        st.iv_min = sma::min(st.iv_min, iv);
        const double t = now();
        if (iv > st.iv_max) {
          st.iv_max = iv;
          st.iv_max_s = t;  // when: to find what delayed it
        }
        if (opt.flood_from >= 0 && t >= opt.flood_from && t < opt.flood_to) {
          st.flood_iv_max = sma::max(st.flood_iv_max, iv);
        }
      } else {
        st.first_tick_s = now();
      }
      const double t = now();
      if (opt.flood_from >= 0 && t >= opt.flood_from && t < opt.flood_to) ++st.flood_ticks;
      st.t_start = c;
      st.pass_n = 0;
      st.plan_done = false;
      st.tick_sees_fault = st.fault_visible_cycle != UINT64_MAX && c >= st.fault_visible_cycle + kAdcFaultCycles;
      st.last_tick_s = t;
      ++st.ticks;
    } else if (v == 2) {
      const uint64_t d = c - st.t_start;
      st.ctl_max = sma::max(st.ctl_max, d);
      if (tick_trace) fprintf(tick_trace, "%llu %.2f %llu\n", (unsigned long long)st.ticks, now(), (unsigned long long)d);
      st.ctl_sum += d;
      ++st.ctl_n;
      if (opt.fault_at >= 0 && now() >= opt.fault_at) {
        if (duty() > 0.0) {
          if (st.tick_sees_fault) ++st.ticks_after_fault_with_heat;
        } else if (st.heater_off_s < 0) st.heater_off_s = now();
      }
    } else if (v == 3) {
      const uint64_t d = c - st.t_start;
      st.tick_max = sma::max(st.tick_max, d);
      st.tick_sum += d;
    } else if (st.plan_done) {  // a call after the tick's planning is done: nothing to time
    } else if (v == 4) {
      st.pass_start = c;
      ++st.pass_n;
    } else if (v == 5 || v == 6) {
      const uint64_t d = c - st.pass_start;
      uint64_t& m = st.pass_n == 1 ? st.pass_first_max : st.pass_other_max;
      m = sma::max(m, d);
      if (v == 6) {
        st.plan_done = true;
        st.plan_done_max = sma::max(st.plan_done_max, c - st.t_start);
      }
      if (pass_trace)
        fprintf(pass_trace, "%llu %u %llu %llu %d\n", (unsigned long long)st.ticks, st.pass_n,
                (unsigned long long)(st.pass_start - st.t_start), (unsigned long long)d, v == 6);
    }
  }
};

Rig* g_rig = nullptr;
volatile sig_atomic_t g_stop = 0;
// Ctrl-C ends the run cleanly (log and JSON written).
void on_sigint(int) { g_stop = 1; }

void noop_sleep(avr_t*, avr_cycle_count_t) {}
void (*g_chained_reset)(avr_t*) = nullptr;
bool g_wdrf_at_reset = false;
void paint_reset(avr_t* avr) {
  if (g_chained_reset) g_chained_reset(avr);
  for (uint32_t a = avr->ioend + 1u; a <= avr->ramend; ++a) avr->data[a] = 0xA5;  // SRAM only
  if (g_wdrf_at_reset) avr->data[0x54] |= 0x08;  // MCUSR.WDRF
}

avr_cycle_count_t plant_cb(avr_t*, avr_cycle_count_t when, void*) {
  g_rig->plant_tick();
  return when + kPlantCycles;
}
// Stack depth: every SP write (pushes, pops, frame set-up) lands here. SP is two registers written
// one after the other (code: SPH then SPL; simavr's push/pop: SPL then SPH), so the value after
// the first write can be a transient: a value is committed only if no other SP write follows
// within 4 cycles.
void sp_commit(Stats& st) {
  if (st.ticks > 0 && st.sp_pending >= 0x100 && st.sp_pending < st.sp_min_run) st.sp_min_run = st.sp_pending;
  if (st.sp_pending >= 0x100 && st.sp_pending < st.sp_min) {
    st.sp_min = st.sp_pending;
    st.sp_min_pc = st.sp_pending_pc;
    st.sp_min_s = st.sp_pending_cycle / static_cast<double>(kFreq);
  }
}
void sp_cb(avr_t* avr, avr_io_addr_t addr, uint8_t v, void*) {
  avr->data[addr] = v;
  Stats& st = g_rig->st;
  if (avr->cycle - st.sp_pending_cycle > 4) sp_commit(st);
  st.sp_pending = static_cast<uint16_t>(avr->data[0x5D] | (avr->data[0x5E] << 8));
  st.sp_pending_cycle = avr->cycle;
  st.sp_pending_pc = avr->pc;
}
void gpior_cb(avr_t* avr, avr_io_addr_t addr, uint8_t v, void*) {
  avr->data[addr] = v;
  g_rig->marker(v);
}
void uart_out_cb(avr_irq_t*, uint32_t value, void*) {
  ++g_rig->st.bytes_out;
  g_rig->out.byte(static_cast<uint8_t>(value), g_rig->now());
}
void xon_cb(avr_irq_t*, uint32_t, void*) {
  g_rig->xon = true;
  g_rig->feed();
}
void xoff_cb(avr_irq_t*, uint32_t, void*) { g_rig->xon = false; }

// --eeprom: the 1 KB EEPROM from/to a file (a missing file = an erased EEPROM, all 0xFF).
// (simavr 1.6's AVR_IOCTL_EEPROM_GET/SET answer -1 here: the EEPROM module is found by its kind.)
avr_eeprom_t* find_eeprom(avr_t* avr) {
  for (avr_io_t* p = avr->io_port; p; p = p->next)
    if (p->kind && strcmp(p->kind, "eeprom") == 0) return reinterpret_cast<avr_eeprom_t*>(p);
  return nullptr;
}
bool eeprom_io(avr_t* avr, const std::string& path, bool save) {
  avr_eeprom_t* ee = find_eeprom(avr);
  if (!ee || !ee->eeprom || ee->size != 1024) {
    fprintf(stderr, "vrig: no 1 KB EEPROM in the simulated MCU\n");
    return false;
  }
  if (save) {
    FILE* fo = fopen(path.c_str(), "wb");
    if (!fo || fwrite(ee->eeprom, 1, ee->size, fo) != ee->size) {
      fprintf(stderr, "vrig: cannot write --eeprom %s\n", path.c_str());
      if (fo) fclose(fo);
      return false;
    }
    fclose(fo);
    return true;
  }
  memset(ee->eeprom, 0xFF, ee->size);
  FILE* fi = fopen(path.c_str(), "rb");
  if (fi) {
    const size_t n = fread(ee->eeprom, 1, ee->size, fi);
    fclose(fi);
    if (n != ee->size) {
      fprintf(stderr, "vrig: --eeprom %s: expected %u bytes, found %zu\n", path.c_str(), ee->size, n);
      return false;
    }
  }
  return true;
}

int run_avr(Rig& rig) {
  elf_firmware_t f;
  memset(&f, 0, sizeof f);
  if (elf_read_firmware(rig.opt.elf.c_str(), &f) != 0) {
    fprintf(stderr, "vrig: cannot read ELF %s\n", rig.opt.elf.c_str());
    return 2;
  }
  snprintf(f.mmcu, sizeof f.mmcu, "%s", rig.opt.mcu.c_str());
  f.frequency = kFreq;
  f.vcc = f.avcc = f.aref = 5000;
  avr_t* avr = avr_make_mcu_by_name(f.mmcu);
  if (!avr) {
    fprintf(stderr, "vrig: --mcu %s: not an MCU simavr knows\n", f.mmcu);
    return 2;
  }
  avr_init(avr);
  avr_load_firmware(avr, &f);
  if (!rig.opt.eeprom.empty() && !eeprom_io(avr, rig.opt.eeprom, false)) return 2;
  avr->frequency = kFreq;
  avr->vcc = avr->avcc = avr->aref = 5000;
  avr->sleep = noop_sleep;
  avr->log = 1;
  // Paint the SRAM at reset: the startup code overwrites .data and .bss, the stack the rest;
  // the longest untouched run is the free margin between .bss and the deepest stack.
  g_chained_reset = avr->reset;
  g_wdrf_at_reset = rig.opt.wdrf;
  avr->reset = paint_reset;
  avr_reset(avr);
  rig.avr = avr;

  uint32_t flags = 0;
  avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
  flags &= ~AVR_UART_FLAG_STDIO;
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out_cb, nullptr);
  if (rig.opt.pty) {
#ifndef VRIG_HAVE_PTY
    fprintf(stderr, "vrig: built without libsimavrparts: no --pty\n");
    return 2;
#else
    uart_pty_init(avr, &rig.pty);
    uart_pty_connect(&rig.pty, '0');
    fprintf(stderr, "vrig: UART0 on %s (also /tmp/simavr-uart0)\n", rig.pty.pty.slavename);
#endif
  } else {
    rig.uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), xon_cb, nullptr);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), xoff_cb, nullptr);
  }
  rig.adc0 = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0);
  avr_register_io_write(avr, kGPIOR0, gpior_cb, nullptr);
  avr_register_io_write(avr, 0x5D, sp_cb, nullptr);
  avr_register_io_write(avr, 0x5E, sp_cb, nullptr);
  // Sensor at rest before the firmware's first conversion.
  avr_raise_irq(rig.adc0, static_cast<uint32_t>(sensor_mv(rig.plant->measure()) + 0.5));
  avr_cycle_timer_register(avr, kPlantCycles, plant_cb, nullptr);

  clock_gettime(CLOCK_MONOTONIC, &rig.wall0);
  const uint64_t end = static_cast<uint64_t>(rig.opt.duration * kFreq);
  int state = cpu_Running;
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_sigint;
  sigaction(SIGINT, &sa, nullptr);
  sma_host::ProgressLine progress("vrig: simulated s", rig.opt.quiet && !rig.opt.pty ? rig.opt.duration : 0.0);
  while (avr->cycle < end && !g_stop) {
    progress(static_cast<double>(avr->cycle) / kFreq);
    state = avr_run(avr);
    if (state == cpu_Done || state == cpu_Crashed) break;
  }
  // (No uart_pty_stop(): in simavr 1.6 it signals the pty thread and joins a loop that does not
  // end; the thread ends with the process.)
  // A line the run's end cut off: shown, never logged as a row (is_row would refuse most, not
  // one that ends inside its last number).
  if (!rig.out.line.empty()) {
    if (!rig.opt.quiet) printf("%s\n", rig.out.line.c_str());
    rig.out.line.clear();
  }
  {
    // Longest run of paint below RAMEND's stack: the free margin between .bss/heap and stack.
    uint32_t best = 0, run = 0;
    for (uint32_t a = avr->ioend + 1u; a <= avr->ramend; ++a) {
      run = avr->data[a] == 0xA5 ? run + 1 : 0;
      if (run > best) best = run;
    }
    rig.st.stack_free = best;
    rig.st.wdtcsr = avr->data[0x60];
    rig.st.plan_short = avr->data[kGPIOR2];
    sp_commit(rig.st);
  }
  write_json(rig.opt, rig.st, "elf", rig.now());
  if (!rig.opt.eeprom.empty() && !eeprom_io(avr, rig.opt.eeprom, true)) return 2;
  if (state == cpu_Crashed) {
    fprintf(stderr, "vrig: the AVR crashed at %.3f s\n", rig.now());
    return 3;
  }
  return 0;
}

// ---- native: the firmware's sma::Board on the host, same plant and script ----------------------
// The same unit as firmware/src/main.cpp with the same rig constants (rig_board.h) and features
// as the float image (RIG_FEATURE_*), driven by the host's one harness (sma_host/board_loop.hpp:
// ADC samples every 1 ms, PWM counts back to volts, the EEPROM in RAM; --eeprom loads and saves it).
typedef sma_host::BoardLoop<RigBoard, vrig::RigWire> NativeLoop;

bool native_eeprom_io(uint8_t* ee, const std::string& path, bool save) {
  if (save) {
    FILE* fo = fopen(path.c_str(), "wb");
    const bool ok = fo && fwrite(ee, 1, 1024, fo) == 1024;
    if (fo) fclose(fo);
    if (!ok) fprintf(stderr, "vrig: cannot write --eeprom %s\n", path.c_str());
    return ok;
  }
  if (FILE* fi = fopen(path.c_str(), "rb")) {
    const size_t n = fread(ee, 1, 1024, fi);
    fclose(fi);
    (void)n;
  }
  return true;
}

int run_native(Rig& rig) {
  sma_host::BoardLoopOptions lo;
  lo.sample_s = kPlantDt;
  lo.fault_at_s = rig.opt.fault_at;
  lo.fault_mv = rig.opt.fault_mv;
  NativeLoop loop(*rig.plant, lo);
  loop.set_sink([&rig](double t, const std::string& line) {
    for (char c : line) rig.out.byte(static_cast<uint8_t>(c), t);
    rig.out.byte('\n', t);
  });
  loop.on_sample = [&rig](double t) { rig.write_truth(t); };
  if (!rig.opt.eeprom.empty() && !native_eeprom_io(loop.eeprom(), rig.opt.eeprom, false)) return 2;
  loop.boot(rig.opt.wdrf, "# sma_firmware float ready: heater off; try help");
  const double dt = NativeLoop::kDt;
  const long n_ticks = static_cast<long>(rig.opt.duration * RIG_TICK_HZ);
  sma_host::ProgressLine progress("vrig --native: simulated s", rig.opt.quiet ? rig.opt.duration : 0.0);
  for (long k = 0; k < n_ticks; ++k) {
    const double t = k * dt;
    progress(t);
    // Console input due by now.
    while (rig.script_pos < rig.script.size() && rig.script[rig.script_pos].t <= t)
      loop.send_bytes(rig.script[rig.script_pos++].text + "\n");
    ++rig.st.ticks;
    loop.tick();
  }
  rig.st.plan_short = loop.board().plan_short();
  write_json(rig.opt, rig.st, "native", n_ticks * dt);
  if (!rig.opt.eeprom.empty() && !native_eeprom_io(loop.eeprom(), rig.opt.eeprom, true)) return 2;
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Rig rig;
  g_rig = &rig;
  Options& o = rig.opt;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto val = [&]() -> const char* {
      if (i + 1 >= argc) {
        fprintf(stderr, "vrig: %s needs a value\n", a.c_str());
        exit(2);
      }
      return argv[++i];
    };
    if (a == "--duration") o.duration = atof(val());
    else if (a == "--script") o.script = val();
    else if (a == "--log") o.log = val();
    else if (a == "--cycles-json") o.cycles_json = val();
    else if (a == "--pass-trace") o.pass_trace = val();
    else if (a == "--tick-trace") o.tick_trace = val();
    else if (a == "--pty") o.pty = o.realtime = true;
    else if (a == "--realtime") o.realtime = true;
    else if (a == "--speed") o.speed = atof(val());
    else if (a == "--native") o.native = true;
    else if (a == "--wdrf") o.wdrf = true;
    else if (a == "--mcu") o.mcu = val();
    else if (a == "--quiet") o.quiet = true;
    else if (a == "--stamp") o.stamp = true;
    else if (a == "--noise-mm") o.noise_mm = atof(val());
    else if (a == "--seed") o.seed = strtoull(val(), nullptr, 10);
    else if (a == "--effect") o.effect_args.push_back(val());
    else if (a == "--params") o.params = val();
    else if (a == "--eeprom") o.eeprom = val();
    else if (a == "--truth") o.truth = val();
    else if (a == "--plant") o.plant = val();
    else if (a == "--sensor-fault") {
      const char* s = val();
      o.fault_at = atof(s);
      if (const char* c = strchr(s, ':')) o.fault_mv = atof(c + 1);
    } else if (a == "--flood") {
      const char* s = val();
      const char* c = strchr(s, ':');
      if (!c) {
        fprintf(stderr, "vrig: --flood T1:T2\n");
        return 2;
      }
      o.flood_from = atof(s);
      o.flood_to = atof(c + 1);
    } else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else if (o.elf.empty() && (a[0] != '-' || a == "-")) {
      o.elf = a;
    } else {
      fprintf(stderr, "vrig: unknown option %s\n", a.c_str());
      usage();
      return 2;
    }
  }
  if (o.elf.empty() && !o.native) {
    usage();
    return 2;
  }
  if (!(o.duration > 0)) {
    fprintf(stderr, "vrig: --duration must be > 0\n");
    return 2;
  }
  if (!(o.speed > 0 && o.speed <= 1000)) {
    fprintf(stderr, "vrig: --speed must be in (0, 1000]\n");
    return 2;
  }
  sma::Params wire;
  try {
    const sma_tools::Model m = sma_tools::read_model(o.params);
    wire = m.p;
    o.fx = m.fx;
  } catch (const std::exception& e) {
    fprintf(stderr, "vrig: --params: %s\n", e.what());
    return 2;
  }
  for (const std::string& e : o.effect_args) {
    const std::string problem = set_effect(o.fx, e.c_str());
    if (!problem.empty()) {
      fprintf(stderr, "vrig: %s\n", problem.c_str());
      return 2;
    }
  }
  if (const sma::param::Violation v = o.fx.check()) {
    fprintf(stderr, "vrig: --effect: %s\n", sma_tools::violation_text(v).c_str());
    return 2;
  }
  if (!o.script.empty() && !read_script(o.script, rig.script)) return 2;
  if (!o.script.empty() || o.pty) o.use_stdin = false;
  rig.out.opt = &o;
  if (!o.log.empty()) {
    rig.out.log = fopen(o.log.c_str(), "w");
    if (!rig.out.log) {
      fprintf(stderr, "vrig: cannot write %s\n", o.log.c_str());
      return 2;
    }
    fprintf(rig.out.log, "# rig: vrig %s noise_mm=%g plant=%s\n", o.native ? "native" : o.elf.c_str(), o.noise_mm,
            o.plant.c_str());
  }
  if (!o.truth.empty() && !(rig.truth = open_out(o.truth, "t_s,true_mm"))) return 2;
  if (!o.pass_trace.empty() && !(rig.pass_trace = open_out(o.pass_trace, "# tick pass start_cycles length_cycles done")))
    return 2;
  if (!o.tick_trace.empty() && !(rig.tick_trace = open_out(o.tick_trace, "# tick t_s control_cycles"))) return 2;
  sma::RigOptions ro;
  ro.noise_mm = o.noise_mm;
  ro.v_supply = RIG_V_SUPPLY;
  ro.seed = o.seed;
  std::unique_ptr<vrig::RigWire> plant;  // on the heap: ~130 KB of sensor history
  if (o.plant == "library") {
    plant.reset(new vrig::LibraryWire(wire, o.fx, ro));
  } else if (o.plant == "b" || o.plant == "b-rpm") {
    std::string problem;
    plant = vrig::make_plant_b(wire, o.fx, o.plant == "b", o.noise_mm, kPlantDt, o.seed, problem);
    if (!plant) {
      fprintf(stderr, "vrig: %s\n", problem.c_str());
      return 2;
    }
  } else {
    fprintf(stderr, "vrig: --plant must be library, b or b-rpm, not '%s'\n", o.plant.c_str());
    return 2;
  }
  rig.plant = plant.get();
  const int rc = o.native ? run_native(rig) : run_avr(rig);
  if (rig.out.log) fclose(rig.out.log);
  if (rig.truth) fclose(rig.truth);
  if (rig.pass_trace) fclose(rig.pass_trace);
  if (rig.tick_trace) fclose(rig.tick_trace);
  fflush(stdout);
  return rc;
}
