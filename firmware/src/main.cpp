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
// GPIOR2 (preview image): ticks that cut the preview's plan passes short (sma::Board::plan_short).
// Scalar type: float, or sma::Fixed (Q16.16) when built with -DSMA_FIRMWARE_FIXED.
// No Arduino core: the firmware uses none of its timers (Timer0's millis ISR would only steal
// cycles from the tick) and its own 115200-baud UART below (HardwareSerial's virtual Print
// interface costs ~1 KB of flash and ~50 B of RAM it does not need).
// The board plans the preview between ticks and does not commit to switches (sma/board.hpp):
// the preview's host options stay out of the image (sma/preview.hpp).
#define SMA_PREVIEW_HOST_OPTIONS 0
#include "rig_board.h"
#include "sma/board.hpp"
#include "sma/codegen.hpp"
#ifdef SMA_FIRMWARE_FIXED
#include "sma/fixed.hpp"
#include "sma/float_from_int.hpp"
typedef sma::Fixed Scalar;
#define FW_VARIANT "fixed"
// The image's int -> float conversions (sma/float_from_int.hpp) instead of avr-libc's, and
// Fixed's (sma_float_from_q16, Fixed::operator float).
__asm__(SMA_FLOAT_FROM_INT_ASM("__floatunsisf", "__floatsisf", "sma_float_from_q16"));
#else
typedef float Scalar;
#define FW_VARIANT "float"
#endif

#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/wdt.h>


// ---- reset cause: saved before anything else runs ----------------------------------------------
// Optiboot clears MCUSR and passes it in r2; a plain reset leaves it in MCUSR. Keep both, clear
// MCUSR and stop a watchdog that survived the reset (it stays on after a watchdog reset).
uint8_t g_reset_cause __attribute__((section(".noinit")));
// The heater's gate: Timer1's OC1A (Uno pin 9 = PB1, Mega 2560 pin 11 = PB5); USART0's vectors.
#if defined(__AVR_ATmega2560__)
#define SMA_USART_RX_vect USART0_RX_vect
#define SMA_USART_UDRE_vect USART0_UDRE_vect
static const uint8_t kHeaterBit = PB5;
#else
#define SMA_USART_RX_vect USART_RX_vect
#define SMA_USART_UDRE_vect USART_UDRE_vect
static const uint8_t kHeaterBit = PB1;
#endif
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
  PORTB &= static_cast<uint8_t>(~_BV(kHeaterBit));
  DDRB |= _BV(kHeaterBit);
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
// The sum as 16 low bits and a carry count (up to 255 samples of 10 bits need 18): a 16-bit add
// keeps the ISR's frame small, and it lands on top of the deepest stack of the main line.
static volatile uint16_t g_adc_sum_lo = 0;
static volatile uint8_t g_adc_sum_hi = 0;
static volatile uint8_t g_adc_n = 0;
static volatile uint8_t g_adc_bad = 0;
// The chain pauses during the control section (its ~12 interrupts there would cost ~1k cycles),
// flags in GPIOR1 (no RAM, single-cycle bit access): kAdcHold = the conversion under way is summed
// but starts no next one, kAdcStopped = it has done so.
static const uint8_t kAdcHold = 0, kAdcStopped = 1;

ISR(ADC_vect) {
  const uint16_t a = ADC;
  if (g_adc_n < 255) {
    const uint16_t s = static_cast<uint16_t>(g_adc_sum_lo + a);
    g_adc_sum_lo = s;
    if (s < a) ++g_adc_sum_hi;
    ++g_adc_n;
    if (a < kAdcLo || a > kAdcHi) ++g_adc_bad;
  }
  if (GPIOR1 & _BV(kAdcHold)) GPIOR1 |= _BV(kAdcStopped);
  else ADCSRA |= _BV(ADSC);  // next conversion (13 ADC clocks at 125 kHz: 104 us)
}

