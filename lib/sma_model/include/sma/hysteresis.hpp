// Phase transformation with major and minor loops (eqs 2-11) and its inverse (eqs 15, 16).
//
// PhaseCurves<T> holds the constant shapes: the major heating curve, the minor-loop rules that
// fix a cooling branch at each reversal, and the inverse of both branches.
// Hysteresis<T> is the rate-independent state machine that walks them: it sees only the
// temperature path, never time. The plant, the model and the inverse (inverse.hpp) all use
// these two classes, so the hysteresis is written exactly once.
//
// Choices beyond the paper (see model.md and README "Model choices"):
//  - heating follows eps = max(eps, eps_h(T)): a heating that starts above the major curve
//    stays flat until it meets it;
//  - return-point memory (Params::reheat = return_point, the default): a heating that reverses
//    before it transformed anything (eps stayed flat) does not open a new loop: the cooling
//    resumes the branch it left, flat until the temperature falls back to where it left it.
//    Without this, small temperature ripples would each add a rise j_i and ratchet eps up to 1.
//    The other reading (Reheat::new_loop, host builds only): model.md's text taken literally,
//    every heating -> cooling reversal opens a loop at its peak, T_MSi from eq 10 with
//    eps_h(T_i) also after a re-heat that changed no fraction (eps_i is then the fraction held).
#ifndef SMA_HYSTERESIS_HPP
#define SMA_HYSTERESIS_HPP

#include "derived.hpp"
#include "params.hpp"
#include "scalar.hpp"

namespace sma {

// The cooling branch fixed at one reversal (eqs 5, 6, 11), with the reciprocals it needs
// precomputed so that evaluating it never divides.
template <class T>
struct CoolingLoop {
  T T_i;        // peak temperature of the loop
  T eps_i;      // fraction at the peak
  T T_ii;       // end of the rise (eq 5)
  T rise_rate;  // j_i / (T_i - T_ii): d(eps)/d(-T) during the rise (eq 6)
  T top;        // eps_i + j_i, clamped to 1: the flat level (eq 5, maintaining)
  T T_MSi;      // martensite start of this loop (eqs 7-10)
  T inv_cool;   // 1 / (T_MSi - T_MF), 0 when the interval is empty
  T inv_top;    // 1 / top, 0 when top is 0
};

template <class T>
class PhaseCurves {
 public:
  explicit PhaseCurves(const Params& p)
      : T_AS_(from_field<T>(p.T_AS)),
        T_MF_(from_field<T>(p.T_MF)),
        inv_width_sf_(reciprocal_as<T>(p.T_f - p.T_s)),
        T_MSf_(from_field<T>(p.T_MSf)),
        q_(from_field<T>(p.q)),
        e_(from_field<T>(p.e)),
        n_knots_(static_cast<uint8_t>(p.n_loops + 2)) {
    const double width_A = p.T_AF - p.T_AS;  // once for the width and its reciprocal
    width_A_ = from_double<T>(width_A);
    inv_width_A_ = reciprocal_as<T>(width_A);
#if SMA_REHEAT_READINGS
    every_peak_ = p.reheat == Reheat::new_loop;
#endif
    // Eq 8's coefficients times eq 7's T_MSs - T_MSf: a reversal adds the polynomial to T_MSf.
    for (uint8_t k = 0; k < 6; ++k) m_[k] = from_double<T>(p.m[k] * (p.T_MSs - p.T_MSf));
    // Knots of the piecewise-linear j(T_i) and span(T_i) = T_i - T_ii: zero at T_s and T_f.
    set_knot(0, p.T_s, 0.0, 0.0);
    for (uint8_t k = 0; k < p.n_loops; ++k)
      set_knot(static_cast<uint8_t>(k + 1), p.loops[k].T_i, p.loops[k].T_i - p.loops[k].T_ii,
               p.loops[k].j);
    set_knot(static_cast<uint8_t>(p.n_loops + 1), p.T_f, 0.0, 0.0);
  }

  // Eq 2: austenite fraction on the major heating curve.
  // (Out of line: one copy for the walker's heating, its reversals and eq 10, flash on the Uno.)
  __attribute__((noinline)) T eps_heat(T Tw) const { return cos_ramp((Tw - T_AS_) * inv_width_A_); }

  // Eq 15: the temperature on the major heating curve for a fraction eps (clamped to 0..1).
  T heat_temperature(T eps) const { return T_AS_ + width_A_ * cos_ramp_inv(eps); }

  // Eqs 7-10: martensite start of a loop that peaked at T_i, before clamping.
  T martensite_start(T T_i) const { return martensite_start(T_i, false, T(0)); }

