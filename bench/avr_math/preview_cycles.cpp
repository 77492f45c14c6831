// Cycles of the preview controller's tick (preview.hpp) on the ATmega328P, for the simavr runner
// (cycles.c protocol: GPIOR1 group names, GPIOR0 1/2 around each sample). One sample = one call
// of PreviewController::step with the reference and its future from ReferenceGen (the sine,
// 15 s from t = 40 s: a peak, the fall and its switch), as the board's control section would
// run it. The measured position is the reference (the loop's plant is not on the chip).
// Built twice (float, and -DSMA_PREVIEW_FIXED for Q16.16: both do not fit 32 KB together).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>
#include "sma/fixed.hpp"
#include "sma/preview.hpp"
#include "sma/reference.hpp"

namespace {
volatile float g_sink;

// name: in flash (PSTR). The controller lives on the stack (~1.6 KB of the 2 KB): names in RAM
// were overwritten by the deepest calls (a stack paint found no byte of RAM the calls left alone).
void group(const char* name) {
  for (char ch; (ch = static_cast<char>(pgm_read_byte(name))) != '\0'; ++name) GPIOR1 = static_cast<uint8_t>(ch);
  GPIOR1 = 0;
}

// steps_per_tick = 0: the plan runs outside step() (plan_in_step = false), idle_steps
// plan_step() calls between ticks (the first samples the next tick's lead reference); the
// samples are step() (measure_idle false) or each plan_step() call (true).
template <class T>
__attribute__((noinline)) void run(const char* name, uint8_t steps_per_tick, bool pwm, uint8_t idle_steps = 0,
                                   bool measure_idle = false) {
  group(name);
  sma::PreviewConfig cfg;
  cfg.steps_per_tick = steps_per_tick ? steps_per_tick : 1;
  cfg.plan_in_step = steps_per_tick > 0;
  if (pwm) cfg.pwm_top = 15999;  // the firmware's 14-bit PWM at 1 kHz
  sma::PreviewController<T> c(sma::Params(), sma::Effects(), cfg);
  sma::ReferenceGen<T> ref(sma::Reference::sine());
  T measured = T(0);
  for (int k = 0; k < 1500; ++k) {
    const double t = 40.0 + 0.01 * k;
    auto future = [&](T tau) { return ref.at(t + sma::to_double(tau)); };
    // tick_only: the reference now is left out (the board's control section computes it for
    // every controller); the lead sample future(track_s) inside step() is counted.
    if (!measure_idle && steps_per_tick > 0) GPIOR0 = 1;
    const T r = ref.at(t);
    if (!measure_idle && steps_per_tick == 0) GPIOR0 = 1;
    const T v = c.step(r, future, measured);
    if (!measure_idle) GPIOR0 = 2;
    for (uint8_t i = 0; i < idle_steps; ++i) {
      if (measure_idle) GPIOR0 = 1;
      const bool done = c.plan_step(future);
      if (measure_idle) GPIOR0 = 2;
      if (done) break;
    }
    g_sink = static_cast<float>(sma::to_double(v));
    measured = r;
  }
}
}  // namespace

int main() {
#ifdef SMA_PREVIEW_FIXED
  run<sma::Fixed>(PSTR("fixed.steps1.pwm"), 1, true);
  run<sma::Fixed>(PSTR("fixed.steps1"), 1, false);
  run<sma::Fixed>(PSTR("fixed.tick_only.pwm"), 0, true, 5);
  run<sma::Fixed>(PSTR("fixed.plan_step.pwm"), 0, true, 5, true);
#else
  run<float>(PSTR("float.steps4.pwm"), 4, true);
  run<float>(PSTR("float.steps4"), 4, false);
  run<float>(PSTR("float.steps1.pwm"), 1, true);
  run<float>(PSTR("float.steps1"), 1, false);
  run<float>(PSTR("float.tick_only.pwm"), 0, true, 5);
  run<float>(PSTR("float.plan_step.pwm"), 0, true, 5, true);
#endif
  for (uint8_t i = 0; i < 5; ++i) GPIOR2 = 0;  // no self-check here: report a pass
  cli();
  sleep_enable();
  sleep_cpu();
  for (;;) {
  }
}
