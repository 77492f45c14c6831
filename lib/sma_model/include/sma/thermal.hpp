// Thermal model of the wire (eq 1) and its inverse (eq 17), with the optional thermal effects
// of effects.hpp. The one place where the power balance of the wire is written:
//
//   C_th dT/dt = V^2 / R(eps) - G (T - T_a) (1 + beta (T - T_a)) - L dEps/dt
//
// with C_th = rho c pi d0^2 L0 / 4, G = pi d0 L0 h, T_a = T_amb + ambient offset,
// R(eps) = R (1 + k_R eps). With all effects zero this is exactly the paper's eq 1.
#ifndef SMA_THERMAL_HPP
#define SMA_THERMAL_HPP

#include "derived.hpp"
#include "effects.hpp"
#include "params.hpp"
#include "scalar.hpp"

namespace sma {

template <class T>
struct Thermal {
  T C;       // heat capacity C_th, J/K
  T inv_C;   // 1 / C_th: the tick never divides
  T G;       // conductance G, W/K
  T R;       // wire resistance, ohm
  T inv_R;   // 1 / R
  T T_a;     // true ambient, deg C
  T beta;    // non-linear convection, 1/K
  T k_R;     // phase-dependent resistance
  T L;       // latent heat of a full transformation, J
  bool plain;  // eq 1 is linear (at most an ambient offset): lets the tick skip work

  explicit Thermal(const Params& p, const Effects& fx = Effects())
      : Thermal(p, fx, p.heat_capacity(), p.conductance()) {}
  // With C_th and G computed by the caller (the inverse model: once for this and its WireStep).
  Thermal(const Params& p, const Effects& fx, double C_th, double G_th)
      : C(from_double<T>(C_th)),
        inv_C(reciprocal_as<T>(C_th)),
        G(from_double<T>(G_th)),
        R(from_field<T>(p.R)),
        inv_R(reciprocal_as<T>(p.R)),
        T_a(from_double<T>(fx.ambient_C(p.T_amb))),
        beta(from_field<T>(fx.convection_beta_per_K)),
        k_R(from_field<T>(fx.resistance_k)),
        L(from_field<T>(fx.latent_heat_J)),
        plain(!fx.nonlinear_thermal()) {}

  // Electrical power into the wire, V^2 / R(eps).
  T heat_in(T V, T eps = T(0)) const {
    const T p = V * V * inv_R;
    return plain ? p : p / (T(1) + k_R * eps);
  }
  // Heat lost to the air, G (T - T_a) (1 + beta (T - T_a)).
  T heat_loss(T Tw) const {
    const T dT = Tw - T_a;
    return plain ? G * dT : G * dT * (T(1) + beta * dT);
  }
  // dT/dt of eq 1 without the latent term (the plant adds that, knowing dEps/dt).
  T rate(T Tw, T V, T eps = T(0)) const { return (heat_in(V, eps) - heat_loss(Tw)) * inv_C; }

  // Steady state of the paper's eq 1 at constant V: T_a + V^2 / (R G).
  T steady_state(T V) const { return T_a + V * V * inv_R / G; }
  // Time constant tau = C_th / G.
  T time_constant() const { return C / G; }

  // Eq 17 (+ effects): the voltage that makes the wire follow a temperature path with slope
  // dTdt, given the fraction eps and its rate along the path. Zero when the wire must cool
  // faster than passive convection allows; the caller clamps to V_max.
  T voltage_for(T Tw, T dTdt, T eps = T(0), T deps_dt = T(0)) const {
    T power = C * dTdt + heat_loss(Tw);
    if (!plain) power = power + L * deps_dt;
    return voltage_at(power, eps);
  }
  // Eq 17 with dT/dt = 0: the voltage that holds the wire at Tw (no C dT/dt term to evaluate).
  T hold_voltage(T Tw, T eps = T(0)) const { return voltage_at(heat_loss(Tw), eps); }

