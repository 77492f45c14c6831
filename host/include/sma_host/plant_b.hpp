// A second SMA plant ("plant B"), written from docs' model.md alone, for tests and benchmarks
// of the identification and discrepancy workflow on data the library's own formulas did not
// make. It deliberately shares no code with lib/sma_model (plant.hpp, hysteresis.hpp,
// thermal.hpp): a bug or a hidden assumption there must not be copied here, so that a log from
// this plant tests the workflow, not the library against itself. docs/plant2.md lists how it
// differs:
//   - thermal eq 1 integrated by classic RK4 in sub-steps (not an exact zero-order-hold step);
//   - convection loss G dT + G2 dT |dT| (quadratic in the temperature rise);
//   - latent heat as a temperature drop per unit of transformed fraction, solved implicitly
//     after each sensible-heat sub-step (operator splitting, not a term of the ODE);
//   - every heating -> cooling reversal opens a new loop at its peak, also after a re-heat
//     that transformed nothing (model.md's text read literally; the library keeps the
//     interrupted loop instead: return-point memory). Wire::return_point_memory switches to
//     the library's reading, for the tests;
//   - sensor effects of plant_b_sensor.hpp (interpolated ring-buffer delay, bilinear lag).
#ifndef SMA_HOST_PLANT_B_HPP
#define SMA_HOST_PLANT_B_HPP

#include <math.h>

namespace sma_host {
namespace plant_b {

// The wire and rig of the paper, Table I-II (model.md "Parameters").
struct Wire {
  double rho = 6500.0, c = 836.8, h = 165.0, R = 1.0, d0 = 0.5e-3, L0 = 0.140, T_amb = 22.0;
  double T_AS = 50.2, T_AF = 80.1, T_MS = 28.0, T_MF = 22.0;
  double T_s = 60.8, T_f = 75.9, T_MSs = 51.1, T_MSf = 28.9;
  double m[6] = {1.0000, -4.8334, 10.2425, -8.6475, 0.0, 2.2385};  // m0..m5 of eq 8
  double q = -32.6936, e = 60.4657;
  double g_mm = 0.958;  // eq 12
  // false: a new loop at every reversal; true: a re-heat that transformed nothing keeps the
  // loop it interrupted (see Transformation::update).
  bool return_point_memory = false;
  // The identified minor loops (model.md table): peak T_i, end of the rise T_ii, rise j.
  double knot_Ti[3] = {63.1, 68.5, 71.5};
  double knot_Tii[3] = {61.2, 59.1, 65.2};
  double knot_j[3] = {0.16, 0.19, 0.10};

  double heat_capacity() const { return rho * c * M_PI * d0 * d0 * L0 / 4.0; }  // C_th, J/K
  double conductance() const { return M_PI * d0 * L0 * h; }                     // G, W/K
};

// Cosine between a (fraction 0) and b (fraction 1): eqs 2, 3 and 11 share this shape.
inline double cosine_ramp(double T, double a, double b) {
  if (T <= a) return 0.0;
  if (T >= b) return 1.0;
  return 0.5 * (1.0 - cos(M_PI * (T - a) / (b - a)));
}

// The cooling branch that starts at a heating -> cooling reversal (eqs 5-11).
struct CoolingBranch {
  double T_i = 0.0, eps_i = 0.0;  // reversal temperature and fraction
  double T_ii = 0.0, j = 0.0;     // end of the rise and the rise (already clamped to eps_i+j <= 1)
  double T_MSi = 0.0;             // martensite start of this loop
  double T_MF = 0.0;

  // Fraction on this branch at temperature T <= T_i.
  double at(double T) const {
    if (T >= T_i) return eps_i;
    if (T > T_ii) return eps_i + j * (T_i - T) / (T_i - T_ii);  // eqs 5-6 (T_i > T_ii here)
    const double top = eps_i + j;
    if (T >= T_MSi) return top;
    if (T_MSi <= T_MF) return T > T_MF ? top : 0.0;
    return top * cosine_ramp(T, T_MF, T_MSi);  // eq 11
  }
};

// Phase memory of the wire: the austenite fraction as a function of the temperature path.
class Transformation {
 public:
  explicit Transformation(const Wire& w) : w_(&w) {
    branch_.T_i = branch_.T_ii = branch_.T_MSi = w.T_MS;  // before any heating: the major cooling curve
    branch_.T_MF = w.T_MF;
    T_last_ = w.T_amb;
  }