// ---- UART0: interrupt-driven rings, 8N1 --------------------------------------------------------
// The RX ring holds the next line while the board waits for a slot (3 ms + a tick at 115200 baud:
// ~70 bytes); the TX ring holds the longest reply (111 chars) so that a reply never blocks loop().
#ifndef SERIAL_TX_BUFFER_SIZE
#define SERIAL_TX_BUFFER_SIZE 128
#endif
#ifndef SERIAL_RX_BUFFER_SIZE
#define SERIAL_RX_BUFFER_SIZE 64
#endif
static_assert((SERIAL_TX_BUFFER_SIZE & (SERIAL_TX_BUFFER_SIZE - 1)) == 0 && SERIAL_TX_BUFFER_SIZE <= 256,
              "TX ring: a power of two up to 256");
static_assert((SERIAL_RX_BUFFER_SIZE & (SERIAL_RX_BUFFER_SIZE - 1)) == 0 && SERIAL_RX_BUFFER_SIZE <= 256,
              "RX ring: a power of two up to 256");
namespace uart {
static volatile uint8_t rx_buf[SERIAL_RX_BUFFER_SIZE];
static volatile uint8_t tx_buf[SERIAL_TX_BUFFER_SIZE];
static volatile uint8_t rx_head = 0, rx_tail = 0, tx_head = 0, tx_tail = 0;  // head: next write

// U2X mode, the divisor rounded as the Arduino core does (115200 baud: UBRR 16, +2.1 %).
static void begin(unsigned long baud) {
  const uint16_t ubrr = static_cast<uint16_t>((F_CPU / 4 / baud - 1) / 2);
  UCSR0A = _BV(U2X0);
  UBRR0H = static_cast<uint8_t>(ubrr >> 8);
  UBRR0L = static_cast<uint8_t>(ubrr);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}
static uint8_t tx_free() {
  return static_cast<uint8_t>((SERIAL_TX_BUFFER_SIZE - 1) - ((tx_head - tx_tail) & (SERIAL_TX_BUFFER_SIZE - 1)));
}
// Waits while the ring is full (the UDRE interrupt drains it; with interrupts off, by polling).
static void put(uint8_t c) {
  while (tx_free() == 0) {
    if (!(SREG & _BV(SREG_I)) && (UCSR0A & _BV(UDRE0))) {
      UDR0 = tx_buf[tx_tail];
      tx_tail = static_cast<uint8_t>((tx_tail + 1) & (SERIAL_TX_BUFFER_SIZE - 1));
    }
  }
  tx_buf[tx_head] = c;
  tx_head = static_cast<uint8_t>((tx_head + 1) & (SERIAL_TX_BUFFER_SIZE - 1));
  UCSR0B |= _BV(UDRIE0);
}
// Next received byte, or -1.
static int16_t get() {
  if (rx_head == rx_tail) return -1;
  const uint8_t c = rx_buf[rx_tail];
  rx_tail = static_cast<uint8_t>((rx_tail + 1) & (SERIAL_RX_BUFFER_SIZE - 1));
  return c;
}
}  // namespace uart

ISR(SMA_USART_RX_vect) {
  const bool parity_error = (UCSR0A & _BV(UPE0)) != 0;
  const uint8_t c = UDR0;
  const uint8_t next = static_cast<uint8_t>((uart::rx_head + 1) & (SERIAL_RX_BUFFER_SIZE - 1));
  if (parity_error || next == uart::rx_tail) return;  // a full ring drops the byte (the line
  uart::rx_buf[uart::rx_head] = c;                     // buffer then reports the bad line)
  uart::rx_head = next;
}
ISR(SMA_USART_UDRE_vect) {
  if (uart::tx_head == uart::tx_tail) {
    UCSR0B &= static_cast<uint8_t>(~_BV(UDRIE0));
    return;
  }
  UDR0 = uart::tx_buf[uart::tx_tail];
  uart::tx_tail = static_cast<uint8_t>((uart::tx_tail + 1) & (SERIAL_TX_BUFFER_SIZE - 1));
}

// ---- heater PWM --------------------------------------------------------------------------------
static void pwm_init() {
  OCR1A = 0;
  ICR1 = static_cast<uint16_t>(RIG_PWM_TOP);
  // Mode 14 (WGM13:0 = 1110), output disconnected until a non-zero duty, prescaler 1.
  TCCR1A = _BV(WGM11);
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS10);
  TCNT1 = 0;
}

