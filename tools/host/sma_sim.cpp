// sma_sim: runs the simulated rig (sma::Plant) and writes a rig log.
//   closed loop : a reference (multi-step, sine, constant, trajectory CSV) run by the board's
//                 logic, sma::Board, configured by console lines as a user would
//                 (sma_host::run_board_loop), or by the library's controller alone
//                 (--loop controller: sma_host::run_closed_loop; any --dt, --v-supply, --adc-step);
//   open loop   : a voltage signal (constant, steps, CSV of t,V, the paper's training signal);
//   replay      : the v_V of an existing log through the model: adds the model's displacement,
//                 temperature and fraction to the log's own columns (what `sma plot` uses).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>
#include "sma/console.hpp"
#include "sma_host/board_rig.hpp"
#include "sma_host/closed_loop.hpp"
#include "sma_tools/cli.hpp"
#include "sma_tools/params_json.hpp"
#include "sma_tools/replay.hpp"
#include "sma_tools/rig_log.hpp"
#include "sma_tools/signals.hpp"

using namespace sma_tools;

static const char* kUsage =
    "usage: sma_sim [common options] (--ref REF | --volt SIGNAL | --replay LOG.csv) [--out FILE]\n"
    "\n"
    "common options:\n"
    "  --params P.json        the simulated wire (default: the paper's Table II)\n"
    "  --effect NAME.P=X      add an effect to the simulated wire (repeatable), e.g.\n"
    "                         sensor_delay.delay_s=0.1, latent_heat.L_J=0.5\n"
    "  --noise MM             RMS displacement noise (default 0)\n"
    "  --adc-step MM          displacement quantisation (default 0)\n"
    "  --rig-like             model.md's rig-like condition (2 um noise, 2 um ADC, PWM levels,\n"
    "                         one tick of delay in closed loop)\n"
    "  --seed N               noise seed (default 1)\n"
    "  --dt S                 sample period (default 0.01 = 100 Hz)\n"
    "  --v-supply V           PWM supply for the duty column, duty = (V/Vs)^2 (default 5)\n"
    "  --out FILE             output CSV (default: stdout)\n"
    "closed loop:\n"
    "  --ref multistep|sine|const:MM|traj:FILE.csv   (trajectory CSV: t_s,mm rows, <= 16)\n"
    "  --mode ffpid|pid|ff|preview  controller (default ffpid), gains: console defaults;\n"
    "                         ffpid on a reference with the known future, as the board\n"
    "                         (--send 'lead 0': the paper's inverse + PID)\n"
    "  --gains KP,KI,KD       override the PID gains\n"
    "  --loop board|controller  board (default): the firmware's logic (sma::Board) at the\n"
    "                         rig's constants (rig_config.h: 100 Hz, 10-bit ADC sampled every\n"
    "                         1 ms, PWM counts), configured by the console lines a user sends\n"
    "                         (model: pbegin, pset per key, pcommit; mode; gains; the reference);\n"
    "                         its ADC and PWM replace --adc-step and the rig-like PWM levels.\n"
    "                         controller: the library's controller alone at --dt\n"
    "  --send LINE            board: one more console line before the reference starts\n"
    "                         (repeatable), e.g. 'tlim 90', 'cool 2'; an ERR reply stops the run\n"
    "  --model-params M.json  what the controller believes (default: the same wire, no effects)\n"
    "  --duration S           run length (default: the reference's own)\n"
    "open loop:\n"
    "  --volt const:V | steps:V@t,V@t,... | csv:FILE.csv (t,V) | train\n"
    "  --duration S           length of const (default 60) / tail after the last step (30)\n"
    "  --train-slope V/S      training ramp slope (default 5.88e-3, the paper's)\n"
    "  --train-peaks V,V,...  ramp peaks (default 2,1.6,1.55,1.5,1.46,1.42,\n"
    "                         1.39,1.36,1.33,1.3,1.25,1.2: 1.7 h at the paper's slope)\n"
    "  --train-floor V        bottom of each descent (default 0)\n"
    "  --train-hold S         hold at the floor (default 20)\n"
    "  --train-probe V,V,...  probe after the ramps: holds at these voltages\n"
    "                         (default 1.2,1.35,1.5,1.3,1.7,1.0,0.6,1.4; 0 = none)\n"
    "  --train-probe-s S      duration of each hold, and of the rest after them (default 20)\n"
    "replay:\n"
    "  --replay LOG.csv       model output for the log's v_V: columns t_s,v_V,d_mm[,ref_mm,duty],\n"
    "                         d_model_mm,T_model_C,eps_model\n"
    "  --eps0 X               austenite fraction at the start (default: --replay: from the log's\n"
    "                         first readings, the engine's initial-state rule; otherwise 0)\n"
    "  --tare                 shift the model's sensor zero to the log's first 50 samples (a\n"
    "                         potentiometer or laser zero differs from run to run)\n";