  // The cooling branch that a reversal at (T_i, eps_i) starts. on_major: eps_i is the major
  // heating curve's fraction at T_i (a peak of a transforming heating), which eq 10 then uses
  // instead of evaluating the curve again.
  CoolingLoop<T> make_loop(T T_i, T eps_i, bool on_major = false) const {
    CoolingLoop<T> L = start_loop(T_i, eps_i, on_major);
    finish_loop(L);
    return L;
  }

  // make_loop in two parts, so that a reversal tick need not pay for all of it. start_loop
  // gives the loop's shape (T_i, eps_i, T_ii, top, T_MSi, inv_top: enough for eq 16,
  // cool_temperature and has_cooling_stage) and leaves its two rates pending: rise_rate holds
  // the rise's span T_i - T_ii and inv_cool the cooling width T_MSi - T_MF until finish_loop
  // divides (the same numbers make_loop gives, computed later).
  CoolingLoop<T> start_loop(T T_i, T eps_i, bool on_major) const {
    CoolingLoop<T> L;
    start_loop(T_i, eps_i, on_major, L);
    return L;
  }
  // The same into `L` (not read: T_i and eps_i are copies): Hysteresis builds its loop in place,
  // without a temporary loop on the stack and its copy (32 B of the deepest stack in Q16.16:
  // pcommit -> the controller's constructor -> Hysteresis::reset).
  void start_loop(T T_i, T eps_i, bool on_major, CoolingLoop<T>& L) const {
    L.T_i = T_i;
    L.eps_i = eps_i;
    T j, span;
    rise_at(T_i, j, span);
    L.top = min(eps_i + j, T(1));  // eps never exceeds 1
    // A span below 1 mK is a step: the rise happens at once (and 1/span would overflow).
    L.T_ii = span > T(0.001) ? T_i - span : T_i;
    L.rise_rate = span;  // pending
    // Clamp T_MSi to [T_MF, T_ii] (model.md): the flat stage cannot start above its own end.
    L.T_MSi = clamp(martensite_start(T_i, on_major, eps_i), T_MF_, L.T_ii);
    L.inv_cool = L.T_MSi - T_MF_;  // pending
    L.inv_top = L.top > T(0) ? T(1) / L.top : T(0);
  }
  // The rates of a loop from start_loop: j_i / (T_i - T_ii) (eq 6) and 1 / (T_MSi - T_MF) (eq 11).
  void finish_loop(CoolingLoop<T>& L) const {
    const T span = L.rise_rate, cool_width = L.inv_cool;
    // A span below 1 mK is a step: the rise happens at once (and 1/span would overflow).
    L.rise_rate = span > T(0.001) ? (L.top - L.eps_i) / span : T(0);
    L.inv_cool = cool_width > T(0.001) ? T(1) / cool_width : T(0);
  }
  // Eq 11 has a cooling stage to invert (its width is above 1 mK): pending or finished loop.
  bool has_cooling_stage(const CoolingLoop<T>& L) const { return L.T_MSi - T_MF_ > T(0.001); }

  // Eqs 5, 6, 11: the fraction on a loop's cooling branch at temperature Tw <= T_i.
  T eps_cool(const CoolingLoop<T>& L, T Tw) const {
    if (Tw >= L.T_i) return L.eps_i;
    if (Tw > L.T_ii) {
      if (L.rise_rate > T(0)) return L.eps_i + (L.T_i - Tw) * L.rise_rate;  // eqs 5-6, rise
      return L.top;
    }
    if (Tw >= L.T_MSi) return L.top;                                   // eq 5, maintaining
    if (Tw > T_MF_ && L.inv_cool > T(0))
      return L.top * cos_ramp((Tw - T_MF_) * L.inv_cool);              // eq 11
    return T(0);
  }

  // Eq 16: the temperature on a loop's cooling branch below its rise for a fraction eps.
  // eps >= top gives T_MSi (the flat stage, its coldest point: cooling must get there).
  T cool_temperature(const CoolingLoop<T>& L, T eps) const {
    if (!(eps < L.top)) return L.T_MSi;
    if (!(eps > T(0))) return T_MF_;
    return T_MF_ + (L.T_MSi - T_MF_) * cos_ramp_inv(eps * L.inv_top);
  }

  // Eqs 5-6 inverted: the temperature on a loop's rise (T_i down to T_ii) where the fraction
  // is eps (eps_i..top): cooling through the rise moves the wire UP, a controllable branch.
  // T_i at or below eps_i, T_ii at or above the top.
  T rise_temperature(const CoolingLoop<T>& L, T eps) const {
    if (!(L.rise_rate > T(0)) || !(eps > L.eps_i)) return L.T_i;
    if (!(eps < L.top)) return L.T_ii;
    return rise_temperature_inside(L, eps);
  }
  // The same for a fraction known to lie on the rise (eps_i <= eps < top of a finished loop
  // with a rise: its rate is above 0), without the tests.
  T rise_temperature_inside(const CoolingLoop<T>& L, T eps) const { return L.T_i - (eps - L.eps_i) / L.rise_rate; }

