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

// What the table's AVR-safe writers (put_key_name, put_violation: anything with put(char))
// write, as a string.
struct StringSink {
  std::string s;
  void put(char c) { s.push_back(c); }
};

// The parameter table's flat keys (sma/param_table.hpp) by their names on the host.
inline std::string key_name(uint8_t k) {  // rho, m3, loop1.T_ii, sensor_delay.delay_s, loops
  StringSink o;
  sma::param::put_key_name(o, k);
  return o.s;
}
// What check() found, as its message ("T_AF: must be > T_AS").
inline std::string violation_text(sma::param::Violation v) {
  StringSink o;
  sma::param::put_violation(o, v);
  return o.s;
}
inline sma::param::Kind key_kind(uint8_t k) { return sma::param::row(sma::param::locate(k).row).kind; }
// The unit of flat key k as the table writes it (degC, W/(m^2*K), 1/K; "1": dimensionless).
inline std::string key_unit(uint8_t k) {
#define SMA_HOST_ROW_UNIT(id, name, unit, lo, hi, kind, member, above) unit,
  static const char* const units[] = {SMA_PARAM_TABLE(SMA_HOST_ROW_UNIT)};
#undef SMA_HOST_ROW_UNIT
  const uint8_t r = sma::param::locate(k).row;
  return r < static_cast<uint8_t>(sma::param::Row::count) ? units[r] : "";
}
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
// The loop memory's reading of a re-heat that stops short of transformation (sma::Reheat,
// hysteresis.hpp) by its name in params JSON ("reheat"), reports and the tools' --reheat.
inline const char* reheat_name(sma::Reheat r) {
  return r == sma::Reheat::new_loop ? "new_loop" : "return_point";
}
inline bool reheat_from_text(const std::string& s, sma::Reheat& r) {
  for (sma::Reheat c : {sma::Reheat::return_point, sma::Reheat::new_loop})
    if (s == reheat_name(c)) {
      r = c;
      return true;
    }
  return false;
}

// The value of flat key k (not the loop count) in a model.
inline double& value(Model& m, uint8_t k) { return *sma::param::value_ptr(m.p, m.fx, k); }
inline double value(const Model& m, uint8_t k) { return sma::param::get_value(m.p, m.fx, k); }
// ... in an Effects alone (k an effect's key).
inline double& value(sma::Effects& fx, uint8_t k) { return *sma::param::value_ptr(fx, k); }
inline double value(const sma::Effects& fx, uint8_t k) { return *sma::param::value_ptr(const_cast<sma::Effects&>(fx), k); }

}  // namespace sma_host

#endif  // SMA_HOST_MODEL_HPP
