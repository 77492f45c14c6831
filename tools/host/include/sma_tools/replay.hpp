// Replays a voltage record through the library's simulated rig (sma::Plant): the only way the
// host tools compute the model. Convention of the rig log: row k holds the displacement
// measured at t_k and the voltage applied from t_k to t_{k+1} (as the firmware logs it: measure,
// compute, apply).
#ifndef SMA_TOOLS_REPLAY_HPP
#define SMA_TOOLS_REPLAY_HPP

#include <memory>
#include <vector>
#include "params_json.hpp"
#include "sma_host/plant.hpp"

namespace sma_tools {

struct Trace {
  std::vector<double> y;    // what the sensor reports (clean unless noise asked)
  std::vector<double> D;    // true displacement, mm
  std::vector<double> T;    // wire temperature, deg C
  std::vector<double> eps;  // austenite fraction
};

struct ReplayOptions {
  sma::RigOptions rig;  // noise etc.; v_supply is raised to the log's largest V
  bool noisy = false;   // measure() (noise, ADC step) instead of measure_clean()
  double eps0 = 0.0;    // fraction at the start (at ambient temperature)
  size_t stride = 1;    // record every stride-th row (the simulation runs all rows)
  bool want_states = true;
};

inline void replay(const Model& m, const std::vector<double>& t, const std::vector<double>& v,
                   const ReplayOptions& o, Trace& out) {
  sma::RigOptions rig = o.rig;
  double vmax = 0.0;
  for (double x : v) vmax = x > vmax ? x : vmax;
  if (vmax * 1.0001 > rig.v_supply) rig.v_supply = vmax * 1.0001;  // the plant clamps V to it
  std::unique_ptr<sma::Plant> plant(new sma::Plant(m.p, m.fx, rig));
  plant->reset(m.p.T_amb + m.fx.ambient_offset_K, o.eps0);
  const size_t n = t.size(), stride = o.stride ? o.stride : 1;
  const size_t nout = (n + stride - 1) / stride;
  out.y.assign(nout, 0.0);
  if (o.want_states) {
    out.D.assign(nout, 0.0);
    out.T.assign(nout, 0.0);
    out.eps.assign(nout, 0.0);
  } else {
    out.D.clear();
    out.T.clear();
    out.eps.clear();
  }
  for (size_t k = 0; k < n; ++k) {
    if (k % stride == 0) {
      const size_t j = k / stride;
      out.y[j] = o.noisy ? plant->measure() : plant->measure_clean();
      if (o.want_states) {
        out.D[j] = plant->displacement();
        out.T[j] = plant->temperature();
        out.eps[j] = plant->fraction();
      }
    }
    if (k + 1 < n) plant->step(v[k], t[k + 1] - t[k]);
  }
}

}  // namespace sma_tools

#endif  // SMA_TOOLS_REPLAY_HPP