namespace {

std::string fmt(double x, int prec = 6) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*f", prec, x);
  return buf;
}

sma::Reference trajectory_from_csv(const std::string& path) {
  // The same strict t,value reader; positions on the stroke are >= 0, as the console's `traj`
  // takes them (the lookahead compares them on their bits, sma::above).
  Pwl p = csv_signal(path, "position (a position on the stroke is >= 0 mm)", "mm");
  sma::Reference r = sma::console::State::trajectory();
  if (p.points().size() > sma::kMaxPoints)
    throw Error(path + ": at most " + std::to_string(sma::kMaxPoints) + " trajectory points");
  for (const auto& pt : p.points()) r.add_point(pt.first, pt.second);
  return r;
}

struct Options {
  std::string params, model_params, out, ref, volt, replay, mode = "ffpid", gains, loop = "board";
  std::vector<std::string> effects, send;
  bool dt_given = false, v_supply_given = false;
  double noise = 0, adc = 0, dt = 0.01, v_supply = 5.0, duration = 0, eps0 = -1;
  unsigned long seed = 1;
  bool rig_like = false, tare = false;
  TrainingSignal train;
};

int run(int argc, char** argv) {
  Args a(argc, argv);
  Options o;
  if (a.empty()) {
    std::cerr << kUsage;
    return 2;
  }
  while (!a.empty()) {
    const std::string k = a.next();
    if (k == "-h" || k == "--help") {
      std::cout << kUsage;
      return 0;
    } else if (k == "--params") o.params = a.value(k);
    else if (k == "--model-params") o.model_params = a.value(k);
    else if (k == "--effect") o.effects.push_back(a.value(k));
    else if (k == "--noise") o.noise = a.number(k);
    else if (k == "--adc-step") o.adc = a.number(k);
    else if (k == "--rig-like") o.rig_like = true;
    else if (k == "--seed") o.seed = static_cast<unsigned long>(a.number(k));
    else if (k == "--dt") o.dt = a.number(k), o.dt_given = true;
    else if (k == "--v-supply") o.v_supply = a.number(k), o.v_supply_given = true;
    else if (k == "--loop") o.loop = a.value(k);
    else if (k == "--send") o.send.push_back(a.value(k));
    else if (k == "--out") o.out = a.value(k);
    else if (k == "--ref") o.ref = a.value(k);
    else if (k == "--mode") o.mode = a.value(k);
    else if (k == "--gains") o.gains = a.value(k);
    else if (k == "--duration") o.duration = a.number(k);
    else if (k == "--volt") o.volt = a.value(k);
    else if (k == "--replay") o.replay = a.value(k);
    else if (k == "--eps0") o.eps0 = a.number(k);
    else if (k == "--tare") o.tare = true;
    else if (k == "--train-slope") o.train.plan.slope = a.number(k);
    else if (k == "--train-peaks") o.train.peaks = parse_list(a.value(k), k);
    else if (k == "--train-floor") o.train.plan.floor_V = a.number(k);
    else if (k == "--train-hold") o.train.plan.hold_s = a.number(k);
    else if (k == "--train-probe") {
      o.train.probes = parse_list(a.value(k), k);
      if (o.train.probes.size() == 1 && o.train.probes[0] == 0.0) o.train.probes.clear();
    }
    else if (k == "--train-probe-s") o.train.plan.probe_s = a.number(k);
    else throw Error("unknown option '" + k + "' (see --help)");
  }
  const int modes = !o.ref.empty() + !o.volt.empty() + !o.replay.empty();
  if (modes != 1) throw Error("give exactly one of --ref, --volt, --replay (see --help)");
  if (!(o.dt > 0.0 && o.dt <= 1.0)) throw Error("--dt must be in 0..1 s");
  if (!(o.noise >= 0.0) || !(o.adc >= 0.0)) throw Error("--noise and --adc-step must be >= 0");
  if (o.eps0 != -1.0 && !(o.eps0 >= 0.0 && o.eps0 <= 1.0)) throw Error("--eps0 must be in 0..1");

  Model wire = read_model(o.params);
  for (const auto& e : o.effects) set_effect_arg(wire.fx, e);
  check_model(wire, o.params.empty() ? "--effect" : o.params);

  sma::RigOptions rig;
  if (o.rig_like) rig = sma::RigOptions::rig_like();
  if (o.noise > 0.0) rig.noise_mm = o.noise;
  if (o.adc > 0.0) rig.adc_step_mm = o.adc;
  rig.seed = o.seed;
  rig.v_supply = o.v_supply;

  std::ostringstream body;
  std::ostringstream head;
  head << "# sma_sim: " << a.command_line() << "\n";
  head << "# params: " << model_to_json(wire, false) << "\n";
  head << "# rig: noise_mm=" << rig.noise_mm << " adc_step_mm=" << rig.adc_step_mm
       << " v_supply=" << rig.v_supply << " pwm_top=" << rig.pwm_top << " seed=" << rig.seed << "\n";

  if (!o.replay.empty()) {
    const RigLog log = read_rig_log(o.replay);
    const std::string note = dropped_note(log);
    if (!note.empty()) std::cerr << note << "\n";
    ReplayOptions ro;
    ro.eps0 = o.eps0;
    Trace tr;
    replay(wire, log.t, log.v, log.d, ro, tr);
    head << "# replay of " << log.name << " (" << log.size() << " rows, " << log.dropped
         << " dropped): model output for its v_V\n";
    if (o.tare) {
      const size_t nt = log.size() < 50 ? log.size() : 50;
      double shift = 0;
      for (size_t k = 0; k < nt; ++k) shift += log.d[k] - tr.d[k];
      shift /= static_cast<double>(nt);
      for (double& y : tr.d) y += shift;
      head << "# tared: model sensor zero shifted by " << fmt(shift, 5) << " mm\n";
    }
    body << "t_s,v_V,d_mm" << (log.has_ref() ? ",ref_mm" : "") << (log.has_duty() ? ",duty" : "")
         << ",d_model_mm,T_model_C,eps_model\n";
    for (size_t k = 0; k < log.size(); ++k) {
      body << fmt(log.t[k], 4) << ',' << fmt(log.v[k], 5) << ',' << fmt(log.d[k], 5);
      if (log.has_ref()) body << ',' << fmt(log.ref[k], 5);
      if (log.has_duty()) body << ',' << fmt(log.duty[k], 6);
      body << ',' << fmt(tr.d[k], 5) << ',' << fmt(tr.T[k], 4) << ',' << fmt(tr.eps[k], 6) << '\n';
    }
  } else if (!o.volt.empty()) {
    Pwl sig;
    std::string desc;
    if (o.volt == "train") {
      sig = o.train.build();
      std::ostringstream d;
      d << "training signal (paper III.B): slope " << o.train.plan.slope << " V/s, peaks";
      for (double p : o.train.peaks) d << ' ' << p;
      d << " V, floor " << o.train.plan.floor_V << " V, hold " << o.train.plan.hold_s << " s, probe";
      for (double p : o.train.probes) d << ' ' << p;
      d << " V x " << o.train.plan.probe_s << " s";
      desc = d.str();
    } else if (o.volt.compare(0, 6, "const:") == 0) {
      double v;
      if (!detail::to_number(o.volt.substr(6), v)) throw Error("--volt const:V: bad number");
      sig.add(0.0, v);
      sig.add(o.duration > 0 ? o.duration : 60.0, v);
      desc = "constant " + o.volt.substr(6) + " V";
    } else if (o.volt.compare(0, 6, "steps:") == 0) {
      sig = steps_signal(o.volt.substr(6), o.duration > 0 ? o.duration : 30.0);
      desc = "steps " + o.volt.substr(6);
    } else if (o.volt.compare(0, 4, "csv:") == 0) {
      sig = csv_signal(o.volt.substr(4));
      desc = "t,V from " + o.volt.substr(4);
    } else {
      throw Error("--volt '" + o.volt + "': expected const:V, steps:V@t,..., csv:FILE or train");
    }
    for (const auto& pt : sig.points())
      if (pt.second < 0.0) throw Error("--volt: negative voltage");
    head << "# signal: open loop, " << desc << "\n";
    const long n = static_cast<long>(sig.duration() / o.dt + 1e-9) + 1;
    std::vector<double> t(static_cast<size_t>(n)), v(static_cast<size_t>(n));
    for (long k = 0; k < n; ++k) {
      t[static_cast<size_t>(k)] = static_cast<double>(k) * o.dt;
      v[static_cast<size_t>(k)] = sig.at(t[static_cast<size_t>(k)]);
    }
    ReplayOptions ro;
    ro.rig = rig;
    ro.noisy = true;
    ro.eps0 = o.eps0;
    Trace tr;
    replay(wire, t, v, {}, ro, tr);
    const double vs = rig.v_supply > 0 ? rig.v_supply : 5.0;
    body << "t_s,v_V,d_mm,duty,T_true_C,eps_true\n";
    for (size_t k = 0; k < t.size(); ++k) {
      const double duty = (v[k] / vs) * (v[k] / vs);
      body << fmt(t[k], 4) << ',' << fmt(v[k], 6) << ',' << fmt(tr.d[k], 6) << ','
           << fmt(duty > 1.0 ? 1.0 : duty, 6) << ',' << fmt(tr.T[k], 4) << ',' << fmt(tr.eps[k], 6)
           << '\n';
    }
  } else {
    sma_host::RunSetup s;
    s.plant_params = wire.p;
    s.plant_effects = wire.fx;
    if (!o.model_params.empty()) {
      const Model believed = read_model(o.model_params);
      s.model_params = believed.p;
      s.model_effects = believed.fx;
    } else {
      s.model_params = wire.p;
    }
    if (o.mode == "ffpid") s.mode = sma::Mode::FeedforwardPid;
    else if (o.mode == "pid") s.mode = sma::Mode::Pid;
    else if (o.mode == "ff") s.mode = sma::Mode::Feedforward;
    else if (o.mode == "preview") s.mode = sma::Mode::Preview;
    else throw Error("--mode '" + o.mode + "': expected ffpid, pid, ff or preview");
    s.config.gains = sma::console::default_gains(s.mode == sma::Mode::Pid ? sma::Mode::Pid
                                                                          : sma::Mode::FeedforwardPid);
    if (!o.gains.empty()) {
      const std::vector<double> g = parse_list(o.gains, "--gains");
      if (g.size() != 3) throw Error("--gains: expected KP,KI,KD");
      s.config.gains.kp = g[0];
      s.config.gains.ki = g[1];
      s.config.gains.kd = g[2];
    }
    s.config.dt = o.dt;
    if (const char* msg = s.config.check()) throw Error(std::string("controller: ") + msg);
    if (o.ref == "multistep") s.reference = sma::Reference::multi_step();
    else if (o.ref == "sine") s.reference = sma::Reference::sine();
    else if (o.ref.compare(0, 6, "const:") == 0) {
      double mm;
      if (!detail::to_number(o.ref.substr(6), mm)) throw Error("--ref const:MM: bad number");
      s.reference = sma::Reference::constant(mm);
      if (!(o.duration > 0)) o.duration = 60.0;
    } else if (o.ref.compare(0, 5, "traj:") == 0) {
      s.reference = trajectory_from_csv(o.ref.substr(5));
    } else {
      throw Error("--ref '" + o.ref + "': expected multistep, sine, const:MM or traj:FILE.csv");
    }
    // Inverse + PID on a reference runs as the board runs it by default: with the known future
    // (sma::lead_for; `--send 'lead 0'` on the board loop: the paper's controller).
    if (s.mode == sma::Mode::FeedforwardPid && sma_host::HostRig::lead()) s.lead = sma::lead_for(s.reference.kind);
    s.condition = o.rig_like ? sma_host::Condition::rig_like() : sma_host::Condition::ideal();
    s.condition.rig = rig;
    s.duration_s = o.duration;
    const bool board = o.loop == "board";
    if (!board && o.loop != "controller") throw Error("--loop '" + o.loop + "': expected board or controller");
    std::vector<sma_host::Sample> run;
    if (board) {
      typedef sma_host::HostRig R;
      // The board's rig is rig_config.h's: what it fixes cannot be set here.
      if (o.dt_given && std::fabs(o.dt * R::tick_hz() - 1.0) > 1e-9)
        throw Error("--dt: the board ticks at " + fmt(1.0 / R::tick_hz(), 3) + " s (rig_config.h); --loop controller for another");
      if (o.v_supply_given && o.v_supply != R::v_supply())
        throw Error("--v-supply: the board's supply is " + fmt(R::v_supply(), 1) + " V (rig_config.h); --loop controller for another");
      if (o.adc > 0.0)
        throw Error("--adc-step: the board's 10-bit ADC quantises the sensor (" +
                    fmt(R::adc_vref() / R::adc_counts() * R::sensor_mm_per_v() * 1000.0, 2) + " um); --loop controller for another");
      s.config.v_max = R::v_max();
      run = sma_host::run_board_loop<R>(s, o.send);
    } else {
      if (!o.send.empty()) throw Error("--send: console lines go to the board (--loop board)");
      run = sma_host::run_closed_loop<double>(s);
    }
    head << "# signal: closed loop, reference " << o.ref << ", mode " << o.mode << ", gains "
         << s.config.gains.kp << ',' << s.config.gains.ki << ',' << s.config.gains.kd << ", "
         << s.condition.name << "\n";
    if (board) {
      head << "# loop: board (sma::Board at rig_config.h's constants; d_mm: the mean of the tick's ADC samples)";
      for (const std::string& l : o.send) head << ", sent '" << l << "'";
      head << "\n";
    } else {
      head << "# loop: controller (sma::Controller alone)\n";
    }
    const double vs = rig.v_supply;
    body << "t_s,v_V,d_mm,ref_mm,duty,T_true_C,d_true_mm\n";
    for (const auto& x : run) {
      const double duty = (x.v / vs) * (x.v / vs);
      body << fmt(x.t, 4) << ',' << fmt(x.v, 6) << ',' << fmt(x.meas, 6) << ',' << fmt(x.ref, 6)
           << ',' << fmt(duty > 1.0 ? 1.0 : duty, 6) << ',' << fmt(x.temp, 4) << ','
           << fmt(x.truth, 6) << '\n';
    }
  }
  if (o.out.empty()) {
    std::cout << head.str() << body.str();
  } else {
    std::ofstream f(o.out);
    if (!f) throw Error(o.out + ": cannot write");
    f << head.str() << body.str();
    if (!f) throw Error(o.out + ": write failed");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return sma_tools::guarded_main("sma_sim", argc, argv, run); }
