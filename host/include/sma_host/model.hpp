// A model of the wire and rig: the paper's parameters (params.hpp) and the effects of the
// vocabulary (effects.hpp). What a params file holds (interfaces.md) and what is identified.
#ifndef SMA_HOST_MODEL_HPP
#define SMA_HOST_MODEL_HPP

#include <stdint.h>
#include <string>
#include "sma/effects.hpp"
#include "sma/param_table_access.hpp"
#include "sma/params.hpp"

namespace sma_host {

struct Model {
  sma::Params p;
  sma::Effects fx;
};

// The parameter table's flat keys (sma/param_table.hpp) by their names on the host.
inline std::string key_name(uint8_t k) {  // rho, m3, loop1.T_ii, sensor_delay.delay_s, loops
  struct Out {
    std::string s;
    void put(char c) { s.push_back(c); }
  } o;
  sma::param::put_key_name(o, k);
  return o.s;
}
inline sma::param::Kind key_kind(uint8_t k) { return sma::param::row(sma::param::locate(k).row).kind; }
// An effect's key: its vocabulary name (interfaces.md) and its parameter's JSON name.
inline std::string effect_of_key(uint8_t k) {
  const std::string n = key_name(k);
  return n.substr(0, n.find('.'));
}
inline std::string param_of_key(uint8_t k) {
  const std::string n = key_name(k);
  return n.substr(n.find('.') + 1);
}
// The name a fit gives the parameter: a Table II name as is, an effect's parameter alone
// (delay_s), a loop's field with the loop counted from 1 (j1, T_ii2).
inline std::string fit_name(uint8_t k) {
  const sma::param::Place at = sma::param::locate(k);
  switch (key_kind(k)) {
    case sma::param::Kind::Effect: return param_of_key(k);
    case sma::param::Kind::Knot: return param_of_key(k) + std::to_string(at.index + 1);
    default: return key_name(k);
  }
}
// The value of flat key k (not the loop count) in a model.
inline double& value(Model& m, uint8_t k) { return *sma::param::value_ptr(m.p, m.fx, k); }
inline double value(const Model& m, uint8_t k) { return sma::param::get_value(m.p, m.fx, k); }
// ... in an Effects alone (k an effect's key).
inline double& value(sma::Effects& fx, uint8_t k) { return *sma::param::value_ptr(fx, k); }
inline double value(const sma::Effects& fx, uint8_t k) { return *sma::param::value_ptr(const_cast<sma::Effects&>(fx), k); }

}  // namespace sma_host

#endif  // SMA_HOST_MODEL_HPP
