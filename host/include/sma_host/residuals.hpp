// Where a residual (measured - model) lives: by regime, in time, against the input.
//  - regimes: heating / cooling / steady (the model's dT/dt above +0.05, below -0.05 K/s, or
//    between), inside / outside the transformation band (0.02 < eps < 0.98);
//  - autocorrelation: white noise dies after lag 0; a missing effect leaves seconds of memory;
//  - cross-correlation with the voltage: a sensor delay or lag peaks at a positive lag,
//    thermal effects correlate with the input's level.
#ifndef SMA_HOST_RESIDUALS_HPP
#define SMA_HOST_RESIDUALS_HPP

#include <math.h>
#include <string>
#include <vector>
#include "discrepancy.hpp"

namespace sma_host {

struct RegimeRms {
  std::string regime;
  double rms_mm;
  double share;  // fraction of the samples
};

inline std::vector<RegimeRms> residual_by_regime(const RigLog& log, const Trace& model) {
  const char* names[] = {"heating", "cooling", "steady", "in band", "out of band"};
  double sum[5] = {0}, n[5] = {0};
  for (size_t k = 0; k < log.size(); ++k) {
    const size_t a = k > 0 ? k - 1 : 0, b = k + 1 < log.size() ? k + 1 : k;
    const double span = log.t[b] - log.t[a];
    const double rate = span > 0 ? (model.T[b] - model.T[a]) / span : 0;
    const double r = log.d[k] - model.d[k];
    const int dyn = rate > 0.05 ? 0 : rate < -0.05 ? 1 : 2;
    const int band = (model.eps[k] > 0.02 && model.eps[k] < 0.98) ? 3 : 4;
    for (int i : {dyn, band}) {
      sum[i] += r * r;
      n[i] += 1;
    }
  }
  std::vector<RegimeRms> out;
  for (int i = 0; i < 5; ++i)
    out.push_back({names[i], n[i] > 0 ? sqrt(sum[i] / n[i]) : 0.0, log.size() ? n[i] / static_cast<double>(log.size()) : 0});
  return out;
}

// Normalised correlation of x with y shifted by each lag (in samples): c[l] = corr(x[k], y[k - l]).
inline std::vector<double> cross_correlation(const std::vector<double>& x, const std::vector<double>& y, int max_lag,
                                             int min_lag = 0) {
  const size_t n = x.size();
  double mx = 0, my = 0;
  for (size_t k = 0; k < n; ++k) {
    mx += x[k];
    my += y[k];
  }
  mx /= static_cast<double>(n ? n : 1);
  my /= static_cast<double>(n ? n : 1);
  double sx = 0, sy = 0;
  for (size_t k = 0; k < n; ++k) {
    sx += (x[k] - mx) * (x[k] - mx);
    sy += (y[k] - my) * (y[k] - my);
  }
  std::vector<double> c;
  for (int l = min_lag; l <= max_lag; ++l) {
    double s = 0;
    for (size_t k = 0; k < n; ++k) {
      const long j = static_cast<long>(k) - l;
      if (j >= 0 && j < static_cast<long>(n)) s += (x[k] - mx) * (y[static_cast<size_t>(j)] - my);
    }
    c.push_back(sx > 0 && sy > 0 ? s / sqrt(sx * sy) : 0.0);
  }
  return c;
}

}  // namespace sma_host

#endif  // SMA_HOST_RESIDUALS_HPP
