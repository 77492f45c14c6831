// SMA actuator firmware for the Arduino Uno: Arduino glue around the header-only library.
//
//   Timer2 CTC 1 kHz --/10--> tick flag (100 Hz, crystal-exact, no drift)
//   ADC0 ISR chain: every conversion is summed; the tick averages its ~96 samples
//   loop(): serial console (one line at most per pass) | on tick: sensor -> reference ->
//           controller (eq 18) -> safety latch -> Timer1 PWM (duty = (V/Vs)^2) -> telemetry
//
// GPIOR0 markers (read by the virtual rig, tools/vrig, for exact cycle counts):
//   1 = control section starts, 2 = control section ends (PWM written),
//   3 = telemetry/console output of the tick ends.
// Scalar type: float, or sma::Fixed (Q16.16) when built with -DSMA_FIRMWARE_FIXED.
// The library first: Arduino.h defines min, max, abs, round... as macros, which would break
// the library's templates of the same names if they came after it.
#include "rig_config.h"
#include "sma/console.hpp"
#include "sma/controller.hpp"
#include "sma/reference.hpp"
#include "sma/safety.hpp"
#ifdef SMA_FIRMWARE_FIXED
#include "sma/fixed.hpp"
typedef sma::Fixed Scalar;
#define FW_VARIANT "fixed"
#else
typedef float Scalar;
#define FW_VARIANT "float"
#endif

#include <Arduino.h>
#include <new.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>
#undef min
#undef max
#undef abs
#undef round

namespace con = sma::console;

// ---- reset cause: saved before anything else runs ----------------------------------------------
// Optiboot clears MCUSR and passes it in r2; a plain reset leaves it in MCUSR. Keep both, clear
// MCUSR and stop a watchdog that survived the reset (it stays on after a watchdog reset).
uint8_t g_reset_cause __attribute__((section(".noinit")));
extern "C" void fw_early_init(void) __attribute__((naked, used, section(".init3")));
extern "C" void fw_early_init(void) {
  uint8_t r2 = 0;
#if RIG_RESET_CAUSE_FROM_R2
  __asm__ __volatile__("mov %0, r2" : "=r"(r2));
  r2 &= 0x0F;  // PORF, EXTRF, BORF, WDRF only
#endif
  g_reset_cause = static_cast<uint8_t>(MCUSR | r2);
  MCUSR = 0;
  wdt_disable();
  // Heater gate low as early as possible.
  PORTB &= static_cast<uint8_t>(~_BV(PB1));
  DDRB |= _BV(PB1);
}

// ---- tick and ADC ISRs -------------------------------------------------------------------------
static volatile uint8_t g_tick_pending = 0;
static volatile uint32_t g_ticks_isr = 0;  // ticks raised by the timer
static volatile uint8_t g_div = 0;

ISR(TIMER2_COMPA_vect) {
  if (++g_div >= RIG_TIMER2_DIV) {
    g_div = 0;
    ++g_ticks_isr;
    g_tick_pending = 1;
  }
}

// ADC counts of the valid sensor range.
static const uint16_t kAdcLo =
    static_cast<uint16_t>(RIG_SENSOR_V_MIN / RIG_ADC_VREF * RIG_ADC_COUNTS + 0.5);
static const uint16_t kAdcHi =
    static_cast<uint16_t>(RIG_SENSOR_V_MAX / RIG_ADC_VREF * RIG_ADC_COUNTS + 0.5);
static volatile uint32_t g_adc_sum = 0;
static volatile uint8_t g_adc_n = 0;
static volatile uint8_t g_adc_bad = 0;

ISR(ADC_vect) {
  const uint16_t a = ADC;
  if (g_adc_n < 255) {
    g_adc_sum += a;
    ++g_adc_n;
    if (a < kAdcLo || a > kAdcHi) ++g_adc_bad;
  }
  ADCSRA |= _BV(ADSC);  // next conversion (13 ADC clocks at 125 kHz: 104 us)
}