  T T_AS() const { return T_AS_; }
  // The major heating curve (eqs 2-4, 15) moved by dT along the temperature: a wire that is at
  // fraction eps_heat(T + dT) of these curves at T (the preview's learned curve shift).
  void shift_heating(T dT) { T_AS_ = T_AS_ - dT; }
  T T_AF() const { return T_AS_ + width_A_; }
  T T_MF() const { return T_MF_; }

  // Reheat::new_loop: a peak opens a loop even when the heating before it transformed nothing.
#if SMA_REHEAT_READINGS
  bool every_peak_opens_loop() const { return every_peak_; }
#else
  bool every_peak_opens_loop() const { return false; }
#endif

 private:
  // Eqs 7-10; eh_i: eps_heat(T_i) when known.
  T martensite_start(T T_i, bool known, T eh_i) const {
    if (T_i > knot_T_[0] && T_i < knot_T_[n_knots_ - 1]) {  // T_s < T_i < T_f
      const T nt = (T_i - knot_T_[0]) * inv_width_sf_;                                  // eq 9
      // Eqs 8 and 7: T_MSf + (T_MSs - T_MSf) n(nt), the difference folded into m_ (Horner's
      // rule as a loop: flash on the Uno; a reversal's loop is built between ticks).
      T n = m_[5];
      for (uint8_t k = 4; k > 0; --k) n = n * nt + m_[k];
      return T_MSf_ + n * nt + m_[0];
    }
    return q_ * (known ? eh_i : eps_heat(T_i)) + e_;  // eq 10
  }
  // Knot k, set in order from 0 (the constructor).
  void set_knot(uint8_t k, double Ti, double span, double j) {
    knot_T_[k] = from_double<T>(Ti);
    knot_span_[k] = from_double<T>(span);
    knot_j_[k] = from_double<T>(j);
    // 1 / width of the segment that ends here: a reversal interpolates without dividing. An
    // empty or reversed segment is never entered (rise_at), whatever its reciprocal.
    if (k > 0) knot_inv_width_[k - 1] = T(1) / (knot_T_[k] - knot_T_[k - 1]);
  }
  // j_i and T_i - T_ii between the identified loops: piecewise-linear in T_i, zero at and
  // outside T_s, T_f (model.md [choice]).
  void rise_at(T T_i, T& j, T& span) const {
    j = T(0);
    span = T(0);
    for (uint8_t k = 0; k + 1 < n_knots_; ++k) {
      if (T_i >= knot_T_[k] && T_i < knot_T_[k + 1]) {
        const T w = (T_i - knot_T_[k]) * knot_inv_width_[k];
        j = knot_j_[k] + w * (knot_j_[k + 1] - knot_j_[k]);
        span = knot_span_[k] + w * (knot_span_[k + 1] - knot_span_[k]);
        return;
      }
    }
  }

  T T_AS_, T_MF_, width_A_, inv_width_A_;
  T inv_width_sf_, T_MSf_;  // T_s, T_f: the first and last knot
  T m_[6];                  // eq 8's m_k (T_MSs - T_MSf)
  T q_, e_;
  uint8_t n_knots_;
#if SMA_REHEAT_READINGS
  bool every_peak_ = false;
#endif
  T knot_T_[kMaxLoopKnots + 2];
  T knot_span_[kMaxLoopKnots + 2];
  T knot_j_[kMaxLoopKnots + 2];
  T knot_inv_width_[kMaxLoopKnots + 1];
};

// The rate-independent state machine over the temperature path.
template <class T>
class Hysteresis {
 public:
  // Starts at rest at T0 with fraction eps0 (0: fully martensite at ambient).
  explicit Hysteresis(const PhaseCurves<T>& curves, T T0 = T(22), T eps0 = T(0))
      : curves_(&curves) {
    reset(T0, eps0);
  }

  // (Out of line: the controller's constructor and mode change both reset.)
  __attribute__((noinline)) void reset(T T0, T eps0 = T(0)) {
    eps_ = clamp01(eps0);
    T_last_ = T0;
    heating_ = false;
    transformed_ = false;
    on_branch_ = true;
    start_loop(T0, false);
    peak_ready_ = false;
    T_left_ = T0;
  }

  // Advance along the temperature path to Tw; returns the new fraction. NaN is ignored.
  T update(T Tw) { return advance(Tw, false, T(0)); }

