// Open-loop voltage signals for the simulated rig: piecewise-linear breakpoint lists (a repeated
// time is a jump), built from a constant, a list of steps, a CSV of t,V, or the paper's training
// signal (section III.B, Fig. 4; defined in sma_host/signals.hpp).
#ifndef SMA_TOOLS_SIGNALS_HPP
#define SMA_TOOLS_SIGNALS_HPP

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include "error.hpp"
#include "rig_log.hpp"
#include "sma_host/signals.hpp"

namespace sma_tools {

class Pwl {
 public:
  void add(double t, double v) {
    if (!pts_.empty() && t < pts_.back().first) throw Error("signal: time must not decrease");
    pts_.emplace_back(t, v);
  }
  bool empty() const { return pts_.empty(); }
  double duration() const { return pts_.empty() ? 0.0 : pts_.back().first; }
  // Value at t: linear between points; at a repeated time the later point holds from there on.
  double at(double t) {
    if (pts_.empty()) return 0.0;
    if (t <= pts_.front().first) return pts_.front().second;
    if (t >= pts_.back().first) return pts_.back().second;
    if (cursor_ >= pts_.size() || pts_[cursor_].first > t) cursor_ = 0;  // rewind if asked back
    while (cursor_ + 1 < pts_.size() && pts_[cursor_ + 1].first <= t) ++cursor_;
    const auto& a = pts_[cursor_];
    const auto& b = pts_[cursor_ + 1];
    const double span = b.first - a.first;
    if (!(span > 0.0)) return b.second;
    return a.second + (t - a.first) / span * (b.second - a.second);
  }
  const std::vector<std::pair<double, double>>& points() const { return pts_; }

 private:
  std::vector<std::pair<double, double>> pts_;
  size_t cursor_ = 0;
};

// The training signal (sma::TrainingPlan::voltage_at, the one definition) as a Pwl: sampled
// every 10 ms, exact at every sample and linear between them, as the ramps are.
struct TrainingSignal : sma_host::TrainingSignal {
  Pwl build() const {
    if (const char* problem = check()) throw Error(std::string("training signal: ") + problem);
    const sma_host::VoltageSignal v = sample(0.01);
    Pwl s;
    for (size_t k = 0; k < v.t.size(); ++k) s.add(v.t[k], v.v[k]);
    s.add(v.t.back() + 0.01, 0.0);
    return s;
  }
};

inline std::vector<double> parse_list(const std::string& text, const std::string& what) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    double x;
    if (!detail::to_number(detail::trim(item), x))
      throw Error(what + ": '" + item + "' is not a number");
    out.push_back(x);
  }
  if (out.empty()) throw Error(what + ": empty list");
  return out;
}

// "V1@t1,V2@t2,...": V1 from t1 (the first time is normally 0), then V2 from t2, ...; the
// last value holds for `tail_s` after its start.
inline Pwl steps_signal(const std::string& spec, double tail_s) {
  Pwl s;
  std::stringstream ss(spec);
  std::string item;
  double last_t = -1.0;
  while (std::getline(ss, item, ',')) {
    const size_t at = item.find('@');
    double v = 0.0, t = 0.0;
    if (at == std::string::npos || !detail::to_number(detail::trim(item.substr(0, at)), v) ||
        !detail::to_number(detail::trim(item.substr(at + 1)), t))
      throw Error("steps: '" + item + "': expected V@t, e.g. 1.4@0,0@60");
    if (!(t > last_t)) throw Error("steps: times must increase ('" + item + "')");
    if (s.empty()) {
      s.add(t, v);
    } else {
      s.add(t, s.points().back().second);
      s.add(t, v);
    }
    last_t = t;
  }
  if (s.empty()) throw Error("steps: empty");
  s.add(last_t + tail_s, s.points().back().second);
  return s;
}

// A CSV of t,V (header optional, '#' comments), linear between points; strict like the logs.
// `value`: what the second column is, for the messages (a voltage, or a trajectory's position).
inline Pwl csv_signal(const std::string& path, const std::string& value = "voltage", const std::string& column = "V") {
  std::ifstream f(path);
  if (!f) throw Error(path + ": cannot open");
  Pwl s;
  std::string raw;
  long lineno = 0;
  bool first = true;
  while (std::getline(f, raw)) {
    ++lineno;
    const std::string line = detail::trim(raw);
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> fld = detail::split(line);
    double t, v;
    const bool numeric = fld.size() == 2 && detail::to_number(fld[0], t) && detail::to_number(fld[1], v);
    if (!numeric) {
      if (first && fld.size() == 2) {  // a header
        first = false;
        continue;
      }
      throw Error(path + ":" + std::to_string(lineno) + ": expected two numbers t," + column);
    }
    first = false;
    if (!s.empty() && !(t > s.points().back().first))
      throw Error(path + ":" + std::to_string(lineno) + ": time does not increase");
    if (v < 0.0) throw Error(path + ":" + std::to_string(lineno) + ": negative " + value);
    s.add(t, v);
  }
  if (s.empty()) throw Error(path + ": no t,V points");
  return s;
}

}  // namespace sma_tools

#endif  // SMA_TOOLS_SIGNALS_HPP
