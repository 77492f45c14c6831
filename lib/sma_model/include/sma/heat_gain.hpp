// The wire's heat loss against the model's: a gain k on the convection conductance G of eq 1
// (G = pi d0 L0 h: k = h_wire / h_model), estimated apart from a shift of the phase curves'
// temperatures.
//
// The wire: C dT/dt = V^2 / R - k G (T - T_a). The model wire runs the same with the current
// estimate k^; to first order the wire's temperature is then T_model + (k - k^) S, with
// S = dT/dk along the model wire's path:
//
//     C dS/dt = -G (T_model - T_a) - k^ G S        (S ~ -(T - T_a) / k at steady state)
//
// The wire's temperature is seen through the position: while both wires transform on the
// heating curve (eq 4: no loop memory involved) the gap (measured - model position) / slope is
// T_wire - T_model. A shift delta of the curves' temperatures adds a constant to that gap, a
// heat-loss error a part proportional to S, so
//
//     z = gap + k^ S = k S + delta
//
// is a straight line in S: its slope is the heat-loss gain, its intercept the curves' shift.
// They separate when the data span several temperatures (a single temperature cannot tell them
// apart, and then the estimate is not moved). Weighted least squares with exponential
// forgetting; the weight is the square of the branch slope (a flat curve says little about the
// temperature). The caller applies k^ to the model wire: eq 1's loss term k^ G (T - T_a) in its
// temperature step and in eq 17 (loss_correction()).
//
// Header-only, no STL; float and double (it compiles for sma::Fixed, but its means move by ~1e-6
// a sample: Q16.16 rounds them away, so the preview leaves it off there).
#ifndef SMA_HEAT_GAIN_HPP
#define SMA_HEAT_GAIN_HPP

#include "params.hpp"
#include "scalar.hpp"

namespace sma {

// One step of a first-order low-pass: m + a (x - m). (Out of line: one copy for the observer's
// means and the preview's filters, flash on the Uno.)
template <class T>
__attribute__((noinline)) T low_pass(T m, T a, T x) {
  return m + a * (x - m);
}

template <class T>
class HeatLossObserver {
 public:
  // dt_s: the tick (tick()); sample_s: time between add() samples; memory_s: the regression's
  // forgetting time; adapt_s: time constant of the gain's move to the regression's slope;
  // dead_zone: |k - 1| below it reads as 1; k_lo..k_hi: the plausible range.
  HeatLossObserver(const Params& p, double dt_s, double sample_s, double memory_s, double adapt_s,
                   double dead_zone, double k_lo = 0.75, double k_hi = 1.33)
      : c_(from_double<T>(dt_s * p.conductance() / p.heat_capacity())),
        a_(from_double<T>(1.0 - decay_factor(sample_s / memory_s))),
        b_(from_double<T>(1.0 - decay_factor(sample_s / adapt_s))),
        k_lo_(from_double<T>(k_lo)),
        k_hi_(from_double<T>(k_hi)),
        dead_(from_double<T>(dead_zone)) {
    reset();
  }

  void reset() {
    mw_ = mws_ = mwss_ = mwz_ = mwsz_ = S_ = T(0);
    k_ = T(1);
    kc_ = T(0);
  }

  // One tick of the sensitivity S, from the model wire's temperature rise T_model - T_a (K).
  void tick(T rise) { S_ = S_ - c_ * (k_ * S_ + rise); }

  // One sample while both wires transform on the heating curve: gap = T_wire - T_model seen
  // through the position (K), slope = the curve's position per kelvin (mm/K).
  void add(T gap, T slope) {
    const T w = slope * slope;
    const T z = gap + k_ * S_;
    const T ws = w * S_;
    mw_ = low_pass(mw_, a_, w);
    mws_ = low_pass(mws_, a_, ws);
    mwss_ = low_pass(mwss_, a_, ws * S_);
    mwz_ = low_pass(mwz_, a_, w * z);
    mwsz_ = low_pass(mwsz_, a_, ws * z);
    // The slope of z over S (ridge regression), pulled towards k = 1 by a prior worth a spread
    // of S of 1 K: data that span few temperatures cannot tell the slope from the intercept (the
    // first transient from ambient spans only a few kelvin).
    const T var = mw_ * mwss_ - mws_ * mws_;  // mw^2 x the weighted variance of S, K^2
    const T prior = mw_ * mw_;                 // mw^2 x (1 K)^2
    if (!(var + prior > T(0))) return;
    T k_ls = clamp((mw_ * mwsz_ - mws_ * mwz_ + prior) / (var + prior), k_lo_, k_hi_);
    if (!is_finite(k_ls)) return;
    // Within the dead zone the model's own h is kept: the slope's bias from the loop's transients
    // is a few per cent, and the preview is as sensitive to a wrong gain as to a wrong h.
    if (abs(k_ls - T(1)) < dead_) k_ls = T(1);
    k_ = low_pass(k_, b_, k_ls);
    kc_ = (k_ - T(1)) * c_;
  }

  T gain() const { return k_; }
  T sensitivity() const { return S_; }  // dT/dk along the model wire's path, K
  // (k^ - 1) G dt / C: the model wire's extra loss per tick and kelvin above ambient.
  T loss_correction() const { return kc_; }

 private:
  T c_;  // G dt / C
  T a_, b_, k_lo_, k_hi_, dead_;
  T mw_, mws_, mwss_, mwz_, mwsz_;  // weighted means: w, w S, w S^2, w z, w S z
  T S_;                             // dT/dk along the model wire's path, K
  T k_, kc_;
};

}  // namespace sma

#endif  // SMA_HEAT_GAIN_HPP
