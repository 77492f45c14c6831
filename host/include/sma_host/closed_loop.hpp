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
  int compute_delay_ticks = 0;  // V computed at tick k is applied from tick k + delay

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

// Mode::Preview: the PreviewController, given the reference's future as the board would
// (ReferenceGen at t + tau). Same delay and sampling as run_closed_loop. PlantT is sma::Plant
// or any plant with its interface (measure, displacement, applied_voltage, temperature, step),
// e.g. plant B (plant_b_rig.hpp); s.plant_params/plant_effects are not read here.
template <class T, class PlantT>
std::vector<Sample> run_preview_loop_on(PlantT& plant, const RunSetup& s) {
  sma::PreviewConfig pc = s.preview;
  pc.dt = s.config.dt;
  pc.v_max = s.config.v_max;
  pc.pwm_top = static_cast<uint16_t>(s.condition.rig.pwm_top);  // the board knows its PWM
  pc.v_supply = s.condition.rig.v_supply;
  sma::PreviewController<T> ctl(s.model_params, s.model_effects, pc);
  sma::ReferenceGen<T> ref(s.reference);
  const double dt = s.config.dt;
  const double duration = s.duration_s > 0.0 ? s.duration_s : s.reference.duration();
  const long n = static_cast<long>(duration / dt + 0.5);
  std::vector<double> pending(static_cast<size_t>(s.condition.compute_delay_ticks) + 1, 0.0);
  std::vector<Sample> out;
  out.reserve(static_cast<size_t>(n));
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double meas = plant.measure();
    const T r = ref.at(t);
    auto future = [&](T tau) { return ref.at(t + sma::to_double(tau)); };
    const double v_cmd = sma::to_double(ctl.step(r, future, sma::from_double<T>(meas)));
    pending.push_back(v_cmd);
    const double v = pending.front();
    pending.erase(pending.begin());
    out.push_back({t, sma::to_double(r), meas, plant.displacement(), plant.applied_voltage(v), 0.0,
                   plant.temperature()});
    plant.step(v, dt);
  }
  return out;
}

template <class T>
std::vector<Sample> run_preview_loop(const RunSetup& s) {
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  return run_preview_loop_on<T>(plant, s);
}

// Any controller mode against a given plant (see run_preview_loop_on for PlantT).
template <class T, class PlantT>
std::vector<Sample> run_closed_loop_on(PlantT& plant, const RunSetup& s) {
  if (s.mode == sma::Mode::Preview) return run_preview_loop_on<T>(plant, s);
  sma::Controller<T> ctl(s.model_params, s.model_effects, s.config);
  sma::ReferenceGen<T> ref(s.reference);
  const double dt = s.config.dt;
  const double duration = s.duration_s > 0.0 ? s.duration_s : s.reference.duration();
  const long n = static_cast<long>(duration / dt + 0.5);
  sma::SensorPredictor<T> sensor(ctl.inverse().curves(), s.model_params, s.model_effects, s.config.dt);
  const bool compensate = s.compensate_sensor && has_sensor_effects(s.model_effects);
  auto feedback = [&](double meas) {
    const T m = sma::from_double<T>(meas);
    return compensate ? sensor.correct(m, ctl.wire_temperature()) : m;
  };
  ctl.set_mode(s.mode, feedback(plant.measure()));
  std::vector<double> pending(static_cast<size_t>(s.condition.compute_delay_ticks) + 1, 0.0);
  std::vector<Sample> out;
  out.reserve(static_cast<size_t>(n));
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double meas = plant.measure();
    const T r = ref.at(t);
    const double v_cmd = sma::to_double(ctl.step(r, feedback(meas)));
    // Computation delay: the command reaches the heater `delay` ticks later.
    pending.push_back(v_cmd);
    const double v = pending.front();
    pending.erase(pending.begin());
    out.push_back({t, sma::to_double(r), meas, plant.displacement(), plant.applied_voltage(v),
                   sma::to_double(ctl.v1()), plant.temperature()});
    plant.step(v, dt);
  }
  return out;
}

template <class T>
std::vector<Sample> run_closed_loop(const RunSetup& s) {
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  return run_closed_loop_on<T>(plant, s);
}

}  // namespace sma_host

#endif  // SMA_HOST_CLOSED_LOOP_HPP
