// The console's state, limits, operations and parsed command (sma/console.hpp: the commands).
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_STATE_HPP
#define SMA_CONSOLE_STATE_HPP

#include <stddef.h>
#include <stdint.h>
#include "../controller.hpp"
#include "../pid.hpp"
#include "../reference.hpp"
#include "../safety.hpp"
#include "../scalar.hpp"

// The preview controller's rows (`mode preview`, `cool W`) in the command table: 1 (the host's
// default) or 0 for a board built without the preview (firmware/include/rig_board.h: ~200 B of
// flash for rows, words and checks it could never use). Where they are compiled in,
// Limits::preview still decides whether they exist.
#ifndef SMA_CONSOLE_PREVIEW
#define SMA_CONSOLE_PREVIEW 1
#endif
// The lead's row (`lead F`, sma::LeadConfig: inverse + PID with the known future) likewise: 1
// (the host's default) or 0 for a board built without the lead (firmware/include/rig_board.h).
#ifndef SMA_CONSOLE_LEAD
#define SMA_CONSOLE_LEAD 1
#endif

namespace sma {
namespace console {

constexpr uint8_t kLineMax = 47;    // longest accepted line, without the newline
constexpr uint8_t kReplyMax = 126;  // longest reply, with the terminating 0 (help: 125 characters)
constexpr double kTrajMaxS = 3600.0;

// Default gains: each mode tuned for its own best result on the paper's sine in rig-like
// conditions (host/include/sma_host/tune.hpp; bench_tracking prints them).
// (Constants, so that the console's initial State is a constant the AVR copies from flash.)
constexpr PidGains kGainsPid = {12.5, 5.12, 0.25, 0.05, 0.05};
constexpr PidGains kGainsFfpid = {12.1, 3.13, 0.0, 0.05, 0.05};
// (Field by field into the return value: a copy of the whole constant would add a temporary to
// Board::construct's frame, the deepest of the firmware.)
inline PidGains default_gains(Mode m) {
  const PidGains& k = m == Mode::Pid ? kGainsPid : kGainsFfpid;
  PidGains g;
  g.kp = k.kp;
  g.ki = k.ki;
  g.kd = k.kd;
  g.d_filter_s = k.d_filter_s;
  g.i_zone_mm = k.i_zone_mm;
  return g;
}

// mode_name() as an SMA_F (flash) string.
inline const char* mode_name_f(Mode m) {
  switch (m) {
    case Mode::OpenLoop: return SMA_F("open");
    case Mode::Pid: return SMA_F("pid");
    case Mode::Feedforward: return SMA_F("ff");
    case Mode::FeedforwardPid: return SMA_F("ffpid");
#if SMA_CONSOLE_PREVIEW
    case Mode::Preview: return SMA_F("preview");
#endif
    default: return SMA_F("off");
  }
}

// Limits of the numbers the console accepts.
struct Limits {
  double g_mm = 0.958;  // stroke: pos and traj points in 0..g
  double v_max = 2.0;   // volt in 0..v_max
  bool model = true;    // the model commands (pbegin ...) exist in this build
  bool train = true;    // train exists in this build
  bool preview = false; // the preview controller (mode preview, cool) exists in this build
  bool single = false;  // numbers in float arithmetic (sma::Board: as on the AVR)
};

// What the console controls but the trajectory (State): with trajectory_shape(), the part with
// non-zero defaults, constants the board copies from flash (the points it only zeroes).
// (The fields the board reads most come first: on the AVR they then sit within a load's 63-byte
// reach of the board's address, sma/board.hpp's member order; -86 B of flash on the float image.)
struct Settings {
  Mode mode = Mode::FeedforwardPid;  // selected controller (never Off; `stop` clears heat)
#if SMA_CONSOLE_PREVIEW
  Mode loop_mode = Mode::FeedforwardPid;  // the controller a reference starts after open loop
  double cool_weight = 1.0;  // the preview's heating/cooling trade-off (cool W, PreviewConfig)
#else
  static constexpr Mode loop_mode = Mode::FeedforwardPid;
  static constexpr double cool_weight = 1.0;
#endif
  bool heat = false;                 // heater allowed: false at boot and after stop or a trip
  bool tele = false;
  bool plot = false;  // telemetry as Teleplot lines (tele plot) instead of rig-log rows (tele on)
  bool training = false;  // the training signal is playing (train), open loop
  RefKind run_kind = RefKind::Constant;  // the reference being run (reference())
  uint16_t run = 0;  // incremented at every (re)start of a reference: restart its clock
  double volt = 0.0;                 // open-loop voltage
  double pos_mm = 0.0;                    // its setpoint if constant
  PidGains gains_pid = kGainsPid;
  PidGains gains_ffpid = kGainsFfpid;
  double tlim_C = 110.0;
#if SMA_CONSOLE_LEAD
  // `mode ffpid`'s heating/cooling trade-off on step, sine and traj (lead F): the cooling lead
  // as a factor of the tuned one (sma::lead_for: 10 s on step, 5.25 s on sine and traj);
  // 0: the paper's inverse + PID.
  double lead = 1.0;
#else
  static constexpr double lead = 0.0;
#endif
};

// The shape part of State::traj: the paper's step and sine, the kind Trajectory.
constexpr RefShape trajectory_shape() {
  RefShape r{};
  r.kind = RefKind::Trajectory;
  return r;
}

// What the console controls. The firmware applies it to the controller and the safety latch.
struct State : Settings {
  Reference traj = trajectory();  // trajectory points (edited by traj, run by traj run)

  // The reference being run (a trajectory as it was at `traj run`: the firmware copies it into
  // its generator then, so editing the points does not disturb a running trajectory).
  Reference reference() const {
    switch (run_kind) {
      case RefKind::MultiStep: return Reference::multi_step();
      case RefKind::Sine: return Reference::sine();
      case RefKind::Trajectory: return traj;
      default: return Reference::constant(pos_mm);
    }
  }

  // The controller mode to run now.
  Mode active_mode() const { return heat ? mode : Mode::Off; }
  // Gains of the selected PID mode (ffpid's for open and ff).
  const PidGains& gains() const { return mode == Mode::Pid ? gains_pid : gains_ffpid; }

  static Reference trajectory() {
    Reference r;
    r.kind = RefKind::Trajectory;
    return r;
  }
};

// The value of the `tele plot` row (tele on: 1, off: 0).
constexpr uint8_t kTelePlot = 2;

enum class Op : uint8_t {
  Empty, Pos, Step, Sine, TrajClear, TrajPoint, TrajRun, SetMode, Volt, Gains, Tlim, Tele,
  Status, Stop, Help, Train, Cool, Lead, PBegin, PSet, PGet, PCommit, PAbort, PInfo
};

// Model commands: executed by the firmware on its EEPROM (model_command()), not by apply().
inline bool is_model_op(Op op) { return op >= Op::PBegin; }

// A parsed line.
struct Command {
  Op op = Op::Empty;
  double a = 0.0, b = 0.0, c = 0.0;
  Mode mode = Mode::Off;
  bool on = false;
  uint8_t key = 0;    // model commands: the key (sma/storage.hpp); help: the build's kModelCmd/kTrainCmd
  uint8_t row = 0;    // its row of the command table (below)
  uint8_t props = 0;  // the row's properties (Prop)
  // Would this command turn the heater on?
  bool heats() const { return (props & 1u) != 0; }  // kHeats
};

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_STATE_HPP
