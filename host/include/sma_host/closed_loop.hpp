// Host side: one closed-loop run against the simulated Plant, two ways:
//   run_board_loop_on  the board's logic, sma::Board, through the host's one harness
//                      (board_loop.hpp), configured by the console lines a user sends: what
//                      `tools/sma sim` runs by default;
//   run_closed_loop_on a Controller<T> / PreviewController<T> at the controller's tick, measure,
//                      compute, apply: any scalar, tick rate, rig condition and preview setting,
//                      at a fraction of the Board's cost (the tracking benchmarks and the tuner
//                      run thousands of these loops).
// Shared by the native tests, the tracking benchmark and `tools/sma sim`.
#ifndef SMA_HOST_CLOSED_LOOP_HPP
#define SMA_HOST_CLOSED_LOOP_HPP

#include <stdio.h>

#include <string>
#include <vector>
#include "sma/console.hpp"
#include "sma/controller.hpp"
#include "sma/storage.hpp"
#include "sma_host/board_loop.hpp"
#include "sma_host/error.hpp"
#include "sma_host/plant.hpp"
#include "sma/preview.hpp"
#include "sma/reference.hpp"
#include "sma/sensor.hpp"

namespace sma_host {

struct Sample {
  double t;       // s
  double ref;     // mm
  double meas;    // measured displacement, mm
  double truth;   // true displacement, mm
  double v;       // voltage applied to the wire, V
  double v1;      // feedforward part, V
  double temp;    // true wire temperature, deg C
};

// One of the two closed-loop conditions of model.md.
struct Condition {
  const char* name = "ideal";
  sma::RigOptions rig;      // noise, ADC step, PWM levels
  int compute_delay_ticks = 0;  // extra ticks before a command reaches the heater (DelayLine)

  static Condition ideal() { return Condition(); }
  static Condition rig_like() {
    Condition c;
    c.name = "rig-like";
    c.rig = sma::RigOptions::rig_like();
    c.compute_delay_ticks = 1;
    return c;
  }
};

struct RunSetup {
  sma::Params plant_params;       // the wire
  sma::Effects plant_effects;     // what the wire does that the model may not know
  sma::Params model_params;       // what the controller believes
  sma::Effects model_effects;
  sma::ControllerConfig config;
  sma::PreviewConfig preview;     // Mode::Preview (dt and v_max come from config)
  sma::LeadConfig lead;           // Mode::FeedforwardPid with the known future (lead.lead_s > 0)
  // preview.plan_in_step = false: plan_step() calls after each tick's step() (the board's idle
  // time between ticks) on the Controller path; < 0: the config's, preview.plan_passes() (the
  // Board's rule, Board::plan()).
  int idle_plan_steps = -1;
  sma::Mode mode = sma::Mode::FeedforwardPid;
  sma::Reference reference = sma::Reference::sine();
  Condition condition;
  double duration_s = 0.0;  // 0: the reference's own duration
  // With sensor effects in model_effects, feed the controller the SensorPredictor's estimate
  // (calibration inverted, Smith predictor for lag/delay) instead of the raw measurement.
  bool compensate_sensor = true;
};

inline bool has_sensor_effects(const sma::Effects& fx) {
  return fx.sensor_delay_s > 0 || fx.sensor_lag_s > 0 || fx.sensor_gain != 1.0 || fx.sensor_offset_mm != 0.0;
}

// The command computed from the measurement of tick k drives the heater from tick k + 1 (the
// firmware writes the PWM for the next period), plus compute_delay_ticks more. A fixed ring of
// delay + 1 slots: each push returns the command pushed delay + 1 ticks earlier (0 V before).
class DelayLine {
 public:
  explicit DelayLine(int delay_ticks) : slots_(static_cast<size_t>(delay_ticks > 0 ? delay_ticks : 0) + 1, 0.0) {}
  double push(double v) {
    const double oldest = slots_[head_];
    slots_[head_] = v;
    head_ = (head_ + 1) % slots_.size();
    return oldest;
  }