  double fraction() const { return eps_; }
  const CoolingBranch& branch() const { return branch_; }

  double heating_curve(double T) const { return cosine_ramp(T, w_->T_AS, w_->T_AF); }  // eq 2

  // The branch that a reversal at (T_i, eps_i) starts (eqs 7-10; j and T_i - T_ii interpolated
  // piecewise-linearly in T_i between the identified loops, zero at and outside T_s, T_f).
  CoolingBranch branch_from(double T_i, double eps_i) const {
    const Wire& w = *w_;
    CoolingBranch b;
    b.T_i = T_i;
    b.eps_i = eps_i;
    b.T_MF = w.T_MF;
    double T_MSi;
    if (T_i > w.T_s && T_i < w.T_f) {
      const double nt = (T_i - w.T_s) / (w.T_f - w.T_s);  // eq 7
      double poly = 0.0;
      for (int k = 5; k >= 0; --k) poly = poly * nt + w.m[k];  // eq 8, Horner
      T_MSi = w.T_MSf + poly * (w.T_MSs - w.T_MSf);            // eq 9
    } else {
      T_MSi = w.q * heating_curve(T_i) + w.e;  // eq 10
    }
    // knots (T_s, 0, 0), the identified loops, (T_f, 0, 0)
    const double kT[5] = {w.T_s, w.knot_Ti[0], w.knot_Ti[1], w.knot_Ti[2], w.T_f};
    const double kJ[5] = {0.0, w.knot_j[0], w.knot_j[1], w.knot_j[2], 0.0};
    const double kS[5] = {0.0, w.knot_Ti[0] - w.knot_Tii[0], w.knot_Ti[1] - w.knot_Tii[1],
                          w.knot_Ti[2] - w.knot_Tii[2], 0.0};
    double j = 0.0, span = 0.0;
    for (int k = 0; k < 4; ++k)
      if (T_i > kT[k] && T_i < kT[k + 1]) {
        const double a = (T_i - kT[k]) / (kT[k + 1] - kT[k]);
        j = kJ[k] + a * (kJ[k + 1] - kJ[k]);
        span = kS[k] + a * (kS[k + 1] - kS[k]);
      } else if (T_i == kT[k + 1]) {
        j = kJ[k + 1];
        span = kS[k + 1];
      }
    b.j = fmin(j, 1.0 - eps_i);
    b.T_ii = T_i - span;
    if (span <= 0.0) b.j = 0.0;
    b.T_MSi = fmax(fmin(T_MSi, b.T_ii), w.T_MF);
    return b;
  }

  // Moves the wire to temperature T (the path between calls is taken as monotone).
  void update(double T) {
    if (heating_) {
      if (T >= T_last_) {
        eps_ = fmax(eps_, heating_curve(T));  // eq 4; flat until it meets the curve
      } else {
        // Heating -> cooling at T_i = T_last_: a new loop (eqs 5-11) fixed by this peak. With
        // return-point memory, a re-heat that transformed nothing keeps the interrupted loop's
        // branch instead and rejoins it where the re-heat began.
        if (!w_->return_point_memory || eps_ > eps_heat_start_ + 1e-12) {
          branch_ = branch_from(T_last_, eps_);
          rejoin_pending_ = false;
        }
        heating_ = false;
        cool_to(T);
      }
    } else {
      if (T <= T_last_) {
        cool_to(T);
      } else {
        heating_ = true;
        eps_heat_start_ = eps_;
        if (!rejoin_pending_) {
          rejoin_pending_ = true;
          T_rejoin_ = T_last_;
        }
        eps_ = fmax(eps_, heating_curve(T));
      }
    }
    T_last_ = T;
  }

 private:
  void cool_to(double T) {
    if (rejoin_pending_) {
      if (T > T_rejoin_) return;  // still above where the interrupted branch was left
      rejoin_pending_ = false;
    }
    eps_ = branch_.at(T);
  }

