// Temperature walks for the phase-transformation tests: from one temperature to another in
// small steps (the last one lands exactly on the target), with a look at every step.
#pragma once
#include <gtest/gtest.h>
#include <math.h>

namespace temperature_walk {

// Calls at(T, rising) at every step from `from` to `to`; stops early on a fatal test failure
// (an ASSERT inside `at` returns from `at` only). Returns where it stopped.
template <class T, class F>
T steps(T from, T to, T step, F at) {
  T x = from;
  const T s = to > x ? step : -step;
  while ((to - x) * s > 0 && !::testing::Test::HasFatalFailure()) {
    x = fabs(to - x) < step ? to : x + s;
    at(x, s > 0);
  }
  return x;
}

// Walks a loop memory (Hysteresis) from its present temperature to `to`, in its own scalar.
template <class H>
void walk(H& h, double to, double step = 0.05) {
  using T = decltype(h.temperature());
  steps(h.temperature(), static_cast<T>(to), static_cast<T>(step), [&](T x, bool) { h.update(x); });
}

}  // namespace temperature_walk
