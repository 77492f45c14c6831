// Plant B (plant_b.hpp, plant_b_sensor.hpp) behind the interface of sma::Plant that the
// closed loops of closed_loop.hpp use, so the controllers, which carry the library's model,
// can be run against a wire their model was not written with (docs/control.md, "Against
// plant B"). Like plant B itself, the rig here is written apart from the library: the PWM
// duty is quantised on its own (duty = (V / V_supply)^2 in pwm_top levels, model.md), the
// sensor's noise and ADC are plant B's.
#ifndef SMA_HOST_PLANT_B_RIG_HPP
#define SMA_HOST_PLANT_B_RIG_HPP

#include <math.h>
#include <stdint.h>
#include "sma_host/plant.hpp"
#include "sma_host/plant_b.hpp"
#include "sma_host/plant_b_sensor.hpp"

namespace sma_host {
namespace plant_b {

// The library's effect vocabulary (sma::Effects: what the discrepancy workflow names) in plant
// B's own terms: convection as a conductance growing with the temperature rise, latent heat as a
// temperature drop per unit of fraction transformed; the sensor's effects apart (no noise, no ADC:
// the caller's).
inline WireEffects wire_effects(const sma::Effects& fx, const Wire& w) {
  WireEffects wf;
  wf.ambient_offset_K = fx.ambient_offset_K;
  wf.G2_W_per_K2 = w.conductance() * fx.convection_beta_per_K;
  wf.k_R = fx.resistance_k;
  wf.latent_K = fx.latent_heat_J / w.heat_capacity();
  wf.alpha_per_K = fx.thermal_expansion_per_K;
  return wf;
}
inline SensorEffects sensor_effects(const sma::Effects& fx) {
  SensorEffects sf;
  sf.delay_s = fx.sensor_delay_s;
  sf.lag_s = fx.sensor_lag_s;
  sf.gain = fx.sensor_gain;
  sf.offset_mm = fx.sensor_offset_mm;
  return sf;
}

class RigB {
 public:
  // rig: noise, ADC step, PWM levels of the condition (sma::RigOptions, read only as numbers).
  RigB(const Wire& w, const WireEffects& fx, const sma::RigOptions& rig, double dt)
      : wire_(w, fx), sensor_(sensor_fx(rig), dt, rig.seed), rig_(rig) {}

  double measure() { return sensor_.read(wire_.displacement_mm()); }
  double displacement() const { return wire_.displacement_mm(); }
  double temperature() const { return wire_.temperature(); }
  double applied_voltage(double V) const {
    if (!(V > 0.0)) return 0.0;  // NaN too: heater off
    V = fmin(V, rig_.v_supply);
    if (rig_.pwm_top == 0) return V;
    const double levels = static_cast<double>(rig_.pwm_top);
    const double n = floor(V * V / (rig_.v_supply * rig_.v_supply) * levels + 0.5);
    return rig_.v_supply * sqrt(n / levels);
  }
  void step(double V, double dt) { wire_.step(applied_voltage(V), dt); }
  const WirePlant& wire() const { return wire_; }

 private:
  static SensorEffects sensor_fx(const sma::RigOptions& rig) {
    SensorEffects s;
    s.noise_mm = rig.noise_mm;
    s.adc_mm = rig.adc_step_mm;
    return s;
  }
  WirePlant wire_;
  Sensor sensor_;
  sma::RigOptions rig_;
};

}  // namespace plant_b
}  // namespace sma_host

#endif  // SMA_HOST_PLANT_B_RIG_HPP