  // The same, for a caller that already knows the fraction the branch it walks gives at Tw:
  // eps_heat(Tw) on a heating, eps_cool(loop_for_cooling(), Tw) on a cooling (the inverse model
  // computed Tw from that very fraction, eqs 15, 16): the curve is not evaluated a second time.
  T update(T Tw, T eps_on_branch) { return advance(Tw, true, eps_on_branch); }

  // The loop a cooling that starts now would follow (what update() will build on the next
  // lower temperature). The inverse model needs it to invert the branch before walking it.
  CoolingLoop<T> loop_for_cooling() const {
    if (heating_ && opens_loop() && !peak_ready_) return curves_->make_loop(T_last_, eps_, transformed_);
    return loop();
  }

  // The same loop, built once: the next update() that cools uses it instead of building it
  // again (a reversal tick would otherwise build the loop twice). Only a transformed heating
  // replaces loop_ here (any heating with Reheat::new_loop), and such a heating replaces it at
  // its peak anyway.
  const CoolingLoop<T>& prepare_cooling() {
    prepare_cooling_shape();
    return loop();
  }

  // The same, but the loop's rates may still be pending (PhaseCurves::start_loop): enough for
  // eq 16 and has_cooling_stage. The inverse model inverts the branch with it on a reversal tick
  // and the two divisions of the rates wait until the memory or loop() needs them: the
  // reversal, the controller's most expensive tick, does not pay for them.
  // (Out of line: the inverse's tick and the between-ticks preparation share one copy.)
  __attribute__((noinline)) const CoolingLoop<T>& prepare_cooling_shape() {
    if (heating_ && opens_loop() && !peak_ready_) {
      start_loop(T_last_, transformed_);
      peak_ready_ = true;
    }
    return loop_;
  }

  T eps() const { return eps_; }
  T temperature() const { return T_last_; }
  bool heating() const { return heating_; }
  const CoolingLoop<T>& loop() const {
    finish_loop();
    return loop_;
  }
  const PhaseCurves<T>& curves() const { return *curves_; }

 private:
  T advance(T Tw, bool known, T eps_known) {
    if (!is_finite(Tw)) return eps_;
    if (Tw > T_last_) {
      if (!heating_) {  // valley: leave the cooling branch, remember where
        heating_ = true;
        transformed_ = false;
        if (on_branch_) T_left_ = T_last_;
        on_branch_ = false;
      }
      const T eh = known ? eps_known : curves_->eps_heat(Tw);  // eq 4: along the major curve
      if (eh > eps_) {
        eps_ = eh;
        transformed_ = true;
      }
    } else if (Tw < T_last_) {
      if (heating_) {  // peak
        heating_ = false;
        if (opens_loop()) {  // a new minor loop (eqs 5-11)
          if (!peak_ready_) start_loop(T_last_, transformed_);
          on_branch_ = true;
        }  // else: return-point memory, resume the old branch below T_left_
      }
      if (!on_branch_ && Tw <= T_left_) on_branch_ = true;
      if (on_branch_) eps_ = known ? eps_known : curves_->eps_cool(loop(), Tw);
    } else {
      return eps_;  // no move: a loop prepared for this point stays valid
    }
    T_last_ = Tw;
    peak_ready_ = false;
    return eps_;
  }

  // loop_ := the loop a cooling from (T_i, eps_) starts, its rates pending until used.
  // (Out of line: one copy for reset(), prepare_cooling_shape() and advance().)
  __attribute__((noinline)) void start_loop(T T_i, bool on_major) {
    curves_->start_loop(T_i, eps_, on_major, loop_);
    loop_pending_ = true;
  }
  // Completes a pending loop_ (a cache: logically const). Out of line: one copy of its two
  // divisions however many callers read the loop (flash on the Uno).
  __attribute__((noinline)) void finish_loop() const {
    if (loop_pending_) {
      curves_->finish_loop(loop_);
      loop_pending_ = false;
    }
  }

  // Does a reversal now open a new loop? After a transforming heating always; after any
  // heating with Reheat::new_loop.
  bool opens_loop() const { return transformed_ || curves_->every_peak_opens_loop(); }

  const PhaseCurves<T>* curves_;
  T eps_;
  T T_last_;
  bool heating_;      // the last move of the temperature was up
  bool transformed_;  // this heating has moved eps along the major curve
  bool on_branch_;    // cooling follows loop_ (else flat, waiting to fall to T_left_)
  bool peak_ready_;   // loop_ already is the loop of a cooling from (T_last_, eps_)
  mutable CoolingLoop<T> loop_;
  T T_left_;          // where the path left loop_'s branch
  mutable bool loop_pending_;  // loop_'s rates not divided yet (prepare_cooling_shape)
};

}  // namespace sma

#endif  // SMA_HYSTERESIS_HPP
