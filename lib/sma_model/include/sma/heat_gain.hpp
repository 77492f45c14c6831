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
// A latent heat the model lacks (eq 1's - L deps/dt) opens a gap of its own while the wires
// transform, and it grows with the transformation as a heat-loss error's does: read as k, it
// puts a gain the wire does not have into the model wire. So the gap has a third term,
// (L - L^) SL with SL = dT/dL along the model wire's path,
//
//     C dSL/dt = -k^ G SL - deps/dt,     z = k S + (L - L^) SL + delta,
//
// and z is regressed on S and SL together (latent_spread > 0), with L - L^ >= -L^ (a wire has
// no negative latent heat). L - L^ only keeps k clean; the model wire does not use it (a fit's
// curves whose span is not the wire's open a gap along the transformation as well).
//
// The regression's sums: in float and double the weighted means of w, w S, w S^2, w z, w S z
// (RawMoments). Q16.16 cannot hold those: the weights are ~1e-4..2.5e-3 (mm/K)^2 and the means
// move by ~1e-6 a sample, below its LSB (1.5e-5), and the products mw mwss, mws^2 cancel to a
// few K^2 out of ~1600 x the means' rounding. It keeps the same estimate in the centred form
// (CentredMoments): the weighted means of S and z and their weighted variance and covariance,
// updated in place (the weights' scale cancels in the slope, so they are normalised there).
//
// Header-only, no STL; float, double and sma::Fixed.
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

// k of the 2x2 system below (RawMoments; Cramer's rule), with the latent heat's coefficient l
// not below l_min (a wire has no negative latent heat: l_min = -the model's): where the free
// solution's l is below it, l is held there and k is the slope of z - l_min SL over S. False
// when the system is singular.
template <class T>
bool solve_gain(T vs, T vl, T csl, T csz, T clz, T l_min, T& k, T& l) {
  const T den = vs * vl - csl * csl;
  if (!(den > T(0))) return false;
  if (vs * clz - csl * csz < l_min * den) {
    k = (csz - l_min * csl) / vs;
    l = l_min;
  } else {
    k = (csz * vl - csl * clz) / den;
    l = (vs * clz - csl * csz) / den;
  }
  return true;
}

// The least-squares slope of z over S with weights w and exponential forgetting a a sample,
// beside a second regressor SL (the latent heat's sensitivity, HeatLossObserver), with ridge
// priors: a spread of S of 1 K towards slope 1, a spread of SL of sigma_L towards no latent
// heat (HeatLossObserver::add). In the weighted (co)variances:
//
//     [ var(S) + 1    cov(S, SL)         ] [ k ]   [ cov(S, z) + 1 ]
//     [ cov(S, SL)    var(SL) + sigma_L^2] [ l ] = [ cov(SL, z)    ]
//
// solved for k (Cramer). add() takes a sample and gives k; false while there is no estimate.
template <class T>
struct RawMoments {
  static constexpr bool kLatent = true;  // takes the latent heat's regressor
  T mw, mws, mwss, mwz, mwsz;  // weighted means: w, w S, w S^2, w z, w S z
  T mwl, mwll, mwsl, mwlz;     // and w SL, w SL^2, w S SL, w SL z

  void reset() { mw = mws = mwss = mwz = mwsz = mwl = mwll = mwsl = mwlz = T(0); }

  // w = slope^2 (mm/K)^2. With everything multiplied by mw^2: no division but the last.
  bool add(T slope, T S, T SL, T z, T a, T prior_L, T l_min, T& k, T& l) {
    const T w = slope * slope;
    const T ws = w * S, wl = w * SL;
    mw = low_pass(mw, a, w);
    mws = low_pass(mws, a, ws);
    mwss = low_pass(mwss, a, ws * S);
    mwz = low_pass(mwz, a, w * z);
    mwsz = low_pass(mwsz, a, ws * z);
    mwl = low_pass(mwl, a, wl);
    mwll = low_pass(mwll, a, wl * SL);
    mwsl = low_pass(mwsl, a, ws * SL);
    mwlz = low_pass(mwlz, a, wl * z);
    const T prior = mw * mw;  // mw^2 x (1 K)^2
    const T vs = mw * mwss - mws * mws + prior;  // mw^2 x (the weighted variance of S + 1 K^2)
    const T vl = mw * mwll - mwl * mwl + prior * prior_L;
    const T csl = mw * mwsl - mws * mwl;
    const T csz = mw * mwsz - mws * mwz + prior;
    const T clz = mw * mwlz - mwl * mwz;
    return solve_gain(vs, vl, csl, csz, clz, l_min, k, l);
  }
};

// The same estimate for a scalar with an absolute resolution (Q16.16): every quantity ~1..1000
// of its LSB or more. The weight is normalised by a reference slope of 1/32 mm/K (w ~ 0.03..2.6
// over the slopes the preview takes, 5..50 um/K); n = sum of w with forgetting (mw / a: ~w / a,
// ~600 at 60 s of memory), so the new sample's share f = w / n is exactly 1 for the first sample
// and ~a after (~110 LSB at 0.1 s / 60 s). Mean and (co)variance updated with it (West 1979):
//
//     m' = m + f (x - m),   C' = (1 - f) (C + f dS dz)   (dS, dz: the sample minus the old means)
//
// which is, in exact arithmetic, RawMoments' ratios (var = mw^2 var_w). Their rounding: a mean
// stops moving within 0.5 LSB / f ~ 0.005 K of its sample, the variance within ~0.01 K^2 of its
// target (< 1 % of the 1 K^2 prior); the gain stays within ~0.3 % of double's
// (test_preview_heat_loss.cpp).
template <class T>
struct CentredMoments {
  static constexpr bool kLatent = false;  // z over S alone (SL, its prior and l_min unused)
  T n, mS, mz, vS, cSz;  // sum of weights, weighted means of S and z (K), var(S), cov(S, z) (K^2)

