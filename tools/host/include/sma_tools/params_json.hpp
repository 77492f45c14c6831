// Model parameters as JSON (interfaces.md): a flat object with the keys of Table II, `m` as the
// list m0..m5, `loops` as a list of {"T_i","T_ii","j"} and `effects` as
// {"<effect name>": {<its parameters>}}, every key from the parameter table (sma/param_table.hpp).
// Missing keys keep the paper's values (sma::Params defaults); an unknown key is an error naming
// the key; the result must pass sma::Params::check() and sma::Effects::check() (the message
// names the key).
#ifndef SMA_TOOLS_PARAMS_JSON_HPP
#define SMA_TOOLS_PARAMS_JSON_HPP

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "error.hpp"
#include "json.hpp"
#include "sma/effects.hpp"
#include "sma/param_table_access.hpp"
#include "sma/params.hpp"
#include "../../../../host/include/sma_host/model.hpp"  // relative: see error.hpp

namespace sma_tools {

using sma_host::Model;

// The keys of the contract from the parameter table (sma/param_table.hpp), in its order: the
// Table II scalars at the top level, and the effects' parameters "<effect>.<param>" under
// "effects" (m and loops have their own shapes). `key`: the table's flat key.
struct ParamKey {
  std::string name;
  uint8_t key;
};
struct EffectKey {
  std::string effect;
  std::string param;
  uint8_t key;
};
using sma_host::key_kind;
using sma_host::key_name;
using sma_host::value;
using sma_host::violation_text;
inline const std::vector<ParamKey>& param_keys() {
  static const std::vector<ParamKey> keys = [] {
    std::vector<ParamKey> v;
    for (uint8_t k = 0; k < sma::param::kKeys; ++k)
      if (key_kind(k) == sma::param::Kind::Table) v.push_back({key_name(k), k});
    return v;
  }();
  return keys;
}
inline const std::vector<EffectKey>& effect_keys() {
  static const std::vector<EffectKey> keys = [] {
    std::vector<EffectKey> v;
    for (uint8_t k = 0; k < sma::param::kKeys; ++k) {
      if (key_kind(k) != sma::param::Kind::Effect) continue;
      const std::string n = key_name(k);
      const size_t dot = n.find('.');
      v.push_back({n.substr(0, dot), n.substr(dot + 1), k});  // (effect_of_key, param_of_key)
    }
    return v;
  }();
  return keys;
}
inline std::string effect_names_list() {
  std::string out, last;
  for (const auto& k : effect_keys()) {
    if (k.effect == last) continue;
    if (!out.empty()) out += ", ";
    out += k.effect;
    last = k.effect;
  }
  return out;
}


// Sets effect parameter `effect`.`param`; throws naming what is unknown.
inline void set_effect(sma::Effects& fx, const std::string& effect, const std::string& param,
                       double value, const std::string& where) {
  bool effect_known = false;
  std::string params;
  for (const auto& k : effect_keys()) {
    if (effect != k.effect) continue;
    effect_known = true;
    if (param == k.param) {
      sma_host::value(fx, k.key) = value;
      return;
    }
    params += params.empty() ? k.param : std::string(", ") + k.param;
  }
  if (!effect_known)
    throw Error(where + "unknown effect '" + effect + "' (known: " + effect_names_list() + ")");
  throw Error(where + "effect '" + effect + "': unknown parameter '" + param + "' (known: " +
              params + ")");
}

// "--effect name.param=value" syntax.
inline void set_effect_arg(sma::Effects& fx, const std::string& arg) {
  const size_t dot = arg.find('.'), eq = arg.find('=');
  if (dot == std::string::npos || eq == std::string::npos || eq < dot)
    throw Error("--effect '" + arg + "': expected name.param=value, e.g. sensor_delay.delay_s=0.1");
  const std::string val = arg.substr(eq + 1);
  char* end = nullptr;
  const double x = std::strtod(val.c_str(), &end);
  if (val.empty() || *end != 0 || !std::isfinite(x))
    throw Error("--effect '" + arg + "': '" + val + "' is not a number");
  set_effect(fx, arg.substr(0, dot), arg.substr(dot + 1, eq - dot - 1), x, "--effect: ");
}

// Checks a model; throws "<where>: <key>: <why>" (the parameter table's message).
inline void check_model(const Model& m, const std::string& where) {
  if (const sma::param::Violation v = m.p.check()) throw Error(where + ": " + violation_text(v));
  if (const sma::param::Violation v = m.fx.check()) throw Error(where + ": " + violation_text(v));
}

inline double need_number(const json::Value& v, const std::string& where, const std::string& key) {
  if (!v.is_number())
    throw Error(where + ":" + std::to_string(v.line) + ": key '" + key + "' must be a number, not " +
                json::Value::type_name(v.type));
  return v.num;
}

// The re-heat reading of the loop memory (sma::Reheat, hysteresis.hpp), key "reheat".
using sma_host::reheat_name;
inline sma::Reheat reheat_from_name(const json::Value& v, const std::string& at) {
  sma::Reheat r;
  if (v.type == json::Value::Type::String && sma_host::reheat_from_text(v.str, r)) return r;
  throw Error(at + ": key 'reheat' must be \"return_point\" or \"new_loop\"");
}
// The tools' --reheat VALUE.
inline sma::Reheat reheat_option(const std::string& s) {
  sma::Reheat r;
  if (!sma_host::reheat_from_text(s, r)) throw Error("--reheat must be return_point or new_loop, not '" + s + "'");
  return r;
}

// Fills `m` from a parsed object (keys not given keep their value in m).
inline void model_from_json(const json::Value& root, Model& m, const std::string& name) {
  if (!root.is_object())
    throw Error(name + ": expected a JSON object of parameters, found " +
                json::Value::type_name(root.type));
  for (const auto& kv : root.obj) {
    const std::string& key = kv.first;
    const json::Value& v = kv.second;
    const std::string at = name + ":" + std::to_string(v.line);
    bool done = false;
    for (const auto& k : param_keys()) {
      if (key == k.name) {
        value(m, k.key) = need_number(v, name, key);
        done = true;
        break;
      }
    }
    if (done) continue;
    if (key == "m") {
      if (!v.is_array() || v.arr.size() != 6)
        throw Error(at + ": key 'm' must be a list of 6 numbers m0..m5");
      for (size_t i = 0; i < 6; ++i) m.p.m[i] = need_number(v.arr[i], name, "m");
    } else if (key == "loops") {
      if (!v.is_array()) throw Error(at + ": key 'loops' must be a list of {\"T_i\",\"T_ii\",\"j\"}");
      if (v.arr.size() > sma::kMaxLoopKnots)
        throw Error(at + ": key 'loops': at most " + std::to_string(sma::kMaxLoopKnots) + " loops");
      m.p.n_loops = static_cast<uint8_t>(v.arr.size());
      for (size_t i = 0; i < v.arr.size(); ++i) {
        const json::Value& L = v.arr[i];
        const std::string lat = name + ":" + std::to_string(L.line);
        if (!L.is_object()) throw Error(lat + ": loops[" + std::to_string(i) + "] must be an object");
        for (const auto& f : L.obj)
          if (f.first != "T_i" && f.first != "T_ii" && f.first != "j")
            throw Error(lat + ": loops[" + std::to_string(i) + "]: unknown key '" + f.first +
                        "' (expected T_i, T_ii, j)");
        const char* req[] = {"T_i", "T_ii", "j"};
        double vals[3];
        for (int r = 0; r < 3; ++r) {
          const json::Value* f = L.find(req[r]);
          if (!f) throw Error(lat + ": loops[" + std::to_string(i) + "]: missing key '" + req[r] + "'");
          vals[r] = need_number(*f, name, std::string("loops.") + req[r]);
        }
        m.p.loops[i] = {vals[0], vals[1], vals[2]};
      }
    } else if (key == "reheat") {
      m.p.reheat = reheat_from_name(v, at);
    } else if (key == "effects") {
      if (!v.is_object()) throw Error(at + ": key 'effects' must be an object {\"name\": {...}}");
      for (const auto& e : v.obj) {
        const std::string eat = name + ":" + std::to_string(e.second.line) + ": ";
        if (!e.second.is_object())
          throw Error(eat + "effect '" + e.first + "' must be an object of its parameters");
        bool known = false;
        for (const auto& k : effect_keys()) known = known || e.first == k.effect;
        if (!known)
          throw Error(eat + "unknown effect '" + e.first + "' (known: " + effect_names_list() + ")");
        for (const auto& pv : e.second.obj)
          set_effect(m.fx, e.first, pv.first, need_number(pv.second, name, e.first + "." + pv.first),
                     name + ":" + std::to_string(pv.second.line) + ": ");
      }
    } else {
    {
      std::string known;
      for (const auto& k : param_keys()) known += k.name + " ";
      throw Error(at + ": unknown key '" + key + "' (known: " + known + "m loops reheat effects)");
    }
    }
  }
}

inline std::string read_text_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open");
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Reads and checks a params file. An empty path gives the paper's model.
inline Model read_model(const std::string& path) {
  Model m;
  if (path.empty()) return m;
  model_from_json(json::parse(read_text_file(path), path), m, path);
  check_model(m, path);
  return m;
}

inline Model model_from_text(const std::string& text, const std::string& name) {
  Model m;
  model_from_json(json::parse(text, name), m, name);
  check_model(m, name);
  return m;
}

// The contract's JSON. Effects that are at their identity value are left out (none: no key).
inline std::string model_to_json(const Model& m, bool pretty = true) {
  const std::string nl = pretty ? "\n" : "", ind = pretty ? "  " : "";
  const std::string sep = pretty ? ": " : ":";
  std::string out = "{" + nl;
  for (const auto& k : param_keys())
    out += ind + json::quote(k.name) + sep + json::number(value(m, k.key)) + "," + nl;
  out += ind + "\"m\"" + sep + "[";
  for (int i = 0; i < 6; ++i) out += (i ? ", " : "") + json::number(m.p.m[i]);
  out += "]," + nl + ind + "\"loops\"" + sep + "[";
  for (int i = 0; i < m.p.n_loops; ++i) {
    const sma::LoopKnot& L = m.p.loops[i];
    out += std::string(i ? ", " : "") + "{\"T_i\": " + json::number(L.T_i) +
           ", \"T_ii\": " + json::number(L.T_ii) + ", \"j\": " + json::number(L.j) + "}";
  }
  out += "]";
  // Written only when it is not the default, so every other params file stays as it was.
  if (m.p.reheat != sma::Reheat::return_point)
    out += "," + nl + ind + "\"reheat\"" + sep + json::quote(reheat_name(m.p.reheat));
  const Model none;
  std::string fx, open;
  for (const auto& k : effect_keys()) {
    if (value(m, k.key) == value(none, k.key)) continue;
    if (open != k.effect) {
      if (!open.empty()) fx += "}, ";
      fx += json::quote(k.effect) + sep + "{";
      open = k.effect;
    } else {
      fx += ", ";
    }
    fx += json::quote(k.param) + sep + json::number(value(m, k.key));
  }
  if (!open.empty()) out += "," + nl + ind + "\"effects\"" + sep + "{" + fx + "}}";
  out += nl + "}" + (pretty ? "\n" : "");
  return out;
}

}  // namespace sma_tools

#endif  // SMA_TOOLS_PARAMS_JSON_HPP