// Counts n, duty = n / (TOP + 1); n = 0 disconnects OC1A (pin low: fast PWM with OCR1A = 0 would
// still give a 1-count pulse).
static void pwm_write(uint16_t n) {
  if (n == 0) {
    TCCR1A = _BV(WGM11);  // COM1A1 = 0: OC1A back to PORTB1 = 0
  } else {
    OCR1A = static_cast<uint16_t>(n - 1u);
    TCCR1A = _BV(COM1A1) | _BV(WGM11);
  }
}

// ---- the board's outputs: serial lines that never stall the tick, the EEPROM -------------------
// A line waits for room in the TX buffer only until the next tick is due (115200 baud drains a
// telemetry row in 3.5 ms), then it is dropped (the board counts it: status drop=).
#if SERIAL_TX_BUFFER_SIZE < 128
#warning "SERIAL_TX_BUFFER_SIZE < 128: replies longer than the buffer block loop() for a few ms"
#endif
struct UnoHw {
  static bool line(const char* s, uint8_t len) {
    const uint16_t need = static_cast<uint16_t>(len + 2u);
    if (need <= SERIAL_TX_BUFFER_SIZE - 1) {
      while (uart::tx_free() < need && !g_tick_pending) {
      }
      if (uart::tx_free() < need) return false;
    }  // else it can never fit: blocking write
    for (uint8_t i = 0; i < len; ++i) uart::put(static_cast<uint8_t>(s[i]));
    uart::put('\r');
    uart::put('\n');
    return true;
  }
  // eeprom_update_byte waits for the previous write (3.4 ms each): the watchdog is fed between
  // bytes. Writing happens only with the heater off (the console refuses otherwise).
  uint8_t read(uint16_t a) const {
    return eeprom_read_byte(reinterpret_cast<const uint8_t*>(static_cast<uintptr_t>(a)));
  }
  void write(uint16_t a, uint8_t v) {
    wdt_reset();
    eeprom_update_byte(reinterpret_cast<uint8_t*>(static_cast<uintptr_t>(a)), v);
  }
  static uint8_t irq_off() {
    const uint8_t s = SREG;
    cli();
    return s;
  }
  static void irq_restore(uint8_t s) { SREG = s; }
};

typedef sma::Board<Scalar, RigBoard, UnoHw> Board;
static Board g_board;

// After a long EEPROM operation: the ticks it blocked are not overruns (heater off meanwhile).
// (A tick raised meanwhile stays pending and runs next.)
static void resync_ticks() {
  cli();
  const uint32_t t = g_tick_pending ? g_ticks_isr - 1u : g_ticks_isr;
  sei();
  g_board.set_ticks(t);
}

// A completed line is handled only while at least 3 ms remain before the next tick (the slowest
// reply, status, takes ~2 ms to format): otherwise it waits, with no further byte read, until
// just after the tick.
// g_div is read before the flag: the timer ISR resets g_div and raises g_tick_pending together, so
// reading the flag first could see "no tick" just before the ISR and then the fresh g_div = 0 (a
// whole period ahead) and start a 2 ms reply on top of the due tick.
static bool line_slot_open() {
  const uint8_t div = g_div;
  return div + 3 < RIG_TIMER2_DIV && !g_tick_pending;
}

// Reads bytes until one line is complete or a tick is due.
static void __attribute__((noinline)) SMA_OWN_OPTIONS poll_serial() {
  if (!g_board.line_waiting()) {
    while (!g_tick_pending) {
      const int16_t b = uart::get();
      if (b < 0) break;
      if (g_board.rx(static_cast<char>(b))) break;
    }
  }
  if (g_board.line_waiting() && line_slot_open()) g_board.handle_line();
}

