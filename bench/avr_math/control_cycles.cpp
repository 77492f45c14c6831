// Cycles of the controller's tick (controller.hpp, mode ffpid: inverse model eqs 14-17 + PID,
// eq 18, and the wire temperature estimate) on the ATmega328P, for the simavr runner (cycles.c
// protocol: GPIOR1 group names, GPIOR0 1/2 around each sample). The board's control section
// (bench/budgets.py) adds to this its own glue: ADC average, reference, safety gate, PWM.
// Two windows of the paper's sine (0.2..0.7 mm, 50 s): 20..30 s holds the peak at 25 s (a
// reversal that builds a minor loop), 45..55 s the valley at 50 s; a group per window. The
// measured position is the reference (the plant is not on the chip: the PID's cost does not
// depend on its error). Built twice (float, and -DSMA_CONTROL_FIXED for Q16.16).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include "sma/controller.hpp"
#include "sma/fixed.hpp"
#include "sma/reference.hpp"

namespace {
volatile float g_sink;

void group(const char* name) {
  while (*name != '\0') GPIOR1 = static_cast<uint8_t>(*name++);
  GPIOR1 = 0;
}

// A reversal's own work: the minor loop that a peak at T_i (40..90 degC, over the identified
// loops' knots and both branches of eqs 7-10) builds (eqs 5-11).
template <class T>
__attribute__((noinline)) void loops(const char* name) {
  group(name);
  const sma::PhaseCurves<T> curves{sma::Params()};
  for (int k = 0; k < 100; ++k) {
    const T T_i = T(40) + T(0.5) * T(k);
    GPIOR0 = 1;
    const sma::CoolingLoop<T> L = curves.make_loop(T_i, curves.eps_heat(T_i));
    GPIOR0 = 2;
    g_sink = static_cast<float>(sma::to_double(L.T_MSi));
  }
}

template <class T>
__attribute__((noinline)) void run(const char* name_peak, const char* name_valley) {
  sma::ControllerConfig cfg;
  cfg.gains.kp = 12.0;
  cfg.gains.ki = 3.0;
  cfg.gains.kd = 0.1;
  sma::Controller<T> c(sma::Params(), sma::Effects(), cfg);
  const sma::ReferenceGen<T> ref(sma::Reference::sine());
  c.set_mode(sma::Mode::FeedforwardPid, ref.at(0.0));
  const char* names[2] = {name_peak, name_valley};
  for (uint8_t w = 0; w < 2; ++w) {
    group(names[w]);
    const double t0 = w == 0 ? 20.0 : 45.0;
    for (int k = 0; k < 1000; ++k) {
      const T r = ref.at(t0 + 0.01 * k);
      GPIOR0 = 1;
      const T v = c.step(r, r);
      GPIOR0 = 2;
      g_sink = static_cast<float>(sma::to_double(v));
    }
  }
}
}  // namespace

int main() {
#ifdef SMA_CONTROL_FIXED
  run<sma::Fixed>("fixed.ffpid.peak", "fixed.ffpid.valley");
  loops<sma::Fixed>("fixed.make_loop+eps_heat");
#else
  run<float>("float.ffpid.peak", "float.ffpid.valley");
  loops<float>("float.make_loop+eps_heat");
#endif
  for (uint8_t i = 0; i < 5; ++i) GPIOR2 = 0;  // no self-check here: report a pass
  cli();
  sleep_enable();
  sleep_cpu();
  for (;;) {
  }
}
