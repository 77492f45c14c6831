// Eigen's Levenberg-Marquardt with a progress line per iteration (progress.hpp).
#ifndef SMA_HOST_LM_PROGRESS_HPP
#define SMA_HOST_LM_PROGRESS_HPP

#include <unsupported/Eigen/NonLinearOptimization>

#include <string>

#include "sma_host/progress.hpp"

namespace sma_host {

// Eigen's Levenberg-Marquardt (unsupported/NonLinearOptimization) minimised step by step, with
// a progress line per iteration: residual evaluations out of the budget `maxfev` (the LM stops
// there at the latest, so the time left is an upper bound). The same result as lm.minimize(x).
template <class LM, class X>
int minimize_reporting(LM& lm, X& x, const char* what) {
  ProgressLine line(std::string(what) + " (residual evaluations, of the budget)",
                    static_cast<double>(lm.parameters.maxfev));
  int status = static_cast<int>(lm.minimizeInit(x));
  if (status == static_cast<int>(Eigen::LevenbergMarquardtSpace::ImproperInputParameters)) return status;
  do {
    status = static_cast<int>(lm.minimizeOneStep(x));
    line(static_cast<double>(lm.nfev));
  } while (status == static_cast<int>(Eigen::LevenbergMarquardtSpace::Running));
  return status;
}

}  // namespace sma_host

#endif  // SMA_HOST_LM_PROGRESS_HPP