// ---- the control objects -----------------------------------------------------------------------
static sma::ControllerConfig make_cfg() {
  sma::ControllerConfig c;
  c.dt = 1.0 / RIG_TICK_HZ;
  c.v_max = RIG_V_MAX;
  c.gains = con::default_gains(sma::Mode::FeedforwardPid);
  return c;
}
static sma::SafetyConfig make_safety_cfg() {
  sma::SafetyConfig c;
  c.t_limit_C = RIG_T_LIMIT_C;
  c.sensor_v_min = RIG_SENSOR_V_MIN;
  c.sensor_v_max = RIG_SENSOR_V_MAX;
  c.link_timeout_s = RIG_LINK_TIMEOUT_S;
  c.dt = 1.0 / RIG_TICK_HZ;
  return c;
}

static con::State g_state;

// RAM is 2 KB and the stack shares it. The controller and the reference generator are built in
// place: sma::Params (193 B) lives only while the models compute their constants, in the
// generator's storage. Where a large temporary is unavoidable (a Reference at the start of a
// run, the Effects at boot) it sits in a noinline function that is never on the stack together
// with the control tick: the deepest stack is the larger of the paths, not their sum (measured
// by tools/vrig: sp_min in --cycles-json).
// The heavy functions below are noinline: inlined into loop() their frames would add up
// (measured: a 186-byte frame for main).
typedef sma::Controller<Scalar> Ctl;
typedef sma::ReferenceGen<Scalar> Gen;
// Storage without construction at static-init time (the objects are built in setup()).
union CtlStore {
  CtlStore() {}
  ~CtlStore() {}
  Ctl obj;
};
union GenStore {  // the generator, or the Params while the models are built
  GenStore() {}
  ~GenStore() {}
  Gen obj;
  sma::Params params;
};
static CtlStore g_ctl_store;
static GenStore g_gen_store;
#define g_ctl (g_ctl_store.obj)
#define g_gen (g_gen_store.obj)

// (Re)starts the generator on the console's reference (the old one is trivially destructible).
static void __attribute__((noinline)) start_reference() {
  const sma::Reference r = g_state.reference();
  new (&g_gen_store.obj) Gen(r);
}

static void __attribute__((noinline)) build_models() {
  sma::Params* p = new (&g_gen_store.params) sma::Params();
  const sma::Effects fx;
  new (&g_ctl_store.obj) Ctl(*p, fx, make_cfg());
  p->~Params();
}

static sma::Safety g_safety(make_safety_cfg());
static con::LineBuffer g_line;
static con::Reply g_reply;
static con::Live g_live;

static uint32_t g_ticks = 0;      // ticks processed
static uint32_t g_run_start = 0;  // tick at which the running reference started
static uint16_t g_run_seen = 0;
static uint16_t g_overruns = 0;   // ticks that found the previous one still pending
static float g_last_mm = 0.0f;
static bool g_header_due = false;

// ---- heater PWM --------------------------------------------------------------------------------
static void pwm_init() {
  OCR1A = 0;
  ICR1 = static_cast<uint16_t>(RIG_PWM_TOP);
  // Mode 14 (WGM13:0 = 1110), output disconnected until a non-zero duty, prescaler 1.
  TCCR1A = _BV(WGM11);
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS10);
  TCNT1 = 0;
}

// Effective volts -> counts n, duty = n / (TOP + 1); n = 0 disconnects OC1A (pin low: fast PWM
// with OCR1A = 0 would still give a 1-count pulse).
static uint16_t pwm_write(float v) {
  const float top1 = static_cast<float>(RIG_PWM_TOP + 1UL);
  float duty = v / static_cast<float>(RIG_V_SUPPLY);
  duty = duty * duty;
  float nf = duty * top1 + 0.5f;
  if (!(nf >= 1.0f)) nf = 0.0f;  // also NaN
  if (nf > top1) nf = top1;
  const uint16_t n = static_cast<uint16_t>(nf);
  if (n == 0) {
    TCCR1A = _BV(WGM11);  // COM1A1 = 0: OC1A back to PORTB1 = 0
  } else {
    OCR1A = static_cast<uint16_t>(n - 1u);
    TCCR1A = _BV(COM1A1) | _BV(WGM11);
  }
  return n;
}

