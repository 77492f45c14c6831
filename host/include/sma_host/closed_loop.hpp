// Host side: one closed-loop run of a Controller<T> against the simulated Plant, at the
// controller's tick, as the firmware runs it: measure, compute, apply.
// Shared by the native tests, the tracking benchmark and `tools/sma sim`.
#ifndef SMA_HOST_CLOSED_LOOP_HPP
#define SMA_HOST_CLOSED_LOOP_HPP

#include <vector>
#include "sma/controller.hpp"
#include "sma_host/plant.hpp"
#include "sma/preview.hpp"
#include "sma/reference.hpp"
#include "sma/sensor.hpp"

namespace sma_host {

struct Sample {
  double t;       // s
  double ref;     // mm
  double meas;    // measured displacement, mm
  double truth;   // true displacement, mm
  double v;       // voltage applied to the wire, V
  double v1;      // feedforward part, V
  double temp;    // true wire temperature, deg C
};

// One of the two closed-loop conditions of model.md.
struct Condition {
  const char* name = "ideal";
  sma::RigOptions rig;      // noise, ADC step, PWM levels
  int compute_delay_ticks = 0;  // extra ticks before a command reaches the heater (DelayLine)

  static Condition ideal() { return Condition(); }
  static Condition rig_like() {
    Condition c;
    c.name = "rig-like";
    c.rig = sma::RigOptions::rig_like();
    c.compute_delay_ticks = 1;
    return c;
  }
};

struct RunSetup {
  sma::Params plant_params;       // the wire
  sma::Effects plant_effects;     // what the wire does that the model may not know
  sma::Params model_params;       // what the controller believes
  sma::Effects model_effects;
  sma::ControllerConfig config;
  sma::PreviewConfig preview;     // Mode::Preview (dt and v_max come from config)
  // preview.plan_in_step = false: plan_step() calls after each tick's step() (the board's idle
  // time between ticks).
  int idle_plan_steps = 4;
  sma::Mode mode = sma::Mode::FeedforwardPid;
  sma::Reference reference = sma::Reference::sine();
  Condition condition;
  double duration_s = 0.0;  // 0: the reference's own duration
  // With sensor effects in model_effects, feed the controller the SensorPredictor's estimate
  // (calibration inverted, Smith predictor for lag/delay) instead of the raw measurement.
  bool compensate_sensor = true;
};

inline bool has_sensor_effects(const sma::Effects& fx) {
  return fx.sensor_delay_s > 0 || fx.sensor_lag_s > 0 || fx.sensor_gain != 1.0 || fx.sensor_offset_mm != 0.0;
}

// The command computed from the measurement of tick k drives the heater from tick k + 1 (the
// firmware writes the PWM for the next period), plus compute_delay_ticks more. A fixed ring of
// delay + 1 slots: each push returns the command pushed delay + 1 ticks earlier (0 V before).
class DelayLine {
 public:
  explicit DelayLine(int delay_ticks) : slots_(static_cast<size_t>(delay_ticks > 0 ? delay_ticks : 0) + 1, 0.0) {}
  double push(double v) {
    const double oldest = slots_[head_];
    slots_[head_] = v;
    head_ = (head_ + 1) % slots_.size();
    return oldest;
  }

 private:
  std::vector<double> slots_;
  size_t head_ = 0;
};

// The loop as the firmware runs it, one tick: measure, compute, apply (after the delay),
// record. compute(t, r, meas) -> {voltage command, its feedforward part}. PlantT is sma::Plant
// or any plant with its interface (measure, displacement, applied_voltage, temperature, step),
// e.g. plant B (plant_b_rig.hpp); s.plant_params/plant_effects are not read here.
struct Command {
  double v;
  double v1;
};

template <class T, class PlantT, class Compute>
std::vector<Sample> run_loop_on(PlantT& plant, const RunSetup& s, sma::ReferenceGen<T>& ref, Compute compute) {
  const double dt = s.config.dt;
  const double duration = s.duration_s > 0.0 ? s.duration_s : s.reference.duration();
  const long n = static_cast<long>(duration / dt + 0.5);
  DelayLine delay(s.condition.compute_delay_ticks);
  std::vector<Sample> out;
  out.reserve(static_cast<size_t>(n));
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double meas = plant.measure();
    const T r = ref.at(t);
    const Command c = compute(t, r, meas);
    const double v = delay.push(c.v);
    out.push_back({t, sma::to_double(r), meas, plant.displacement(), plant.applied_voltage(v), c.v1,
                   plant.temperature()});
    plant.step(v, dt);
  }
  return out;
}

// Mode::Preview: the PreviewController, given the reference's future as the board would
// (ReferenceGen at t + tau).
template <class T, class PlantT>
std::vector<Sample> run_preview_loop_on(PlantT& plant, const RunSetup& s) {
  sma::PreviewConfig pc = s.preview;
  pc.dt = s.config.dt;
  pc.v_max = s.config.v_max;
  pc.pwm_top = static_cast<uint16_t>(s.condition.rig.pwm_top);  // the board knows its PWM
  pc.v_supply = s.condition.rig.v_supply;
  sma::PreviewController<T> ctl(s.model_params, s.model_effects, pc);
  sma::ReferenceGen<T> ref(s.reference);
  return run_loop_on<T>(plant, s, ref, [&](double t, T r, double meas) {
    auto future = [&](T tau) { return ref.at(t + sma::to_double(tau)); };
    const Command c{sma::to_double(ctl.step(r, future, sma::from_double<T>(meas))), 0.0};
    if (!pc.plan_in_step)
      for (int i = 0; i < s.idle_plan_steps; ++i)
        if (ctl.plan_step(future)) break;
    return c;
  });
}

template <class T>
std::vector<Sample> run_preview_loop(const RunSetup& s) {
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  return run_preview_loop_on<T>(plant, s);
}

// Any controller mode against a given plant (see run_loop_on for PlantT).
template <class T, class PlantT>
std::vector<Sample> run_closed_loop_on(PlantT& plant, const RunSetup& s) {
  if (s.mode == sma::Mode::Preview) return run_preview_loop_on<T>(plant, s);
  sma::Controller<T> ctl(s.model_params, s.model_effects, s.config);
  sma::ReferenceGen<T> ref(s.reference);
  sma::SensorPredictor<T> sensor(ctl.inverse().curves(), s.model_params, s.model_effects, s.config.dt);
  const bool compensate = s.compensate_sensor && has_sensor_effects(s.model_effects);
  auto feedback = [&](double meas) {
    const T m = sma::from_double<T>(meas);
    return compensate ? sensor.correct(m, ctl.wire_temperature()) : m;
  };
  ctl.set_mode(s.mode, feedback(plant.measure()));
  return run_loop_on<T>(plant, s, ref, [&](double, T r, double meas) {
    const double v = sma::to_double(ctl.step(r, feedback(meas)));
    return Command{v, sma::to_double(ctl.v1())};
  });
}

template <class T>
std::vector<Sample> run_closed_loop(const RunSetup& s) {
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  return run_closed_loop_on<T>(plant, s);
}

}  // namespace sma_host

#endif  // SMA_HOST_CLOSED_LOOP_HPP
