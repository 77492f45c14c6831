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
#include "sma/storage.hpp"
#include "sma/training.hpp"
// Features that do not all fit in 32 KB of flash (see firmware/README.md):
//   FW_MODEL (default on for float): model parameters in EEPROM (pbegin/pset/pcommit/pget/pinfo)
//   FW_TRAIN (-DSMA_FIRMWARE_TRAIN): the built-in training run (train)
#ifndef FW_MODEL
#ifdef SMA_FIRMWARE_FIXED
#define FW_MODEL 0
#else
#define FW_MODEL 1
#endif
#endif
#ifdef SMA_FIRMWARE_TRAIN
#define FW_TRAIN 1
#else
#define FW_TRAIN 0
#endif
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
#include <avr/eeprom.h>
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
struct Training {      // the training signal being played (train)
  sma::TrainingPlan plan;
  uint32_t end_ticks;  // its length in ticks
};
union GenStore {  // the generator, or the Params while the models are built, or a training plan
  GenStore() {}
  ~GenStore() {}
  Gen obj;
  sma::Params params;
  Training train;
};
static CtlStore g_ctl_store;
static GenStore g_gen_store;
#define g_ctl (g_ctl_store.obj)
#define g_gen (g_gen_store.obj)

// (Re)starts the generator on the console's reference (the old one is trivially destructible).
static bool g_training = false;   // g_gen_store holds a Training (not a Gen)
static void __attribute__((noinline)) start_reference() {
  g_training = false;
  const sma::Reference r = g_state.reference();
  new (&g_gen_store.obj) Gen(r);
}

// ---- model parameters in EEPROM (sma/storage.hpp): two slots, CRC, commit mark ----------------
// eeprom_update_byte waits for the previous write (3.4 ms each): the watchdog is fed between
// bytes. Writing happens only with the heater off (the console refuses otherwise).
struct AvrEeprom {
  uint8_t read(uint16_t a) const {
    return eeprom_read_byte(reinterpret_cast<const uint8_t*>(static_cast<uintptr_t>(a)));
  }
  void write(uint16_t a, uint8_t v) {
    wdt_reset();
    eeprom_update_byte(reinterpret_cast<uint8_t*>(static_cast<uintptr_t>(a)), v);
  }
};
static sma::storage::Store<AvrEeprom> g_store;

// The one place the controller is constructed (its constructor is large: inlined twice it
// would cost kilobytes of flash).
// Interrupts off meanwhile: this is the deepest stack of the firmware, no ISR frame on top.
static void __attribute__((noinline)) construct_ctl(const sma::Params& p, const sma::Effects& fx) {
  const uint8_t sreg = SREG;
  cli();
  new (&g_ctl_store.obj) Ctl(p, fx, make_cfg());
  SREG = sreg;
}

// A set is valid when the controller built from it is (Controller::valid(): Params::check(),
// Effects::check()). Reading check()'s messages would keep ~600 B of them in RAM.
struct FwValidator {
  const char* operator()(const sma::Params& p, const sma::Effects& fx, uint8_t& bad_key) const {
    bad_key = sma::storage::kNoKey;
    construct_ctl(p, fx);
    return g_ctl.valid() ? nullptr : SMA_F("invalid model");
  }
};

// The paper's values into `p`, in one place: its constructor is ~500 B of stores, and two
// inlined copies did not fit the flash.
static void __attribute__((noinline)) paper_params(sma::Params* p) { new (p) sma::Params(); }