 private:
  // The voltage that puts `power` into the wire at fraction eps; 0 for no power (or NaN).
  // (Out of line: one copy for the feedforward's eq 17 and V_hold, flash on the Uno.)
  __attribute__((noinline)) T voltage_at(T power, T eps) const {
    if (!(power > T(0))) return T(0);
    const T r = plain ? R : R * (T(1) + k_R * eps);
    return sqrt(r * power);
  }
};

// Eq 1 discretised exactly for a constant V over dt (zero-order hold, as the PWM holds V for
// one tick): T' = T_a + a (T - T_a) + b V^2, a = exp(-dt/tau), b = (1 - a) / (R G).
// Used by the on-board temperature estimate: two multiplies a tick, exact for any dt.
template <class T>
struct ThermalStep {
  T a, b, T_a;
  ThermalStep(const Params& p, double dt, const Effects& fx = Effects())
      : ThermalStep(p, dt, p.heat_capacity(), p.conductance(), from_double<T>(p.conductance()),
                    from_double<T>(fx.ambient_C(p.T_amb))) {}
  // With C_th, G and the true ambient computed by the caller (Thermal's), G also as the scalar
  // (the one eq 17's V_hold multiplies by). b comes from the scalar's own a and G, not from the
  // exact ones: V_hold = sqrt(R G (T - T_a)) then holds this step's T, b V_hold^2 =
  // (1 - a)(T - T_a). In Q16.16 a rounded on its own moves 1 - a (~0.0024) by up to 0.3 %; a
  // controller whose floor is V_hold at its own estimate would walk that estimate, and the wire
  // with it, ~2 K in 4 min on a hold (a cooler wire rides its loop's rise: eqs 5-6).
  ThermalStep(const Params& p, double dt, double C_th, double G_th, T G, T T_amb_true) : T_a(T_amb_true) {
    double one_minus_a;
    a = decay_as<T>(dt, C_th / G_th, one_minus_a);
    b = from_double<T>(one_minus_a / (p.R * to_double(G)));
  }
  T operator()(T Tw, T V) const { return passive(Tw) + heat(V); }
  T passive(T Tw) const { return T_a + a * (Tw - T_a); }  // no power
  T heat(T V) const { return b * V * V; }                  // what V adds
};

// One tick of the wire's temperature under a held voltage, with the same power balance as
// Thermal: exact (ThermalStep) for the paper's linear eq 1, one Euler step of the full balance
// with non-linear effects (dt = 10 ms << tau = 4 s). Shared by the feedforward's model wire and
// the controller's temperature estimate, so that both agree with what eq 17 inverts.
template <class T>
struct WireStep {
  const Thermal<T>* th;  // owned by the caller (the inverse model)
  ThermalStep<T> exact;
  T dt;

  WireStep(const Thermal<T>& thermal, const Params& p, double dt_s, const Effects& fx)
      : th(&thermal), exact(p, dt_s, fx), dt(from_double<T>(dt_s)) {}
  // With the C_th and G that `thermal` was built from (its true ambient too).
  WireStep(const Thermal<T>& thermal, const Params& p, double dt_s, double C_th, double G_th)
      : th(&thermal), exact(p, dt_s, C_th, G_th, thermal.G, thermal.T_a), dt(from_double<T>(dt_s)) {}

  // eps: austenite fraction (phase-dependent resistance); d_eps: its change over the tick (the
  // latent heat of what the wire transformed: fed a measured fraction tick by tick, its noise
  // does not add up, the changes telescope).
  T operator()(T Tw, T V, T eps = T(0), T d_eps = T(0)) const {
    if (th->plain) return exact(Tw, V);
    return Tw + ((th->heat_in(V, eps) - th->heat_loss(Tw)) * dt - th->L * d_eps) * th->inv_C;  // eq 1's heat over the tick
  }
};

}  // namespace sma

#endif  // SMA_THERMAL_HPP