// ---- serial output: never stalls the tick -----------------------------------------------------
// A line waits for room in the TX buffer only until the next tick is due (115200 baud drains a
// telemetry row in 3.5 ms), then it is dropped and counted (status: drop=).
#if SERIAL_TX_BUFFER_SIZE < 128
#warning "SERIAL_TX_BUFFER_SIZE < 128: replies longer than the buffer block loop() for a few ms; build the core and the sketch with -DSERIAL_TX_BUFFER_SIZE=128"
#endif
static void send_line(const char* s, uint8_t len) {
  if (static_cast<int>(len) + 2 > SERIAL_TX_BUFFER_SIZE - 1) {  // can never fit: blocking write
    Serial.write(reinterpret_cast<const uint8_t*>(s), len);
    Serial.write('\r');
    Serial.write('\n');
    return;
  }
  while (Serial.availableForWrite() < static_cast<int>(len) + 2 && !g_tick_pending) {
  }
  if (Serial.availableForWrite() < static_cast<int>(len) + 2) {
    if (g_live.dropped < 0xFFFFu) ++g_live.dropped;
    return;
  }
  Serial.write(reinterpret_cast<const uint8_t*>(s), len);
  Serial.write('\r');
  Serial.write('\n');
}
static void send_reply() {
  if (g_reply.len) send_line(g_reply.text, g_reply.len);
}

// ---- console -----------------------------------------------------------------------------------
// Makes the controller and the latch follow the console state after an OK.
static void __attribute__((noinline)) sync_state(const con::Command& c, bool tele_before) {
  if (c.op == con::Op::Stop) g_safety.clear();
  g_safety.set_limit(g_state.tlim_C);
  g_ctl.set_voltage(static_cast<Scalar>(sma::from_double<Scalar>(g_state.volt)));
  const sma::Mode m = g_state.active_mode();
  if (m != g_ctl.mode()) g_ctl.set_mode(m, sma::from_double<Scalar>(g_last_mm));
  if (c.op == con::Op::Gains || c.op == con::Op::SetMode) g_ctl.set_gains(g_state.gains());
  if (g_state.run != g_run_seen) {
    g_run_seen = g_state.run;
    start_reference();
    g_run_start = g_ticks;
  }
  if (c.op == con::Op::Tele && c.on && !tele_before) g_header_due = true;  // once per start
}

static void __attribute__((noinline)) handle_line_status(con::LineBuffer::Status st) {
  if (st == con::LineBuffer::Status::Line) {
    con::Command c;
    const bool tele_before = g_state.tele;
    if (con::execute(g_line.line(), g_state, g_safety.fault(), g_reply, con::Limits(), &c)) {
      if (c.op == con::Op::Status) con::status_line(g_reply, g_state, g_live);
      sync_state(c, tele_before);
    }
  } else {
    con::line_error(st, g_reply);
  }
  send_reply();
}

// Reads bytes until one line is complete or a tick is due.
static void __attribute__((noinline)) poll_serial() {
  while (!g_tick_pending && Serial.available() > 0) {
    const int b = Serial.read();
    if (b < 0) break;
    g_safety.on_rx();
    const con::LineBuffer::Status st = g_line.push(static_cast<char>(b));
    if (st != con::LineBuffer::Status::Pending) {
      handle_line_status(st);
      break;
    }
  }
}