// The controller from the active set in EEPROM, or the paper's values when there is none.
// The Params live in the generator's storage meanwhile (call start_reference() afterwards).
static void __attribute__((noinline)) build_models() {
  sma::Params* p = &g_gen_store.params;
  sma::Effects fx;
  if (!FW_MODEL || g_store.load(*p, fx, FwValidator()) < 0) {  // builds the controller from each candidate
    paper_params(p);
    new (&fx) sma::Effects();
    construct_ctl(*p, fx);
  }
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
static bool g_train_done = false; // "# train done" is due
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
// After a long EEPROM operation: the ticks it blocked are not overruns (heater off meanwhile).
// (A tick raised meanwhile stays pending and runs next.)
static void resync_ticks() {
  cli();
  g_ticks = g_tick_pending ? g_ticks_isr - 1u : g_ticks_isr;
  sei();
}

// The model commands (sma/storage.hpp via con::model_command) on `p`, a scratch Params.
// pcommit builds the controller from the staged set (FwValidator); refused, the controller is
// rebuilt from the active set.
static void __attribute__((noinline)) model_op(const con::Command& c, sma::Params* p) {
  paper_params(p);  // the defaults (pbegin and pget read them when no set is active)
  sma::Effects fx;
  if (!con::model_command(c, g_store, *p, fx, g_reply, FwValidator()) && c.op == con::Op::PCommit)
    build_models();
}

// A model command waits here for loop() to run it at the top of the stack: pcommit builds the
// controller (the deepest stack of the firmware) and must not do it below the console's frames.
struct PendingModelOp {
  con::Op op;
  uint8_t key;
  float a;
};
static PendingModelOp g_model_op = {con::Op::Empty, 0, 0.0f};

// pbegin / pcommit need the heater off (the console refuses them otherwise): their scratch is
// the generator's storage, the reference restarts afterwards.
static void __attribute__((noinline)) model_write(const con::Command& c) {
  model_op(c, &g_gen_store.params);
  g_ctl.set_gains(g_state.gains());
  start_reference();
}
// pset / pget / pinfo / pabort may run while heating: their scratch is on the stack.
static void __attribute__((noinline)) model_read(const con::Command& c) {
  union Scratch {
    Scratch() {}
    sma::Params p;
  } u;
  model_op(c, &u.p);
}
static void __attribute__((noinline)) model_exec() {
  con::Command c;
  c.op = g_model_op.op;
  c.key = g_model_op.key;
  c.a = g_model_op.a;
  g_model_op.op = con::Op::Empty;
  if (c.op == con::Op::PBegin || c.op == con::Op::PCommit) model_write(c);
  else model_read(c);
  if (c.op == con::Op::PBegin || c.op == con::Op::PCommit || c.op == con::Op::PSet) resync_ticks();
  send_reply();
}

// The latch tripped while heating (or the watchdog reset the board): say so once, on its own
// line, so a user (or a log) sees why the heater went off without polling status.
static bool g_fault_due = false;
static void __attribute__((noinline)) announce_fault() {
  g_fault_due = false;
  g_reply.clear();
  g_reply.put_f(SMA_F("# fault "));
  g_reply.put_f(sma::fault_name(g_safety.fault()));
  g_reply.put_f(SMA_F(": heater off"));
  send_reply();
}

static void __attribute__((noinline)) start_training(double slope) {
  sma::TrainingPlan* plan = new (&g_gen_store.train.plan) sma::TrainingPlan();
  if (slope > 0.0) plan->slope = slope;
  g_gen_store.train.end_ticks = static_cast<uint32_t>(plan->duration() * RIG_TICK_HZ) + 1u;
  g_training = true;
  g_run_start = g_ticks;
  g_reply.put(' ');
  g_reply.put_fixed(plan->duration(), 1);
  g_reply.put_f(SMA_F(" s"));
}

// The training plan's storage back to a generator once training has ended (any way).
static void __attribute__((noinline)) end_training_if_over() {
  if (g_training && !g_state.training) {
    g_training = false;
    start_reference();
  }
  if (g_train_done) {
    g_train_done = false;
    g_reply.clear();
    g_reply.put_f(SMA_F("# train done: heater off"));
    send_reply();
  }
}

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
  if (FW_TRAIN && c.op == con::Op::Train) start_training(c.a);
}

