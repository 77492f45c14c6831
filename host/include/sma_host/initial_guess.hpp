// Start values from the log itself, and the plausible ranges of a NiTi wire (issue 11).
//
// A fit started from another wire's values (the paper's: a 0.14 m wire transforming at
// 50-80 degC) stalls in a valley of the hysteresis parameters on any other wire. What the log
// itself says, given the geometry (d0, L0) and the wire's resistance R:
//  - the thermal time constant tau = C_th / G (eq 1), i.e. h: a global stage replays the log for
//    h on a log-spaced grid and keeps the best;
//  - for each h the wire temperature T(t) of eq 1 follows from the log's voltage alone
//    (ThermalStep: exact for a held V), and the transformation band is read where the
//    displacement moves: the temperature at which it first crosses 10 % and 90 % of its range
//    while heating gives T_AS, T_AF (eq 2's cosine passes 0.1 and 0.9 at 20.5 % and 79.5 % of
//    its band), the last crossings while cooling give the martensite start of a full
//    transformation T_MSi = q + e (eq 10 at eps_h = 1) and T_MF (eq 3);
//  - the stroke g and the sensor zero from the displacement's range;
//  - T_s, T_f, T_MSs, T_MSf and the loop knots tied to the bands: the paper's Table II mapped
//    from its bands (50.2-80.1 heating, 22-27.77 cooling) onto the log's, so the minor loops
//    move with the wire instead of staying at the paper's temperatures;
//  - thermal expansion (effects.hpp), when the model carries it: from the rise of the position
//    after the last heater-off edge, while the wire cools towards its martensite start.
// Eq 1 is linear, so scaling every temperature rise over ambient by s and R by 1/s (and the
// expansion coefficient by 1/s) leaves the displacement unchanged: a log alone cannot tell the
// heating power's scale. R stays the user's; a band hint (the wire's nominal transformation
// temperatures) may fix that scale instead.
#ifndef SMA_HOST_INITIAL_GUESS_HPP
#define SMA_HOST_INITIAL_GUESS_HPP

#include <math.h>
#include <algorithm>
#include <memory>
#include <string>
#include <vector>
#include "sma/effects.hpp"
#include "sma/params.hpp"
#include "sma_host/plant.hpp"
#include "sma/thermal.hpp"