 private:
  std::vector<double> slots_;
  size_t head_ = 0;
};

// The loop as the firmware runs it, one tick: measure, compute, apply (after the delay),
// record. compute(t, r, meas) -> {voltage command, its feedforward part}. PlantT is sma::Plant
// or any plant with its interface (measure, displacement, applied_voltage, temperature, step),
// e.g. plant B (plant_b_rig.hpp); s.plant_params/plant_effects are not read here.
struct Command {
  double v;
  double v1;
};

template <class T, class PlantT, class Compute>
std::vector<Sample> run_loop_on(PlantT& plant, const RunSetup& s, sma::ReferenceGen<T>& ref, Compute compute) {
  const double dt = s.config.dt;
  const double duration = s.duration_s > 0.0 ? s.duration_s : s.reference.duration();
  const long n = static_cast<long>(duration / dt + 0.5);
  DelayLine delay(s.condition.compute_delay_ticks);
  std::vector<Sample> out;
  out.reserve(static_cast<size_t>(n));
  for (long k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    const double meas = plant.measure();
    const T r = ref.at(t);
    const Command c = compute(t, r, meas);
    const double v = delay.push(c.v);
    out.push_back({t, sma::to_double(r), meas, plant.displacement(), plant.applied_voltage(v), c.v1,
                   plant.temperature()});
    plant.step(v, dt);
  }
  return out;
}

// Mode::Preview: the PreviewController, given the reference's future as the board would
// (ReferenceGen at t + tau). watch(controller) after each tick's planning (tests read its state).
struct NoWatch {
  template <class C>
  void operator()(const C&) const {}
};

template <class T, class PlantT, class Watch = NoWatch>
std::vector<Sample> run_preview_loop_on(PlantT& plant, const RunSetup& s, Watch watch = Watch()) {
  sma::PreviewConfig pc = s.preview;
  pc.dt = s.config.dt;
  pc.v_max = s.config.v_max;
  pc.pwm_top = static_cast<uint16_t>(s.condition.rig.pwm_top);  // the board knows its PWM
  pc.v_supply = s.condition.rig.v_supply;
  sma::PreviewController<T> ctl(s.model_params, s.model_effects, pc);
  sma::ReferenceGen<T> ref(s.reference);
  return run_loop_on<T>(plant, s, ref, [&](double t, T r, double meas) {
    auto future = [&](T tau) { return ref.at(t + sma::to_double(tau)); };
    const Command c{sma::to_double(ctl.step(r, future, sma::from_double<T>(meas))), 0.0};
    const int passes = s.idle_plan_steps < 0 ? pc.plan_passes() : s.idle_plan_steps;
    if (!pc.plan_in_step)
      for (int i = 0; i < passes; ++i)
        if (ctl.plan_step(future)) break;
    watch(ctl);
    return c;
  });
}

template <class T>
std::vector<Sample> run_preview_loop(const RunSetup& s) {
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  return run_preview_loop_on<T>(plant, s);
}

// Any controller mode against a given plant (see run_loop_on for PlantT).
template <class T, class PlantT>
std::vector<Sample> run_closed_loop_on(PlantT& plant, const RunSetup& s) {
  if (s.mode == sma::Mode::Preview) return run_preview_loop_on<T>(plant, s);
  sma::Controller<T> ctl(s.model_params, s.model_effects, s.config);
  sma::ReferenceGen<T> ref(s.reference, s.config.dt);
  const bool lead = s.lead.on();
  const uint32_t lead_ticks = s.lead.lead_ticks(s.config.dt), sample_ticks = s.lead.sample_ticks(s.config.dt);
  sma::SensorPredictor<T> sensor(ctl.inverse().curves(), s.model_params, s.model_effects, s.config.dt);
  const bool compensate = s.compensate_sensor && has_sensor_effects(s.model_effects);
  auto feedback = [&](double meas) {
    const T m = sma::from_double<T>(meas);
    return compensate ? sensor.correct(m, ctl.wire_temperature()) : m;
  };
  ctl.set_mode(s.mode, feedback(plant.measure()));
  return run_loop_on<T>(plant, s, ref, [&](double t, T r, double meas) {
    // The known future as the board reads it (ReferenceGen::lookahead at the tick).
    const uint32_t k = static_cast<uint32_t>(t / s.config.dt + 0.5);
    const sma::Lookahead<T> future = lead ? ref.lookahead(k, lead_ticks, sample_ticks, s.config.dt) : sma::Lookahead<T>{r, r, r};
    const double v = sma::to_double(ctl.step(r, feedback(meas), future, lead));
    const Command c{v, sma::to_double(ctl.v1())};
    ctl.prepare_next_tick(lead);  // between ticks, as the board (the lead's check of a parked wire)
    return c;
  });
}

template <class T>
std::vector<Sample> run_closed_loop(const RunSetup& s) {
  sma::Plant plant(s.plant_params, s.plant_effects, s.condition.rig);
  return run_closed_loop_on<T>(plant, s);
}

// ---- the same run on the Board ---------------------------------------------------------------
// A plain decimal (the console takes no exponent) of x in at most `room` characters, with as many
// of ~9 significant digits as fit.
inline std::string console_number(double x, size_t room) {
  if (x == 0.0) return "0";
  int dec = 8 - static_cast<int>(floor(log10(fabs(x))));
  if (dec < 0) dec = 0;
  for (;; --dec) {
    char buf[64];
    snprintf(buf, sizeof buf, "%.*f", dec, x);
    std::string t(buf);
    if (t.find('.') != std::string::npos) {
      t.erase(t.find_last_not_of('0') + 1);
      if (t.back() == '.') t.pop_back();
    }
    if (t.size() <= room || dec == 0) return t;
  }
}

// `pset <key> <value>` within a console line; an effect key too long for its value goes as its
// parameter alone (sensor_delay.delay_s -> delay_s), which the board accepts too.
inline std::string pset_line(uint8_t key, double value) {
  struct Name {
    std::string s;
    void put(char c) { s.push_back(c); }
  } n;
  sma::storage::put_key_name(n, key);
  std::vector<std::string> names{n.s};
  const size_t dot = n.s.find('.');
  if (key >= sma::storage::kFirstEffect && dot != std::string::npos) names.push_back(n.s.substr(dot + 1));
  std::string line;
  for (const std::string& name : names) {
    const size_t room = sma::console::kLineMax - 6 - name.size();
    line = "pset " + name + " " +
           (key == sma::storage::kKeyLoops ? std::to_string(static_cast<int>(value)) : console_number(value, room));
    if (line.size() <= sma::console::kLineMax) break;
  }
  return line;
}

// The console lines that give the board the run `s` describes: the model (pbegin, a pset per key,
// pcommit: sma upload's sequence), the controller and its gains (and, on a board with the lead,
// `board_lead`, inverse + PID's lead on a reference: `lead F`), then the reference (which starts
// the run). What the console cannot set is refused here, naming the setting.
inline std::vector<std::string> board_commands(const RunSetup& s, bool board_lead = true) {
  using sma::Mode;
  if (s.model_params.reheat != sma::Reheat::return_point)
    throw Error("the board's model reads a re-heat by its return point only (reheat \"return_point\")");
  std::vector<std::string> c{"pbegin"};
  for (uint8_t k = 0; k < sma::storage::kNumKeys; ++k)
    c.push_back(pset_line(k, sma::storage::get_value(s.model_params, s.model_effects, k)));
  c.push_back("pcommit");
  c.push_back(std::string("mode ") + sma::mode_name(s.mode));
  if (s.mode == Mode::Pid || s.mode == Mode::FeedforwardPid) {
    const sma::PidGains d = sma::console::default_gains(s.mode);
    if (s.config.gains.d_filter_s != d.d_filter_s || s.config.gains.i_zone_mm != d.i_zone_mm)
      throw Error("the board's console sets kp, ki, kd only (d_filter_s, i_zone_mm are its defaults)");
    const size_t room = 14;
    c.push_back("gains " + console_number(s.config.gains.kp, room) + " " + console_number(s.config.gains.ki, room) + " " +
                console_number(s.config.gains.kd, room));
  }
  if (s.mode == Mode::Preview && s.preview.cool_weight != sma::PreviewConfig().cool_weight)
    c.push_back("cool " + console_number(s.preview.cool_weight, 20));
  if (s.mode == Mode::FeedforwardPid && s.reference.kind != sma::RefKind::Constant) {
    // The board's lead is `lead F` times the tuned one of the reference's kind (sma::lead_for),
    // with the default peak window; s.lead off: `lead 0`, the paper's inverse + PID.
    const sma::LeadConfig tuned = sma::lead_for(s.reference.kind);
    const double f = s.lead.on() ? s.lead.lead_s / tuned.lead_s : 0.0;
    if (s.lead.on() && (!board_lead || s.lead.peak_window_s != tuned.peak_window_s || !(f <= 2.0)))
      throw Error("the board's known future is `lead F`: F (0..2) times its tuned lead of " +
                  console_number(tuned.lead_s, 10) + " s with a " + console_number(tuned.peak_window_s, 10) +
                  " s peak window" + (board_lead ? "" : ", on a board built with it (RIG_FEATURE_LEAD)"));
    if (board_lead) c.push_back("lead " + console_number(f, 20));
  }
  const sma::Reference& r = s.reference;
  const sma::Reference paper = r.kind == sma::RefKind::Sine ? sma::Reference::sine() : sma::Reference::multi_step();
  switch (r.kind) {
    case sma::RefKind::Sine:
      if (r.sine_lo_mm != paper.sine_lo_mm || r.sine_hi_mm != paper.sine_hi_mm || r.sine_period_s != paper.sine_period_s)
        throw Error("the board's sine is the paper's (0.2..0.7 mm, 50 s): give another as a trajectory");
      c.push_back("sine");
      break;
    case sma::RefKind::MultiStep:
      for (uint8_t k = 0; k < sma::kMaxSteps; ++k)
        if (r.n_steps != paper.n_steps || r.step_s != paper.step_s || (k < r.n_steps && r.step_mm[k] != paper.step_mm[k]))
          throw Error("the board's multi-step is the paper's: give another as a trajectory");
      c.push_back("step");
      break;
    case sma::RefKind::Trajectory:
      c.push_back("traj clear");
      for (uint8_t k = 0; k < r.n_points; ++k)
        c.push_back("traj " + console_number(r.point_t[k], 20) + " " + console_number(r.point_mm[k], 20));
      c.push_back("traj run");
      break;
    default:
      c.push_back("pos " + console_number(r.constant_mm, 30));
  }
  return c;
}

// The run on the Board: `s`'s commands sent before the first tick (each must be answered OK,
// else Error with the board's reply), then `extra` lines (e.g. tlim, cool) before the reference
// starts, the plant sampled by the board's ADC and driven by its PWM (the plant's own ADC step
// and PWM levels are the board's here: give the plant neither). s.config's dt and v_max are the
// rig's (Rig), the compute delay is the board's own (none added).
// Row k: t_k; ref and meas as the board's tick k saw them (meas: the mean of the tick's samples,
// before the sensor compensation); truth, temp at t_k; v (v1) the voltage (feedforward) the
// wire got from t_k to t_k+1.
template <class Rig, class PlantT>
std::vector<Sample> run_board_loop_on(PlantT& plant, const RunSetup& s, const std::vector<std::string>& extra = {}) {
  if (fabs(s.config.dt * Rig::tick_hz() - 1.0) > 1e-9 || s.config.v_max != Rig::v_max())
    throw Error("the board ticks at " + std::to_string(static_cast<int>(Rig::tick_hz())) + " Hz with V_max " +
                console_number(Rig::v_max(), 10) + " V (rig_config.h)");
  BoardLoop<Rig, PlantT> loop(plant);
  loop.boot();
  std::vector<std::string> lines = board_commands(s, BoardLoop<Rig, PlantT>::Board::kLead);
  lines.insert(lines.end() - (s.reference.kind == sma::RefKind::Trajectory ? 2 + s.reference.n_points : 1), extra.begin(),
               extra.end());
  for (const std::string& l : lines) {
    const std::string reply = loop.send(l);
    if (reply.compare(0, 2, "OK") != 0) throw Error("the board refused '" + l + "': " + reply);
  }
  const double duration = s.duration_s > 0.0 ? s.duration_s : s.reference.duration();
  const long n = static_cast<long>(duration * Rig::tick_hz() + 0.5);
  std::vector<Sample> out;
  out.reserve(static_cast<size_t>(n));
  double v = 0.0, v1 = 0.0;  // what the wire gets over the next tick
  for (long k = 0; k < n; ++k) {
    Sample x;
    x.t = loop.time();
    x.truth = plant.displacement();
    x.temp = plant.temperature();
    x.v = v;
    x.v1 = v1;
    v = loop.tick().v;
    v1 = s.mode == sma::Mode::Preview ? 0.0 : sma::to_double(loop.board().controller().v1());
    const sma::console::Live& live = loop.board().live();
    x.ref = live.ref_mm;
    x.meas = live.d_mm;
    out.push_back(x);
  }
  return out;
}

template <class Rig>
std::vector<Sample> run_board_loop(const RunSetup& s, const std::vector<std::string>& extra = {}) {
  sma::RigOptions rig = s.condition.rig;
  rig.adc_step_mm = 0.0;  // the board's ADC
  rig.pwm_top = 0;        // the board's PWM counts
  rig.v_supply = Rig::v_supply();
  sma::Plant plant(s.plant_params, s.plant_effects, rig);
  return run_board_loop_on<Rig>(plant, s, extra);
}

}  // namespace sma_host

#endif  // SMA_HOST_CLOSED_LOOP_HPP