static void __attribute__((noinline)) handle_line_status(con::LineBuffer::Status st) {
  if (st == con::LineBuffer::Status::Line) {
    con::Command c;
    const bool tele_before = g_state.tele;
    con::Limits lim;
    lim.model = FW_MODEL;
    lim.train = FW_TRAIN;
    if (con::execute(g_line.line(), g_state, g_safety.fault(), g_reply, lim, &c)) {
      if (c.op == con::Op::Status) con::status_line(g_reply, g_state, g_live);
      if (FW_MODEL && con::is_model_op(c.op)) {  // run by loop(), which replies
        g_model_op.op = c.op;
        g_model_op.key = c.key;
        g_model_op.a = static_cast<float>(c.a);
        return;
      }
      sync_state(c, tele_before);
    }
  } else {
    con::line_error(st, g_reply);
  }
  send_reply();
}

// A completed line is handled only while at least 3 ms remain before the next tick (the
// slowest reply, status, takes ~2 ms to format): otherwise it waits, with no further byte read,
// until just after the tick. Found by the soak: a status line parsed at the end of a period
// delayed the tick by 2 ms.
static con::LineBuffer::Status g_line_waiting = con::LineBuffer::Status::Pending;
// g_div is read before the flag: the timer ISR resets g_div and raises g_tick_pending together, so
// reading the flag first could see "no tick" just before the ISR and then the fresh g_div = 0 (a
// whole period ahead) and start a 2 ms reply on top of the due tick (the soak's late tick).
static bool line_slot_open() {
  const uint8_t div = g_div;
  return div + 3 < RIG_TIMER2_DIV && !g_tick_pending;
}

// Reads bytes until one line is complete or a tick is due.
static void __attribute__((noinline)) poll_serial() {
  if (g_line_waiting != con::LineBuffer::Status::Pending) {
    if (!line_slot_open()) return;
    const con::LineBuffer::Status st = g_line_waiting;
    g_line_waiting = con::LineBuffer::Status::Pending;
    handle_line_status(st);
    return;
  }
  while (!g_tick_pending && Serial.available() > 0) {
    const int b = Serial.read();
    if (b < 0) break;
    g_safety.on_rx();
    const con::LineBuffer::Status st = g_line.push(static_cast<char>(b));
    if (st != con::LineBuffer::Status::Pending) {
      if (line_slot_open()) handle_line_status(st);
      else g_line_waiting = st;
      break;
    }
  }
}

// ---- the tick ----------------------------------------------------------------------------------
static float __attribute__((noinline)) training_voltage(float t) {
  return static_cast<float>(g_gen_store.train.plan.voltage_at(t));
}

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
  Scalar ref = Scalar(0);
  if (FW_TRAIN && g_training) {  // the training signal, open loop (the latch below still applies)
    if (g_ticks - g_run_start >= g_gen_store.train.end_ticks) {
      if (g_state.training) g_train_done = true;
      g_state.training = false;
      g_state.heat = false;
      g_ctl.set_mode(sma::Mode::Off, sma::from_double<Scalar>(mm));
    } else {
      g_ctl.set_voltage(sma::from_double<Scalar>(training_voltage(t_ref)));
    }
  } else {
    ref = g_gen.at(t_ref);
  }
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
    g_fault_due = true;
    g_state.heat = false;
    g_state.training = false;
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
  g_reply.put_f(SMA_F("# sma_firmware " FW_VARIANT " ready: heater off; try help"));
  send_reply();
  if (wdrf) announce_fault();  // "# fault watchdog": the last run hung
  wdt_enable(WDTO_250MS);
}

void loop() {
  poll_serial();
  if (FW_MODEL && g_model_op.op != con::Op::Empty) model_exec();
  if (FW_TRAIN) end_training_if_over();
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
    if (g_fault_due) announce_fault();
  }
  if (FW_TRAIN) end_training_if_over();
}
