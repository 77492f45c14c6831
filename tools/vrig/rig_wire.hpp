// The wire behind the virtual rig: the library's plant (sma::Plant, the default) or plant B
// (sma_host/plant_b.hpp, written from model.md apart from the library: RK4 thermal sub-steps,
// its own hysteresis code, its own reading of each effect). With plant B the firmware's model
// and the wire it controls share no formula, so a firmware-in-the-loop run on it tests the
// board against a wire it was not written with, not against itself.
#ifndef VRIG_RIG_WIRE_HPP
#define VRIG_RIG_WIRE_HPP

#include <memory>
#include <string>

#include "sma/effects.hpp"
#include "sma/params.hpp"
#include "sma_host/plant.hpp"
#include "sma_host/plant_b_rig.hpp"

namespace vrig {

// What the rig needs of a wire: one heater step, one sensor sample, the true displacement.
class RigWire {
 public:
  virtual ~RigWire() {}
  virtual void step(double V, double dt) = 0;  // V already PWM-quantised by the firmware
  virtual double measure() = 0;                // the sensor's mm, one call per sample
  virtual double displacement() const = 0;     // the wire's true mm
};

class LibraryWire : public RigWire {
 public:
  LibraryWire(const sma::Params& p, const sma::Effects& fx, const sma::RigOptions& ro) : plant_(p, fx, ro) {}
  void step(double V, double dt) override { plant_.step(V, dt); }
  double measure() override { return plant_.measure(); }
  double displacement() const override { return plant_.displacement(); }

 private:
  sma::Plant plant_;
};

class PlantBWire : public RigWire {
 public:
  PlantBWire(const sma_host::plant_b::Wire& w, const sma_host::plant_b::WireEffects& wf,
             const sma_host::plant_b::SensorEffects& sf, double dt, uint64_t seed)
      : wire_(w, wf), sensor_(sf, dt, seed) {}
  void step(double V, double dt) override { wire_.step(V > 0.0 ? V : 0.0, dt); }
  double measure() override { return sensor_.read(wire_.displacement_mm()); }
  double displacement() const override { return wire_.displacement_mm(); }

 private:
  sma_host::plant_b::WirePlant wire_;
  sma_host::plant_b::Sensor sensor_;
};

// Plant B with the wire of a params JSON (Table II values copied, no code shared) and the
// effects in plant B's own terms (plant_b_rig.hpp, as tools/plant2/make_logs.cpp reads them).
// literal: a new loop at every heating -> cooling reversal (model.md read literally); else
// return-point memory (the library's reading). Null, with `problem`, when the wire does not fit
// plant B.
inline std::unique_ptr<RigWire> make_plant_b(const sma::Params& p, const sma::Effects& fx, bool literal,
                                             double noise_mm, double dt, uint64_t seed, std::string& problem) {
  sma_host::plant_b::Wire w;
  if (p.n_loops != 3) {
    problem = "--plant b takes a wire with 3 minor loops (plant B's table), this one has " +
              std::to_string(static_cast<int>(p.n_loops));
    return nullptr;
  }
  w.rho = p.rho, w.c = p.c, w.h = p.h, w.R = p.R, w.d0 = p.d0, w.L0 = p.L0, w.T_amb = p.T_amb;
  w.T_AS = p.T_AS, w.T_AF = p.T_AF, w.T_MS = p.T_MS, w.T_MF = p.T_MF;
  w.T_s = p.T_s, w.T_f = p.T_f, w.T_MSs = p.T_MSs, w.T_MSf = p.T_MSf;
  for (int k = 0; k < 6; ++k) w.m[k] = p.m[k];
  w.q = p.q, w.e = p.e, w.g_mm = p.g;
  for (int k = 0; k < 3; ++k) {
    w.knot_Ti[k] = p.loops[k].T_i;
    w.knot_Tii[k] = p.loops[k].T_ii;
    w.knot_j[k] = p.loops[k].j;
  }
  w.return_point_memory = !literal;
  sma_host::plant_b::SensorEffects sf = sma_host::plant_b::sensor_effects(fx);
  sf.noise_mm = noise_mm;
  return std::unique_ptr<RigWire>(new PlantBWire(w, sma_host::plant_b::wire_effects(fx, w), sf, dt, seed));
}

}  // namespace vrig

#endif  // VRIG_RIG_WIRE_HPP
