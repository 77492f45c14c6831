// Closed loops on plant B (plant_b_rig.hpp) for the benchmarks: one place for the rig they build.
#ifndef SMA_HOST_PLANT_B_LOOP_HPP
#define SMA_HOST_PLANT_B_LOOP_HPP

#include <vector>
#include "sma_host/closed_loop.hpp"
#include "sma_host/plant_b_rig.hpp"

namespace sma_host {
namespace plant_b {

// A closed loop (run_closed_loop_on) on plant B, wire w (default: the paper's, model.md's literal
// re-heat reading), without effects, under the run's rig condition.
template <class T>
std::vector<Sample> run_closed_loop_b(const RunSetup& s, const Wire& w = Wire()) {
  RigB rig(w, WireEffects(), s.condition.rig, s.config.dt);
  return run_closed_loop_on<T>(rig, s);
}

}  // namespace plant_b
}  // namespace sma_host

#endif  // SMA_HOST_PLANT_B_LOOP_HPP
