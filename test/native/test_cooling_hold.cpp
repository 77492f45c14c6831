// A hold reached on the cooling branch (a down-step) is kept: the PID's cap on that branch (it
// may not heat the wire along a flat stage, eq 4) never holds the command below the
// feedforward's own V1 (eq 17 on the cooling curve, eq 16). The cap is V_hold at the
// controller's wire estimate, and after a down-step that estimate can sit below the inverse's
// model wire (the PID first cancels part of the feedforward): a cap below V1 then cools the wire
// under the hold, and on the cooling branch nothing brings it back up.
// On the board's own loop (the Uno's default for steps, `mode ffpid` with the known future, and
// the paper's inverse + PID, `lead 0`), rig-like, with models that are not the plain paper wire.
#include <gtest/gtest.h>
#include <math.h>

#include <string>
#include <vector>

#include "sma_host/board_rig.hpp"
#include "sma_host/closed_loop.hpp"
#include "sma_host/e2e_wire.hpp"
#include "sma_host/metrics.hpp"

namespace {
using sma_host::HostRig;
using sma_host::RunSetup;
using sma_host::Sample;

struct Wire {
  const char* name;
  sma::Params plant, model;
  sma::Effects plant_fx, model_fx;
};

std::vector<Wire> wires() {
  std::vector<Wire> w;
  sma::Effects latent;
  latent.latent_heat_J = 1.0;
  // A wire with 1 J of latent heat and its exact model (the estimate the cap reads leaves the
  // latent heat out: a measured d(eps)/dt is noise).
  w.push_back({"latent heat 1 J, exact model", sma::Params(), sma::Params(), latent, latent});
  // A model whose heat loss h is 10 % above the wire's.
  Wire h{"model h +10 %", sma::Params(), sma::Params(), sma::Effects(), sma::Effects()};
  h.plant.h = h.model.h / 1.1;
  w.push_back(h);
  return w;
}

// The largest |error| of the true position over [t0, t1) s.
double worst_between(const std::vector<Sample>& r, double t0, double t1) {
  double worst = 0.0;
  for (const Sample& x : r)
    if (x.t >= t0 && x.t < t1) worst = fmax(worst, fabs(x.ref - x.truth));
  return worst;
}

TEST(CoolingHold, ADownStepsHoldIsKept) {
  for (const Wire& w : wires()) {
    for (double lead : {1.0, 0.0}) {  // the default, the paper's inverse + PID
      RunSetup s;
      s.plant_params = w.plant;
      s.plant_effects = w.plant_fx;
      s.model_params = w.model;
      s.model_effects = w.model_fx;
      s.mode = sma::Mode::FeedforwardPid;
      s.config.gains = sma::console::default_gains(sma::Mode::FeedforwardPid);
      s.reference = sma::Reference::multi_step();
      s.lead = sma::lead_for(s.reference.kind);
      s.lead.lead_s *= lead;
      s.condition = sma_host::Condition::rig_like();
      const std::vector<Sample> r = sma_host::run_board_loop<HostRig>(s);
      // The 0.8 -> 0.5 mm step at 100 s: from the wire's arrival (5 s after the step with the
      // lead, which starts the cooling 10 s early; 15 s without it: ~9 s of passive cooling to
      // T_MSi first) until the next step's lead (10 s before 125 s; the hold's end without it).
      const double from = lead > 0.0 ? 105.0 : 115.0, until = 125.0 - s.lead.lead_s;
      const double worst = worst_between(r, from, until);
      std::printf("%s, lead %.0f s: worst |error| at the 0.5 mm hold, %.0f-%.0f s: %.4f mm\n", w.name,
                  s.lead.lead_s, from, until, worst);
      EXPECT_LE(worst, 0.01) << w.name << ", lead " << s.lead.lead_s << " s";  // 5 ADC steps
    }
  }
}
}  // namespace

namespace {
// A hold approached on the heating branch: with the exact model on the board the PID does not
// push the wire past the setpoint (it acts on the gap to the model wire, not to the reference,
// until the model is there), so no up-step of the multi-step overshoots by more than 0.01 mm and
// none is held off (issue 13). The paper's wire, and the end-to-end flow's wire (hidden non-linear
// convection) with its true model; the Uno's default.
TEST(HeatingHold, TheExactModelsStepsDoNotOvershoot) {
  struct Case {
    const char* name;
    sma::Params p;
    sma::Effects fx;
  };
  for (const Case& c : {Case{"paper wire", sma::Params(), sma::Effects()},
                        Case{"e2e wire", sma_host::e2e_wire(), sma_host::e2e_wire_effects()}}) {
    RunSetup s;
    s.plant_params = s.model_params = c.p;
    s.plant_effects = s.model_effects = c.fx;
    s.mode = sma::Mode::FeedforwardPid;
    s.config.gains = sma::console::default_gains(sma::Mode::FeedforwardPid);
    s.reference = sma::Reference::multi_step();
    s.lead = sma::lead_for(s.reference.kind);
    s.condition = sma_host::Condition::rig_like();
    const std::vector<Sample> r = sma_host::run_board_loop<HostRig>(s);
    const double over = sma_host::step_overshoot_mm(r, s.reference.step_s, 10.0);
    const sma_host::Metrics m = sma_host::step_metrics(r, s.reference.step_s);
    std::printf("%s, exact model: overshoot %.4f mm, SSE %.4f mm, RMS %.4f mm\n", c.name, over, m.sse_mm, m.rms_mm);
    EXPECT_LE(over, 0.01) << c.name;
    EXPECT_LE(m.sse_mm, 0.01) << c.name;
  }
}
}  // namespace
