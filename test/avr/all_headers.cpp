// Compiled by avr-g++ 5.4 in CTest (avr_compile_float / avr_compile_fixed): every header the
// firmware can include (sma_model.h includes them all; plant.hpp is host-only), every model
// template instantiated for the scalar under test, so that STL use, exceptions, 16-bit-int
// overflows or conversion warnings on AVR fail the build.
#include <sma_model.h>
#include <sma/board.hpp>
#include <sma/console.hpp>
#include <sma/safety.hpp>

#include "../board_test_rig.hpp"

#if defined(SMA_AVR_SCALAR_fixed)
typedef sma::Fixed Scalar;
#else
typedef float Scalar;
#endif

volatile float g_in = 0.4f;

// The board's unit with a rig of constants and outputs that go nowhere.
typedef BoardTestRig AvrTestRig;
volatile uint8_t g_sink;
struct AvrTestHw {
  bool line(const char* s, uint8_t len) {
    g_sink = static_cast<uint8_t>(s[0] + len);
    return true;
  }
  uint8_t read(uint16_t a) const { return static_cast<uint8_t>(a); }
  void write(uint16_t a, uint8_t v) { g_sink = static_cast<uint8_t>(a + v); }
  uint8_t irq_off() { return 0; }
  void irq_restore(uint8_t s) { g_sink = s; }
};
sma::Board<Scalar, AvrTestRig, AvrTestHw> g_board;
volatile float g_out;

int main() {
  const sma::Params p;
  const sma::Effects fx;
  sma::ControllerConfig cfg;
  sma::Controller<Scalar> ctl(p, fx, cfg);
  ctl.set_mode(sma::Mode::FeedforwardPid, Scalar(0.2));
  sma::ReferenceGen<Scalar> ref(sma::Reference::sine());
  const Scalar v = ctl.step(ref.at(1.0), sma::from_double<Scalar>(g_in));
  sma::PhaseCurves<Scalar> curves(p);
  sma::Hysteresis<Scalar> h(curves);
  h.update(Scalar(60));
  sma::Thermal<Scalar> th(p, fx);
  sma::ThermalStep<Scalar> ts(p, 0.01);
  sma::Mechanics<Scalar> m(p);
  g_out = static_cast<float>(sma::to_double(v + h.eps() + th.steady_state(Scalar(1)) +
                                            ts(Scalar(30), Scalar(1)) + m.displacement(Scalar(0.5)) +
                                            ctl.wire_temperature()));
  // The firmware-side headers: the console protocol and the safety latch.
  sma::console::State state;
  sma::console::Reply reply;
  sma::console::execute("pos 0.4", state, sma::Fault::None, reply);
  sma::Safety safety;
  g_board.boot(false, SMA_F("# ready"));
  for (const char* c = "pbegin\n"; *c; ++c)
    if (g_board.rx(*c)) g_board.handle_line();
  if (g_board.model_pending()) g_board.run_model_op();
  g_sink = static_cast<uint8_t>(g_board.control(50000u, 96, 0));
  g_board.report();
  g_board.poll();
  sma::SensorPredictor<Scalar> sensor(curves, p, fx, 0.01);
  g_out = g_out + static_cast<float>(sma::to_double(sensor.correct(Scalar(0.3), Scalar(40))));
  return (p.check() == nullptr && reply.len > 0) ? 0 : 1;
}