#if RIG_FEATURE_PREVIEW
// A plan pass starts only while >= 1.5 ms remain before the next tick (kPassSlot, in Timer2 counts
// of 4 us): a grid step takes ~8-27 k cycles (0.5-1.7 ms), the long ones early in the tick; the
// tick's first pass (the lead sample, <= ~49 k) comes right after the tick. The telemetry row
// (<= ~16 k cycles, 1 ms) waits for the passes and is written while >= 1.25 ms remain (kRowSlot).
// Timer2's count says how far into the current millisecond it is; a compare match not yet serviced
// (interrupts off here) is a millisecond gone.
constexpr int16_t kPassSlot = 375, kRowSlot = 312;
static bool slot_open(int16_t counts) {
  cli();
  uint8_t div = g_div;
  const uint8_t count = TCNT2;
  if (TIFR2 & _BV(OCF2A)) ++div;
  const bool tick_due = g_tick_pending;
  sei();
  const int16_t left = static_cast<int16_t>(RIG_TIMER2_DIV - 1 - div) * (RIG_TIMER2_OCR + 1) + (RIG_TIMER2_OCR + 1 - count);
  return !tick_due && left >= counts;
}
#endif

// ---- the tick ----------------------------------------------------------------------------------
static void __attribute__((noinline)) control_tick() {
  GPIOR0 = 1;
  // Sensor: the samples since the last tick.
  uint32_t sum;
  uint8_t n, bad;
  cli();
  sum = (static_cast<uint32_t>(g_adc_sum_hi) << 16) | g_adc_sum_lo;
  n = g_adc_n;
  bad = g_adc_bad;
  g_adc_sum_lo = 0;
  g_adc_sum_hi = 0;
  g_adc_n = 0;
  g_adc_bad = 0;
  GPIOR1 = _BV(kAdcHold);
  sei();
  pwm_write(g_board.control(sum, n, bad));
  GPIOR0 = 2;
  cli();
  if (GPIOR1 & _BV(kAdcStopped)) ADCSRA |= _BV(ADSC);  // the chain resumes
  GPIOR1 = 0;
  sei();
  wdt_reset();
  g_board.report();
  GPIOR0 = 3;
}

static void setup() {
  const bool wdrf = (g_reset_cause & _BV(WDRF)) != 0;
  pwm_init();
  uart::begin(RIG_BAUD);
  // The models' construction (the deepest stack of the run, interrupts off meanwhile), the
  // ready line, "# fault watchdog" if the last run hung. Before the tick timer starts: tick 0
  // is the timer's first.
  g_board.boot(wdrf, SMA_F("# sma_firmware " FW_VARIANT " ready: heater off; try help"));
#if RIG_FEATURE_PREVIEW
  g_board.rows_after_plan(true);  // the plan passes first, the telemetry row after them (loop())
#endif
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
  wdt_enable(WDTO_250MS);
}

static void loop() {
  poll_serial();
  // A model command runs here, at the top of the stack: pcommit builds the controller (the
  // deepest stack) and must not do it below the console's frames.
  if (g_board.model_pending() && g_board.run_model_op()) resync_ticks();
  g_board.poll();
  if (g_tick_pending) {
    cli();
    const uint32_t raised = g_ticks_isr;
    g_tick_pending = 0;
    sei();
    // Ticks lost while the previous one ran too long (never expected: counted for status).
    if (raised > g_board.ticks() + 1u) g_board.overrun_to(raised - 1u);
    control_tick();
#if RIG_FEATURE_PREVIEW
    const uint16_t short_ticks = g_board.plan_short();
    GPIOR2 = short_ticks > 0xFFu ? 0xFFu : static_cast<uint8_t>(short_ticks);
#endif
  }
  g_board.poll();
  // The preview's planning, one bounded step (<= ~2.2 ms; the tick's first <= ~3.2 ms) per pass
  // while the slot is open, until the tick's passes are done (Board::plan_passes(), the host's:
  // plan() then does nothing). Ticks that came first are counted; GPIOR2 shows the count to the virtual
  // rig (fil_preview asserts 0): written after each tick. Then the tick's telemetry row (~1 ms),
  // if it fits before the next tick (else the next tick's report() writes it; docs/control.md
  // section 22).
#if RIG_FEATURE_PREVIEW
  if (!g_board.line_waiting() && slot_open(kPassSlot)) {
    GPIOR0 = 4;  // the virtual rig times each pass (vrig --pass-trace)
    const bool done = g_board.plan();
    GPIOR0 = done ? 6 : 5;
    if (done && slot_open(kRowSlot)) g_board.telemetry();
  }
#endif
}

int main() {
  sei();  // as the Arduino core's init() did before setup(): the banner drains meanwhile
  setup();
  for (;;) loop();
}