// ---- the tick ----------------------------------------------------------------------------------
static void __attribute__((noinline)) control_tick() {
  GPIOR0 = 1;
  // Sensor: average of the samples since the last tick.
  uint32_t sum;
  uint8_t n, bad;
  cli();
  sum = g_adc_sum;
  n = g_adc_n;
  bad = g_adc_bad;
  g_adc_sum = 0;
  g_adc_n = 0;
  g_adc_bad = 0;
  sei();
  const float volts = n ? static_cast<float>(sum) / static_cast<float>(n) *
                              static_cast<float>(RIG_ADC_VREF / RIG_ADC_COUNTS)
                        : -1.0f;  // no sample: sensor lost
  const float mm = static_cast<float>(RIG_SENSOR_MM_PER_V) * volts + static_cast<float>(RIG_SENSOR_OFFSET_MM);
  g_last_mm = mm;

  // Reference and controller.
  const float t_ref = static_cast<float>(g_ticks - g_run_start) * (1.0f / RIG_TICK_HZ);
  const Scalar ref = g_gen.at(t_ref);
  const Scalar v_cmd = g_ctl.step(ref, sma::from_double<Scalar>(mm));

  // Safety latch.
  sma::SafetyInput in;
  in.sensor_v = volts;
  in.samples_in_range = bad == 0 && n > 0;
  in.measured_mm = mm;
  in.wire_temp_C = static_cast<float>(sma::to_double(g_ctl.wire_temperature()));
  in.command_v = static_cast<float>(sma::to_double(v_cmd));
  in.heating = g_state.heat;
  const float v = static_cast<float>(g_safety.gate(in));
  if (g_safety.tripped() && g_state.heat) {
    g_state.heat = false;
    g_ctl.set_mode(sma::Mode::Off, sma::from_double<Scalar>(mm));
  }
  const uint16_t counts = pwm_write(v);
  GPIOR0 = 2;
  wdt_reset();

  g_live.ticks = g_ticks;
  g_live.t_ref_s = t_ref;
  g_live.d_mm = mm;
  g_live.ref_mm = static_cast<float>(sma::to_double(ref));
  g_live.v = v;
  g_live.temp_C = in.wire_temp_C;
  g_live.fault = g_safety.fault();

  if (g_state.tele) {
    if (g_header_due) {
      g_reply.clear();
      g_reply.put_f(con::telemetry_header());
      send_line(g_reply.text, g_reply.len);
      g_header_due = false;
    }
    con::telemetry_row(g_reply, g_ticks, RIG_TICK_HZ, v, mm, g_live.ref_mm,
                       static_cast<float>(counts) / static_cast<float>(RIG_PWM_TOP + 1UL));
    send_line(g_reply.text, g_reply.len);
  }
  ++g_ticks;
  GPIOR0 = 3;
}

void setup() {
  // First: the models' construction below runs the deepest stack, close to .noinit.
  const bool wdrf = (g_reset_cause & _BV(WDRF)) != 0;
  pwm_init();
  // The deepest stack of the run (models' constructors): no ISR on top of it.
  cli();
  build_models();
  sei();
  start_reference();
  g_live.temp_C = static_cast<float>(sma::to_double(g_ctl.wire_temperature()));
  // Timer2: CTC, prescaler 64, 16 MHz / 64 / 250 = 1 kHz.
  TCCR2A = _BV(WGM21);
  TCCR2B = _BV(CS22);
  OCR2A = RIG_TIMER2_OCR;
  TCNT2 = 0;
  TIMSK2 = _BV(OCIE2A);
  // ADC: AVcc reference, channel 0, prescaler 128 (125 kHz), interrupt chain.
  ADMUX = _BV(REFS0) | (RIG_SENSOR_CHANNEL & 0x07);
  DIDR0 = _BV(RIG_SENSOR_CHANNEL);
  ADCSRA = _BV(ADEN) | _BV(ADIE) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);
  ADCSRA |= _BV(ADSC);

  Serial.begin(RIG_BAUD);
  g_safety.boot(wdrf);
  g_reply.clear();
  g_reply.put_f(SMA_F("# sma_firmware " FW_VARIANT " ready: heater off; help lists commands"));
  send_reply();
  if (wdrf) {
    g_reply.clear();
    g_reply.put_f(SMA_F("# fault watchdog: the last run hung; send stop to clear"));
    send_reply();
  }
  wdt_enable(WDTO_250MS);
}

void loop() {
  poll_serial();
  if (g_tick_pending) {
    cli();
    const uint32_t raised = g_ticks_isr;
    g_tick_pending = 0;
    sei();
    // Ticks lost while the previous one ran too long (never expected: counted for status).
    if (raised > g_ticks + 1u && g_overruns < 0xFFFFu) {
      ++g_overruns;
      g_live.overruns = g_overruns;
      g_ticks = raised - 1u;
    }
    control_tick();
  }
}
