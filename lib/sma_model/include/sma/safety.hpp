// Safety of the heater: a fault latch between the controller and the PWM.
//
// Heating an SMA wire is the one thing the firmware can do wrong in a way that hurts: an
// overheated NiTi wire loses its shape memory (anneals) long before anything smokes. The rule is
// therefore simple: when anything looks wrong the heater is switched off (V = 0) and stays off
// until an operator clears the fault (console `stop`) and commands heating again.
//
// Faults (the first one is latched and kept; every tick with a fault condition is counted):
//   sensor    the sensor's analog voltage left its calibrated range (laser lost the target,
//             cable off, out of range: the LC-2000 saturates its analog output); any sample of
//             the tick's window out of range counts, so it trips within one tick
//   nan       a non-finite measurement, temperature estimate or command
//   overtemp  the on-board wire temperature estimate (eq 1 on the commanded V) is above the
//             limit (default 110 degC; the wire's A_f is 80.1 degC)
//   link      no byte received for link_timeout_s while heating (0 = off, the default: a
//             closed-loop run started from a script must not stop when the terminal closes)
//   watchdog  the MCU came out of a watchdog reset (MCUSR.WDRF): the last run hung
// The heater is also off at boot: nothing heats until a console command asks for it (the
// console's `heat` flag, console.hpp); a trip clears that flag as well.
//
// Pure logic, no I/O: the firmware feeds one SafetyInput per tick and applies gate()'s output.
// The latch compares in the scalar S of the control path (SafetyLatch<S>; Safety is the double
// one): the board's tick hands over its own numbers, and a Q16.16 board compares integers instead
// of converting four values to float every tick. The thresholds are kept in S as well (converted
// when the config changes); the config itself stays double (what was set, reported exactly).
#ifndef SMA_SAFETY_HPP
#define SMA_SAFETY_HPP

#include <stdint.h>
#include "scalar.hpp"

// Strings that stay in flash on AVR (2 KB of RAM cannot hold the messages). SMA_F("text")
// gives a pointer that must be read with sma::flash_char(); on the host both are plain.
#ifndef SMA_F
#if defined(__AVR__)
#include <avr/pgmspace.h>
#define SMA_F(s) PSTR(s)
namespace sma {
inline char flash_char(const char* p) { return static_cast<char>(pgm_read_byte(p)); }
}  // namespace sma
#else
#define SMA_F(s) (s)
namespace sma {
inline char flash_char(const char* p) { return *p; }
}  // namespace sma
#endif
#endif

namespace sma {

enum class Fault : uint8_t { None = 0, Sensor, NotFinite, OverTemp, LinkLoss, Watchdog };

// Short name of a fault (an SMA_F string: read with flash_char).
inline const char* fault_name(Fault f) {
  switch (f) {
    case Fault::Sensor: return SMA_F("sensor");
    case Fault::NotFinite: return SMA_F("nan");
    case Fault::OverTemp: return SMA_F("overtemp");
    case Fault::LinkLoss: return SMA_F("link");
    case Fault::Watchdog: return SMA_F("watchdog");
    default: return SMA_F("none");
  }
}

struct SafetyConfig {
  double t_limit_C = 110.0;     // wire temperature estimate limit, degC
  double sensor_v_min = 0.1;    // valid analog range of the displacement sensor, V
  double sensor_v_max = 4.9;
  double link_timeout_s = 0.0;  // 0 = link loss is not a fault
  double dt = 0.01;             // tick, s

  // nullptr when usable, else a message naming the field (plain string, host side).
  const char* check() const {
    if (!(t_limit_C >= 30.0 && t_limit_C <= 150.0)) return "t_limit_C must be in 30..150";
    if (!(sensor_v_min >= 0.0 && sensor_v_max <= 5.5 && sensor_v_min < sensor_v_max))
      return "sensor_v_min < sensor_v_max within 0..5.5";
    if (!(link_timeout_s >= 0.0 && link_timeout_s <= 3600.0)) return "link_timeout_s must be in 0..3600";
    if (!(dt > 0.0 && dt <= 1.0)) return "dt must be in 0..1";
    return nullptr;
  }
};

// What the firmware knows at one tick, in the latch's scalar S.
template <class S>
struct SafetyInputOf {
  S sensor_v = S(2.5);          // average analog voltage of the tick's samples, V
  bool samples_in_range = true; // false if any sample of the window was out of range
  S measured_mm = S(0);
  S wire_temp_C = S(22);        // controller's eq-1 estimate
  S command_v = S(0);           // controller output, V
  bool heating = false;         // the loop is commanded to heat (any mode but off)
};

template <class S>
class SafetyLatch {
 public:
  // (constexpr: a latch of constant config is a constant the board copies from flash.)
  // The config is kept as the thresholds in S and the link timeout in ticks; the limit also as
  // set (t_limit_C(): what `tlim` reports).
  constexpr explicit SafetyLatch(const SafetyConfig& cfg = SafetyConfig())
      : t_limit_C_(cfg.t_limit_C), t_limit_(S(cfg.t_limit_C)), v_min_(S(cfg.sensor_v_min)),
        v_max_(S(cfg.sensor_v_max)), link_ticks_(link_ticks(cfg)) {}