namespace sma_host {

// Soft bounds of a NiTi actuator wire: outside them a fit is suspect, not impossible.
struct Plausible {
  double T_lo = 0.0, T_hi = 120.0;        // transformation temperatures, degC
  double width_lo = 5.0, width_hi = 35.0; // width of a transformation band, K
  double h_lo = 5.0, h_hi = 500.0;        // convection, W/(m^2 K)
  double alpha_hi = 3e-5;                 // linear expansion, 1/K (NiTi: 0.7-1.1e-5)
};

// One message per parameter outside the plausible ranges, naming it; empty when all are in.
inline std::vector<std::string> plausibility_warnings(const sma::Params& p, const sma::Effects& fx,
                                                      const Plausible& b = Plausible()) {
  std::vector<std::string> w;
  char buf[200];
  auto temp = [&](const char* name, double v) {
    if (v < b.T_lo || v > b.T_hi) {
      snprintf(buf, sizeof buf, "%s = %.1f degC is outside the plausible %.0f..%.0f degC of a NiTi wire", name, v,
               b.T_lo, b.T_hi);
      w.push_back(buf);
    }
  };
  auto width = [&](const char* name, double v) {
    if (v < b.width_lo || v > b.width_hi) {
      snprintf(buf, sizeof buf, "%s = %.1f K: a NiTi wire transforms over %.0f..%.0f K", name, v, b.width_lo,
               b.width_hi);
      w.push_back(buf);
    }
  };
  const double T_MS_full = p.q + p.e;  // eq 10 at eps_h = 1: the martensite start after a full heat
  temp("T_AS", p.T_AS);
  temp("T_AF", p.T_AF);
  temp("T_MF", p.T_MF);
  temp("q + e (martensite start of a full transformation)", T_MS_full);
  width("T_AF - T_AS", p.T_AF - p.T_AS);
  width("q + e - T_MF (cooling band)", T_MS_full - p.T_MF);
  if (p.h < b.h_lo || p.h > b.h_hi) {
    snprintf(buf, sizeof buf, "h = %.1f W/(m^2 K) is outside the plausible %.0f..%.0f", p.h, b.h_lo, b.h_hi);
    w.push_back(buf);
  }
  if (fx.thermal_expansion_per_K > b.alpha_hi) {
    snprintf(buf, sizeof buf, "alpha_per_K = %.3g /K is above the %.0e of NiTi", fx.thermal_expansion_per_K,
             b.alpha_hi);
    w.push_back(buf);
  }
  return w;
}

struct GuessOptions {
  double h_lo = 5.0, h_hi = 500.0;  // the global stage's grid of h
  int n_h = 25;
  double band_hint_C = NAN;         // nominal middle of the heating band, degC: fixes R's scale
};

struct Guess {
  sma::Params p;
  sma::Effects fx;
  double rms_mm = NAN;               // of the guess on the log
  std::vector<std::string> notes;    // what was read from the log, or why not
};

namespace detail {

// Wire temperature along the log, eq 1 held over each sample (row k's V applies to t_k..t_k+1).
inline std::vector<double> temperature_path(const sma::Params& p, const sma::Effects& fx,
                                            const std::vector<double>& t, const std::vector<double>& v) {
  std::vector<double> T(t.size());
  const sma::Thermal<double> th(p, fx);
  double Tw = th.T_a;
  for (size_t k = 0; k < t.size(); ++k) {
    T[k] = Tw;
    if (k + 1 < t.size()) {
      const sma::ThermalStep<double> step(p, t[k + 1] - t[k], fx);
      Tw = step(Tw, v[k]);
    }
  }
  return T;
}

// First index in [from, to) where x crosses level upwards (rising) or downwards; -1 if none.
inline long crossing(const std::vector<double>& x, double level, bool rising, size_t from, size_t to) {
  for (size_t k = std::max<size_t>(from, 1); k < to; ++k)
    if (rising ? (x[k - 1] < level && x[k] >= level) : (x[k - 1] > level && x[k] <= level))
      return static_cast<long>(k);
  return -1;
}

// The paper's Table II bands, onto which a log's are mapped (model.md).
constexpr double kPaperAS = 50.2, kPaperAF = 80.1, kPaperMS = 27.772, kPaperMF = 22.0;

}  // namespace detail

// RMS of a model on a log (the library's plant driven by the log's voltage, clean sensor).
inline double model_rms(const sma::Params& p, const sma::Effects& fx, const std::vector<double>& t,
                        const std::vector<double>& v, const std::vector<double>& d) {
  if (p.check() || fx.check()) return INFINITY;
  sma::RigOptions rig;
  for (double x : v) rig.v_supply = std::max(rig.v_supply, x * 1.0001);
  std::unique_ptr<sma::Plant> plant(new sma::Plant(p, fx, rig));
  double s = 0.0;
  for (size_t k = 0; k < t.size(); ++k) {
    const double r = plant->measure_clean() - d[k];
    s += r * r;
    if (k + 1 < t.size()) plant->step(v[k], t[k + 1] - t[k]);
  }
  return sqrt(s / static_cast<double>(std::max<size_t>(t.size(), 1)));
}

// The start values read from a log (t, v, d), for the wire `start` (its geometry, R, T_amb and
// effects are kept; its transformation parameters, h, g, the sensor offset and, when the model
// has it, the thermal expansion are replaced by what the log shows).
inline Guess initial_guess(const std::vector<double>& t, const std::vector<double>& v,
                           const std::vector<double>& d, const sma::Params& start, const sma::Effects& fx0,
                           const GuessOptions& o = GuessOptions()) {
  Guess best;
  best.p = start;
  best.fx = fx0;
  const size_t n = t.size();
  if (n < 10) {
    best.notes.push_back("log too short for start values: kept the given ones");
    return best;
  }
  std::vector<double> s = d;
  std::sort(s.begin(), s.end());
  const double lo = s[n / 100], hi = s[n - 1 - n / 100];
  if (!(hi - lo > 0.0)) {
    best.notes.push_back("the displacement does not move: kept the given start values");
    return best;
  }
  const double y10 = lo + 0.1 * (hi - lo), y90 = lo + 0.9 * (hi - lo);
  // The heating crossings: first up-crossings; the cooling ones: after the last 90 % down-crossing.
  const long up10 = detail::crossing(d, y10, true, 0, n);
  const long up90 = up10 < 0 ? -1 : detail::crossing(d, y90, true, static_cast<size_t>(up10), n);
  long dn90 = -1;
  for (size_t k = n - 1; k > 0 && dn90 < 0; --k)
    if (d[k - 1] > y90 && d[k] <= y90) dn90 = static_cast<long>(k);
  const long dn10 = dn90 < 0 ? -1 : detail::crossing(d, y10, false, static_cast<size_t>(dn90), n);
  if (up10 < 0 || up90 < 0) {
    best.notes.push_back("the log never heats the wire through its band: kept the given start values");
    return best;
  }
  const bool cools = dn90 > 0 && dn10 > 0;
  if (!cools) best.notes.push_back("the log does not cool the wire through its band: the cooling branch keeps its start");
  // The last heater-off edge before the cooling transformation, for the expansion.
  long off = -1;
  if (cools)
    for (long k = dn90; k > 0 && off < 0; --k)
      if (v[static_cast<size_t>(k - 1)] > 0.0 && v[static_cast<size_t>(k)] <= 0.0) off = k;

  const double c10 = 0.2048, c90 = 0.7952;  // eq 2's cosine: 0.1 and 0.9 at these band fractions
  double best_rms = INFINITY;
  for (int i = 0; i < o.n_h; ++i) {
    sma::Params p = start;
    sma::Effects fx = fx0;
    p.h = o.h_lo * pow(o.h_hi / o.h_lo, i / static_cast<double>(o.n_h - 1));
    fx.sensor_offset_mm = lo;
    p.g = hi - lo;
    const std::vector<double> T = detail::temperature_path(p, fx, t, v);
    const double w = (T[static_cast<size_t>(up90)] - T[static_cast<size_t>(up10)]) / (c90 - c10);
    if (!(w > 0.5)) continue;
    p.T_AS = T[static_cast<size_t>(up10)] - c10 * w;
    p.T_AF = p.T_AS + w;
    double T_MS = p.T_AS - 0.2 * w, T_MF = T_MS - w;  // without a cool-down: below the heating band
    if (cools) {
      const double wc = (T[static_cast<size_t>(dn90)] - T[static_cast<size_t>(dn10)]) / (c90 - c10);
      if (wc > 0.5) {
        T_MF = T[static_cast<size_t>(dn10)] - c10 * wc;
        T_MS = T_MF + wc;
      }
    }
    // Table II mapped onto these bands (T_s, T_f, the loops' T_i, T_ii on the heating band;
    // T_MSs, T_MSf, q, e on the cooling one, q as the slope of eq 10 in band units).
    const double kh = w / (detail::kPaperAF - detail::kPaperAS);
    const double kc = (T_MS - T_MF) / (detail::kPaperMS - detail::kPaperMF);
    auto heat_map = [&](double x) { return p.T_AS + (x - detail::kPaperAS) * kh; };
    auto cool_map = [&](double x) { return T_MF + (x - detail::kPaperMF) * kc; };
    const sma::Params paper;
    p.T_s = heat_map(paper.T_s);
    p.T_f = heat_map(paper.T_f);
    p.T_MSs = cool_map(paper.T_MSs);
    p.T_MSf = cool_map(paper.T_MSf);
    p.q = paper.q * kc;
    p.e = T_MS - p.q;  // q + e = T_MS
    p.T_MF = T_MF;
    p.T_MS = T_MS;
    for (uint8_t k = 0; k < p.n_loops; ++k) {
      p.loops[k].T_i = heat_map(start.loops[k].T_i);
      p.loops[k].T_ii = heat_map(start.loops[k].T_ii);
    }
    if (fx0.thermal_expansion_per_K > 0.0 && off > 0) {
      // The position rises from the heater-off edge to its peak as the wire shortens.
      size_t kp = static_cast<size_t>(off);
      for (size_t k = static_cast<size_t>(off); k < static_cast<size_t>(dn90); ++k)
        if (d[k] > d[kp]) kp = k;
      const double rise = d[kp] - d[static_cast<size_t>(off)];
      const double dT = T[static_cast<size_t>(off)] - T[kp];
      if (rise > 0.0 && dT > 1.0) fx.thermal_expansion_per_K = std::min(rise / (1000.0 * p.L0 * dT), 1e-4);
    }
    const double r = model_rms(p, fx, t, v, d);
    if (r < best_rms) {
      best_rms = r;
      best.p = p;
      best.fx = fx;
    }
  }
  if (!std::isfinite(best_rms)) {
    best.notes.push_back("no h of the grid gave a physical start: kept the given start values");
    best.p = start;
    best.fx = fx0;
    return best;
  }
  // Eq 1 cannot tell the heating power's scale (see the top): a nominal band fixes it.
  if (std::isfinite(o.band_hint_C)) {
    const double Ta = best.fx.ambient_C(best.p.T_amb);
    const double mid = 0.5 * (best.p.T_AS + best.p.T_AF);
    const double k = (o.band_hint_C - Ta) / (mid - Ta);
    if (k > 0.05 && k < 20.0) {
      auto sc = [&](double& x) { x = Ta + k * (x - Ta); };
      sc(best.p.T_AS), sc(best.p.T_AF), sc(best.p.T_MS), sc(best.p.T_MF), sc(best.p.T_s), sc(best.p.T_f);
      sc(best.p.T_MSs), sc(best.p.T_MSf);
      for (uint8_t i = 0; i < best.p.n_loops; ++i) sc(best.p.loops[i].T_i), sc(best.p.loops[i].T_ii);
      const double T_MS_full = Ta + k * (best.p.q + best.p.e - Ta);
      best.p.q *= k;
      best.p.e = T_MS_full - best.p.q;
      best.p.R /= k;
      best.fx.thermal_expansion_per_K /= k;
      best.fx.latent_heat_J *= k;
      best.fx.convection_beta_per_K /= k;
      char buf[160];
      snprintf(buf, sizeof buf, "heating power scaled by %.3g (R %.3g ohm) to put the heating band's middle at %.1f degC",
               k, best.p.R, o.band_hint_C);
      best.notes.push_back(buf);
    }
  }
  best.rms_mm = model_rms(best.p, best.fx, t, v, d);
  char buf[300];
  snprintf(buf, sizeof buf,
           "start values from the log: h %.3g (tau %.2f s), T_AS %.1f, T_AF %.1f, T_MS %.1f, T_MF %.1f degC, "
           "g %.3g mm, offset %.3g mm, alpha %.3g /K: RMS %.3g mm",
           best.p.h, best.p.heat_capacity() / best.p.conductance(), best.p.T_AS, best.p.T_AF, best.p.q + best.p.e,
           best.p.T_MF, best.p.g, best.fx.sensor_offset_mm, best.fx.thermal_expansion_per_K, best.rms_mm);
  best.notes.push_back(buf);
  return best;
}

}  // namespace sma_host

#endif  // SMA_HOST_INITIAL_GUESS_HPP