  void reset() { n = mS = mz = vS = cSz = T(0); }

  bool add(T slope, T S, T /*SL*/, T z, T a, T /*prior_L*/, T /*l_min*/, T& k, T& l) {
    l = T(0);
    const T u = slope * T(32);
    const T w = u * u;
    n = n + w - a * n;
    if (!(n > T(0))) return false;
    const T f = w / n;
    const T dS = S - mS, dz = z - mz;
    const T fdS = f * dS;
    mS = mS + fdS;
    mz = mz + f * dz;
    const T keep = T(1) - f;
    vS = keep * (vS + fdS * dS);
    cSz = keep * (cSz + fdS * dz);
    k = (cSz + T(1)) / (vS + T(1));
    return true;
  }
};

class Fixed;  // fixed.hpp
// The regression's form for scalar T: raw means unless T's resolution is absolute.
template <class T> struct MomentsFor { typedef RawMoments<T> type; };
template <> struct MomentsFor<Fixed> { typedef CentredMoments<Fixed> type; };

template <class T>
class HeatLossObserver {
 public:
  // dt_s: the tick (tick()); sample_s: time between add() samples; memory_s: the regression's
  // forgetting time; adapt_s: time constant of the gain's move to the regression's slope;
  // dead_zone: |k - 1| below it reads as 1; latent_spread: the latent heat's regressor's prior,
  // a spread of SL (K/J; 0: no such regressor); model_latent_J: the model's latent heat; k_lo..k_hi:
  // the plausible range. (Always inlined: out of line, avr-gcc 5.4 makes the Q16.16 one 320 B more
  // flash.)
  __attribute__((always_inline)) HeatLossObserver(const Params& p, double dt_s, double sample_s, double memory_s,
                                                  double adapt_s, double dead_zone, double latent_spread = 0.0,
                                                  double model_latent_J = 0.0, double k_lo = 0.75,
                                                  double k_hi = 1.33)
      : c_(from_double<T>(dt_s * p.conductance() / p.heat_capacity())),
        e_(from_double<T>(dt_s / p.heat_capacity())),
        a_(from_double<T>(1.0 - decay_factor(sample_s / memory_s))),
        b_(from_double<T>(1.0 - decay_factor(sample_s / adapt_s))),
        k_lo_(from_double<T>(k_lo)),
        k_hi_(from_double<T>(k_hi)),
        dead_(from_double<T>(dead_zone)),
        l_min_(from_double<T>(-model_latent_J)),
        prior_L_(from_double<T>(latent_spread > 0.0 ? latent_spread * latent_spread : 1.0)),
        latent_(latent_spread > 0.0 && MomentsFor<T>::type::kLatent) {
    reset();
  }

  void reset() {
    m_.reset();
    S_ = T(0);
    SL_ = T(0);
    k_ = T(1);
    kc_ = T(0);
  }

  // One tick of the sensitivities S and SL, from the model wire's temperature rise T_model - T_a
  // (K) and the rate of its fraction (1/s). (Without the latent regressor SL stays 0, and the
  // regression is z over S alone.)
  void tick(T rise, T deps_dt = T(0)) {
    S_ = S_ - c_ * (k_ * S_ + rise);
    if (latent_) SL_ = SL_ - c_ * k_ * SL_ - e_ * deps_dt;
  }

  // One sample while both wires transform on the heating curve: gap = T_wire - T_model seen
  // through the position (K), slope = the curve's position per kelvin (mm/K). (Always inlined
  // into the preview's one call: a frame of its own is ~50 B of stack, which the 328P cycle
  // harness, the controller on its stack, does not have.)
  __attribute__((always_inline)) void add(T gap, T slope) {
    const T z = gap + k_ * S_;
    // The slope of z over S (ridge regression, weight slope^2), pulled towards k = 1 by a prior
    // worth a spread of S of 1 K: data that span few temperatures cannot tell the slope from the
    // intercept (the first transient from ambient spans only a few kelvin).
    T k_ls, l_ls;  // l_ls: the latent heat beyond the model's, which only keeps k clean
    if (!m_.add(slope, S_, SL_, z, a_, prior_L_, l_min_, k_ls, l_ls)) return;
    k_ls = clamp(k_ls, k_lo_, k_hi_);
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
  T e_;  // dt / C
  T a_, b_, k_lo_, k_hi_, dead_;
  T l_min_;    // -the model's latent heat, J: the wire's latent heat is not negative
  T prior_L_;  // the latent regressor's prior, (K/J)^2
  bool latent_;
  typename MomentsFor<T>::type m_;  // the regression's sums
  T S_;                             // dT/dk along the model wire's path, K
  T SL_;                            // dT/dL along it, K/J
  T k_, kc_;
};

}  // namespace sma

#endif  // SMA_HEAT_GAIN_HPP