  const Wire* w_;
  CoolingBranch branch_;
  double eps_ = 0.0;
  double T_last_ = 0.0;
  bool heating_ = true;
  double eps_heat_start_ = 0.0;
  bool rejoin_pending_ = false;
  double T_rejoin_ = 0.0;
};

// Physical effects the paper's model leaves out, in this plant's own terms (each 0 = absent).
struct WireEffects {
  double ambient_offset_K = 0.0;  // true ambient = T_amb + this
  double G2_W_per_K2 = 0.0;       // convection: loss = G dT + G2 dT |dT|
  double k_R = 0.0;               // R(eps) = R (1 + k_R eps)
  double latent_K = 0.0;          // temperature drop per unit of fraction transformed to austenite
  double alpha_per_K = 0.0;       // linear thermal expansion of the wire
};

// Thermal eq 1 with the wire effects, the phase memory and the wire's length change.
class WirePlant {
 public:
  WirePlant(const Wire& w, const WireEffects& fx, int substeps = 5)
      : w_(w), fx_(fx), phase_(w_), substeps_(substeps) {
    T_ = ambient();
    phase_.update(T_);
  }
  WirePlant(const WirePlant&) = delete;
  WirePlant& operator=(const WirePlant&) = delete;

  double ambient() const { return w_.T_amb + fx_.ambient_offset_K; }
  double temperature() const { return T_; }
  double fraction() const { return phase_.fraction(); }
  const Transformation& phase() const { return phase_; }
  const Wire& wire() const { return w_; }

  // Heat flows, W, at temperature T and fraction eps under voltage V.
  double heating_W(double V, double eps) const { return V * V / (w_.R * (1.0 + fx_.k_R * eps)); }
  double loss_W(double T) const {
    const double dT = T - ambient();
    return w_.conductance() * dT + fx_.G2_W_per_K2 * dT * fabs(dT);
  }

  // The wire's length change, mm: D = g eps (eq 12) minus the thermal expansion of the wire
  // (the actuator shortens as the wire transforms; a warmer wire is longer).
  double displacement_mm() const {
    return w_.g_mm * phase_.fraction() - 1000.0 * fx_.alpha_per_K * w_.L0 * (T_ - ambient());
  }

  // Holds V for dt seconds. Each sub-step: RK4 on the sensible heat (fraction frozen over the
  // sub-step), then the latent temperature drop of the fraction that sub-step transforms.
  void step(double V, double dt) {
    const double h = dt / substeps_, C = w_.heat_capacity();
    for (int s = 0; s < substeps_; ++s) {
      const double eps = phase_.fraction();
      auto f = [&](double T) { return (heating_W(V, eps) - loss_W(T)) / C; };
      const double k1 = f(T_), k2 = f(T_ + 0.5 * h * k1), k3 = f(T_ + 0.5 * h * k2), k4 = f(T_ + h * k3);
      const double T1 = T_ + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      T_ = latent_settle(T1);
      phase_.update(T_);
    }
  }

 private:
  // Fraction the wire would have at T from the present state (the state is not changed).
  double trial_fraction(double T) const {
    Transformation t = phase_;
    t.update(T);
    return t.fraction();
  }

  // Solves T2 = T1 - latent_K (eps(T2) - eps0): the temperature after the transformation the
  // move to T2 causes has absorbed (heating) or released (cooling) its heat. On the heating curve
  // and below T_MSi the fraction rises with T, so the left side minus the right is monotone
  // and the root lies between the start and T1: bisection. The rise of a minor loop (eqs 5-6)
  // gains fraction while cooling; its heat is left out, since a reading of it as latent heat
  // gives a negative heat capacity for loop 2 (latent_K * j / (T_i - T_ii) > 1).
  double latent_settle(double T1) const {
    const double T0 = T_, eps0 = phase_.fraction();
    if (fx_.latent_K == 0.0 || T1 == T0) return T1;
    const double e1 = trial_fraction(T1);
    if ((T1 > T0 && e1 <= eps0) || (T1 < T0 && e1 >= eps0)) return T1;  // no transformation / rise
    double lo = fmin(T0, T1), hi = fmax(T0, T1);
    auto resid = [&](double T) { return T - T1 + fx_.latent_K * (trial_fraction(T) - eps0); };
    for (int it = 0; it < 40; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (resid(mid) > 0.0) hi = mid; else lo = mid;
    }
    return 0.5 * (lo + hi);
  }

  Wire w_;
  WireEffects fx_;
  Transformation phase_;
  int substeps_;
  double T_ = 0.0;
};

}  // namespace plant_b
}  // namespace sma_host

#endif  // SMA_HOST_PLANT_B_HPP
