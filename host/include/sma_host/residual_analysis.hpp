// Which of the model's states the unexplained residual follows: what tells a user that the
// vocabulary is not enough, and where to look for the missing physics.
// States along the log (from the model's trace): the wire temperature T, its rate dT/dt, the
// austenite fraction, heating (dT/dt > 0) or cooling, the heating input V^2, and the time since
// the model last reversed between heating and cooling. For each: the share of the residual's
// variance explained by a straight line (R^2 linear) and by the means of 8 equally populated
// bins (R^2 binned: any shape), with those bin means for the plot.
#ifndef SMA_HOST_RESIDUAL_ANALYSIS_HPP
#define SMA_HOST_RESIDUAL_ANALYSIS_HPP

#include <math.h>
#include <algorithm>
#include <string>
#include <vector>
#include "identify.hpp"

namespace sma_host {

struct StateFit {
  std::string state;               // "T", "dT/dt", "fraction", "heating", "V^2", "time since reversal"
  std::string unit;
  double r2_linear = 0, r2_binned = 0;
  double slope = 0;                // mm per unit of the state
  std::vector<double> bin_x, bin_mean;  // bin centres (mean state) and mean residual
};

struct ResidualAnalysis {
  double rms_mm = 0;
  std::vector<StateFit> states;  // sorted: the best-explaining state first
  std::string follows;           // the state with R^2 binned >= 0.3, else ""
};

// The model's states along a log: what the residual is regressed on.
inline std::vector<std::vector<double>> model_states(const RigLog& log, const Trace& tr) {
  const size_t n = log.size();
  std::vector<double> rate(n), heat(n), v2(n), since(n);
  for (size_t k = 0; k < n; ++k) {
    const size_t a = k ? k - 1 : 0, b = k + 1 < n ? k + 1 : k;
    const double span = log.t[b] - log.t[a];
    rate[k] = span > 0 ? (tr.T[b] - tr.T[a]) / span : 0.0;
    heat[k] = rate[k] > 0 ? 1.0 : 0.0;
    v2[k] = log.v[k] * log.v[k];
  }
  // A reversal: the direction of dT/dt changes, ignoring rates below 0.05 K/s (holds).
  int dir = 0;
  double t_rev = n ? log.t[0] : 0.0;
  for (size_t k = 0; k < n; ++k) {
    const int d = rate[k] > 0.05 ? 1 : rate[k] < -0.05 ? -1 : 0;
    if (d != 0 && d != dir) {
      dir = d;
      t_rev = log.t[k];
    }
    since[k] = log.t[k] - t_rev;
  }
  return {tr.T, rate, tr.eps, heat, v2, since};
}

inline StateFit fit_state(const std::string& name, const std::string& unit, const std::vector<double>& x,
                          const std::vector<double>& r) {
  StateFit s;
  s.state = name;
  s.unit = unit;
  const size_t n = r.size();
  if (n < 16) return s;
  double mx = 0, mr = 0;
  for (size_t k = 0; k < n; ++k) {
    mx += x[k] / static_cast<double>(n);
    mr += r[k] / static_cast<double>(n);
  }
  double sxx = 0, sxr = 0, srr = 0;
  for (size_t k = 0; k < n; ++k) {
    sxx += (x[k] - mx) * (x[k] - mx);
    sxr += (x[k] - mx) * (r[k] - mr);
    srr += (r[k] - mr) * (r[k] - mr);
  }
  if (!(srr > 0)) return s;
  s.slope = sxx > 0 ? sxr / sxx : 0.0;
  s.r2_linear = sxx > 0 ? sxr * sxr / (sxx * srr) : 0.0;
  // 8 equally populated bins (a two-valued state such as heating: its two values).
  std::vector<size_t> idx(n);
  for (size_t k = 0; k < n; ++k) idx[k] = k;
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
  const size_t bins = 8;
  double between = 0;
  size_t start = 0;
  while (start < n) {
    size_t end = std::min(n, start + (n + bins - 1) / bins);
    while (end < n && x[idx[end]] == x[idx[end - 1]]) ++end;  // ties stay in one bin
    double bx = 0, br = 0;
    for (size_t i = start; i < end; ++i) {
      bx += x[idx[i]];
      br += r[idx[i]];
    }
    const double m = static_cast<double>(end - start);
    s.bin_x.push_back(bx / m);
    s.bin_mean.push_back(br / m);
    between += m * (br / m - mr) * (br / m - mr);
    start = end;
  }
  s.r2_binned = between / srr;
  return s;
}

// residual = measured - model (the final model's), tr its trace on the same log.
inline ResidualAnalysis analyse_residual(const RigLog& log, const Trace& tr, const std::vector<double>& residual) {
  ResidualAnalysis a;
  double sq = 0;
  for (double x : residual) sq += x * x;
  a.rms_mm = residual.empty() ? 0 : sqrt(sq / static_cast<double>(residual.size()));
  const std::vector<std::vector<double>> st = model_states(log, tr);
  const char* names[] = {"T", "dT/dt", "fraction", "heating", "V^2", "time since reversal"};
  const char* units[] = {"degC", "K/s", "1", "1", "V^2", "s"};
  for (size_t i = 0; i < st.size(); ++i) a.states.push_back(fit_state(names[i], units[i], st[i], residual));
  std::sort(a.states.begin(), a.states.end(),
            [](const StateFit& p, const StateFit& q) { return p.r2_binned > q.r2_binned; });
  if (!a.states.empty() && a.states[0].r2_binned >= 0.3) a.follows = a.states[0].state;
  return a;
}

}  // namespace sma_host

#endif  // SMA_HOST_RESIDUAL_ANALYSIS_HPP