  void set_config(const SafetyConfig& cfg) {
    t_limit_C_ = cfg.t_limit_C;
    t_limit_ = from_double<S>(cfg.t_limit_C);
    v_min_ = from_double<S>(cfg.sensor_v_min);
    v_max_ = from_double<S>(cfg.sensor_v_max);
    link_ticks_ = link_ticks(cfg);
  }
  double t_limit_C() const { return t_limit_C_; }
  // The console's `tlim`; false (nothing changes) outside 30..150 or NaN.
  bool set_limit(double t_C) {
    if (!(t_C >= 30.0 && t_C <= 150.0)) return false;
    t_limit_C_ = t_C;
    t_limit_ = from_double<S>(t_C);
    return true;
  }

  // At reset: a watchdog reset latches a fault (the previous run hung).
  void boot(bool watchdog_reset) {
    fault_ = Fault::None;
    trips_ = 0;
    since_rx_ = 0;
    if (watchdog_reset) trip(Fault::Watchdog);
  }

  // A byte arrived on the console.
  void on_rx() { since_rx_ = 0; }

  // One tick: checks the inputs, latches the first fault, returns the voltage to apply
  // (the command, or 0 once latched).
  S gate(const SafetyInputOf<S>& in) {
    if (since_rx_ < UINT32_MAX) ++since_rx_;
    const Fault f = classify(in);
    if (f != Fault::None) trip(f);
    if (fault_ != Fault::None) return S(0);
    return positive(in.command_v) ? in.command_v : S(0);
  }

  // What is wrong with an input, regardless of the latch (Fault::None if nothing).
  Fault classify(const SafetyInputOf<S>& in) const {
    if (!is_finite(in.sensor_v) || !is_finite(in.measured_mm) || !is_finite(in.wire_temp_C) ||
        !is_finite(in.command_v))
      return Fault::NotFinite;
    // (The samples in range, the mean volts are >= 0, as the range's ends: above().)
    if (!in.samples_in_range || above(v_min_, in.sensor_v) || above(in.sensor_v, v_max_)) return Fault::Sensor;
    if (in.wire_temp_C > t_limit_) return Fault::OverTemp;
    if (link_ticks_ > 0 && in.heating && since_rx_ > link_ticks_) return Fault::LinkLoss;
    return Fault::None;
  }

  // Operator acknowledgement (console `stop`): unlatch. The next tick checks again, and heating
  // needs a new command anyway.
  void clear() {
    fault_ = Fault::None;
    since_rx_ = 0;
  }

  bool tripped() const { return fault_ != Fault::None; }
  Fault fault() const { return fault_; }
  uint16_t trips() const { return trips_; }  // ticks with a fault condition since boot (saturates)
  uint32_t ticks_since_rx() const { return since_rx_; }

 private:
  void trip(Fault f) {
    if (trips_ < UINT16_MAX) ++trips_;
    if (fault_ == Fault::None) fault_ = f;
  }

  // The link timeout in ticks, at least 1 when there is one (0: none).
  static constexpr uint32_t link_ticks(const SafetyConfig& cfg) {
    if (!(cfg.link_timeout_s > 0.0)) return 0;
    const double ticks = cfg.link_timeout_s / cfg.dt;
    if (ticks >= 4.0e9) return UINT32_C(4000000000);
    const uint32_t n = static_cast<uint32_t>(ticks + 0.5);
    return n > 0 ? n : 1;
  }

  double t_limit_C_;
  S t_limit_, v_min_, v_max_;  // the thresholds in S
  Fault fault_ = Fault::None;
  uint16_t trips_ = 0;
  uint32_t since_rx_ = 0;
  uint32_t link_ticks_;
};

// The latch of host code and tests: double throughout.
typedef SafetyInputOf<double> SafetyInput;
typedef SafetyLatch<double> Safety;

}  // namespace sma

#endif  // SMA_SAFETY_HPP
