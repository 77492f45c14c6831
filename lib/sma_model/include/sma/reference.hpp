// Reference generators for the paper's two tests and for user trajectories.
//  - multi-step (Fig. 9-11): 0.2 -> 0.4 -> 0.6 -> 0.8 -> 0.5 -> 0.3 mm, 25 s per step;
//  - sine (Fig. 12-13): between 0.2 and 0.7 mm, period 50 s, starting at the bottom so that
//    the reference has no jump at t = 0;
//  - trajectory: user points (t, mm), linear between them, held after the last.
// All are configurable; times are seconds from the start of the run.
#ifndef SMA_REFERENCE_HPP
#define SMA_REFERENCE_HPP

#include <stdint.h>
#include "scalar.hpp"
#include "trunc_u32.hpp"

namespace sma {

constexpr uint8_t kMaxSteps = 8;
constexpr uint8_t kMaxPoints = 16;

enum class RefKind : uint8_t { Constant, MultiStep, Sine, Trajectory };

// A reference's kind and the settings of the paper's tests (no trajectory points): the part
// with non-zero defaults (the board copies it from flash, the points it only zeroes).
struct RefShape {
  RefKind kind = RefKind::Constant;
  double constant_mm = 0.0;
  // Multi-step.
  double step_mm[kMaxSteps] = {0.2, 0.4, 0.6, 0.8, 0.5, 0.3};
  uint8_t n_steps = 6;
  double step_s = 25.0;
  // Sine.
  double sine_lo_mm = 0.2, sine_hi_mm = 0.7, sine_period_s = 50.0;
  double sine_cycles = 3.0;  // length of the run, in periods
};

struct Reference : RefShape {
  // Trajectory (all zero by default). (The count before the points: on the AVR a load reaches
  // 63 bytes past the reference's address.)
  uint8_t n_points = 0;
  double point_t[kMaxPoints] = {};
  double point_mm[kMaxPoints] = {};

  static Reference multi_step() {
    Reference r;
    r.kind = RefKind::MultiStep;
    return r;
  }
  static Reference sine() {
    Reference r;
    r.kind = RefKind::Sine;
    return r;
  }
  static Reference constant(double mm) {
    Reference r;
    r.kind = RefKind::Constant;
    r.constant_mm = mm;
    return r;
  }

  // Length of the run, s (constant references never end: 0).
  double duration() const {
    switch (kind) {
      case RefKind::MultiStep: return n_steps * step_s;
      case RefKind::Sine: return sine_cycles * sine_period_s;
      case RefKind::Trajectory: return n_points ? point_t[n_points - 1] : 0.0;
      default: return 0.0;
    }
  }

  // Appends a trajectory point; false (and nothing changes) if full, time not increasing, or the
  // position below the stroke (the known future's compares take positions >= 0: Lookahead).
  // (The sign on the bits: no soft-float compare on the AVR, where double is float.)
  bool add_point(double t, double mm) {
    if (n_points >= kMaxPoints || !is_finite(t) || !is_finite(mm) || negative(static_cast<float>(mm))) return false;
    if (n_points > 0 && !(t > point_t[n_points - 1])) return false;
    point_t[n_points] = t;
    point_mm[n_points] = mm;
    ++n_points;
    return true;
  }
};

// The known future the inverse model reads (LeadConfig, ReferenceGen::lookahead):
// `ahead`, the reference lead_s ahead (the inverse reads it where it is below the present one), and
// `peak`, the highest reference of the next peak_window_s; `now`, the present reference (a board
// computes the next tick's between ticks: the control section does not evaluate it).
template <class T>
struct Lookahead {
  T ahead, peak, now;
};
constexpr uint8_t kLookaheadSamples = 8;  // the window's samples (ReferenceGen::lookahead)

// Evaluates a Reference in the scalar type T; parameters are converted once.
template <class T>
class ReferenceGen {
 public:
  // `dt`: the tick of at_tick() (0: at() only).
  explicit ReferenceGen(const Reference& r, double dt = 0.0) : r_(r) {
    lo_ = from_double<T>(r.sine_lo_mm);
    span_ = from_double<T>(r.sine_hi_mm - r.sine_lo_mm);
    inv_step_s_ = 1.0 / r.step_s;
    inv_period_s_ = 1.0 / r.sine_period_s;
    // The sine's phase advance per tick in Q0.32 turns, rounded: the phase error after k ticks
    // is below k / 2^33 turn (3 periods of the paper's sine: 2e-6 turn).
    // (A period shorter than the tick, or none, gives no tick path: 0.)
    const double turns = dt * inv_period_s_;
    turns_per_tick_ = turns < 1.0 ? trunc_u32(turns * 4294967296.0 + 0.5) : 0u;
  }

  // Reference at tick k of the run (t = k dt): the sine's phase from the tick count in integers
  // (Q0.32 turns, wrapping once per period), no time in T or float; the other kinds at(k dt).
  T at_tick(uint32_t k, double dt) const {
    if (r_.kind == RefKind::Sine) return sine_at(k * turns_per_tick_);
    return at_other(static_cast<double>(k) * dt);
  }

  // The known future at tick k: the reference lead_ticks ahead, and the
  // peak over kLookaheadSamples points sample_ticks apart (the window; the paper's sine peak
  // lies within 0.2 % of its span of the highest sample of a 10 s window; a step is seen at most
  // a sample late).
  // `future` false: `now` only (ahead and peak the present).
  // (One evaluation in the loop, flash on the Uno. Where T is a class, Q16.16, through sample(),
  // out of line: the loop's live values and the evaluation's 4-byte scalars no longer compete
  // for registers, -18 B of the Q16.16 image. A built-in float inlines at_tick: the Mega image's
  // preview planning, which shares this code's layout, has ~1.9 k of its 160 k cycles left at its
  // worst tick, and the shifted layout of the out-of-line form cost it one tick; docs/control.md
  // section 36.)
  Lookahead<T> lookahead(uint32_t k, uint32_t lead_ticks, uint32_t sample_ticks, double dt, bool future = true) const {
    Lookahead<T> f;
    uint32_t at = k;
    for (uint8_t i = 0;; ++i) {
      const T r = __is_class(T) ? sample(at, dt) : at_tick(at, dt);
      if (i == 0) {  // now
        f.now = f.ahead = f.peak = r;
        if (!future) break;
        at += lead_ticks;
        continue;
      }
      if (i == 1) {  // lead_ticks ahead
        f.ahead = r;
        at = k;
      } else {  // the window's samples
        if (above(r, f.peak)) f.peak = r;  // (positions on the stroke, >= 0)
        if (i == kLookaheadSamples + 1) break;
      }
      at += sample_ticks;
    }
    return f;
  }

  // at_tick, out of line (the lookahead's evaluation in Q16.16).
  __attribute__((noinline)) T sample(uint32_t k, double dt) const { return at_tick(k, dt); }

  // Reference at t seconds (t >= 0).
  T at(double t) const {
    if (r_.kind == RefKind::Sine) {
      // Phase reduced to [0, 1) in double (float on AVR) so T never sees a large angle.
      const double cycles = t * inv_period_s_;
      return sine_at(trunc_u32((cycles - static_cast<double>(trunc_u32(cycles))) * 4294967296.0));
    }
    return at_other(t);
  }

  const Reference& config() const { return r_; }

 private:
  // Every kind but the sine at t seconds (at_tick has the sine's own path: the sine's case out
  // of at_tick's code, where the Q16.16 image's build cannot prove it dead, -22 B there).
  T at_other(double t) const {
    switch (r_.kind) {
      case RefKind::MultiStep: {
        long k = static_cast<long>(trunc_u32(t * inv_step_s_));  // (t >= 0)
        if (k < 0) k = 0;
        if (k >= r_.n_steps) k = r_.n_steps - 1;
        return from_double<T>(r_.step_mm[k]);
      }
      case RefKind::Trajectory: {
        if (r_.n_points == 0) return T(0);
        if (t <= r_.point_t[0]) return from_double<T>(r_.point_mm[0]);
        for (uint8_t k = 1; k < r_.n_points; ++k) {
          if (t < r_.point_t[k]) {
            const double w = (t - r_.point_t[k - 1]) / (r_.point_t[k] - r_.point_t[k - 1]);
            return from_double<T>(r_.point_mm[k - 1] + w * (r_.point_mm[k] - r_.point_mm[k - 1]));
          }
        }
        return from_double<T>(r_.point_mm[r_.n_points - 1]);
      }
      default: return from_double<T>(r_.constant_mm);
    }
  }

  // The sine at phase p (Q0.32 turns): lo + span (1 - cos 2 pi p) / 2 = lo + span cos_ramp(x),
  // x = 2 p folded to [0, 1]: the phase curves' shape (scalar.hpp), so the image carries one
  // cosine. x in Q1.31 is 2 p for p <= 1/2, 2 (1 - p) above.
  T sine_at(uint32_t p) const {
    const uint32_t x31 = p <= 0x80000000u ? p : 0u - p;
    return lo_ + span_ * cos_ramp(from_q31<T>(x31));
  }

  // (The scalars before the reference: on the AVR a load reaches 63 bytes past the generator's
  // address.)
  T lo_, span_;
  // The tick multiplies: a division costs ~500 AVR cycles of the control section.
  double inv_step_s_, inv_period_s_;
  uint32_t turns_per_tick_;  // the sine's phase per tick of at_tick(), Q0.32 turns
  Reference r_;
};

}  // namespace sma

#endif  // SMA_REFERENCE_HPP
