// A parsed command applied to the console State, its reply, and the status line.
// Part of sma/console.hpp (the command set and the contract are documented there).
#ifndef SMA_CONSOLE_EXECUTE_HPP
#define SMA_CONSOLE_EXECUTE_HPP

#include "parse.hpp"

namespace sma {
namespace console {

// ---- execution ---------------------------------------------------------------------------------
// Applies a parsed command to the state and writes the reply. `fault` is the latched safety
// fault (Fault::None if none). Returns false (ERR, state untouched) if the command is refused.
// Status and Help only write their reply here; the firmware appends live values to status
// (status_line()).
inline bool apply(const Command& c, State& s, Fault fault, Reply& reply) {
  reply.clear();
  if (c.heats() && fault != Fault::None) {
    reply.put_f(SMA_F("ERR fault "));
    reply.put_f(fault_name(fault));
    reply.put_f(SMA_F(": send stop"));
    return false;
  }
  const char* why = nullptr;  // refused: `ERR <command>: <why>`
  if (is_model_op(c.op)) {
    if (!(s.heat && (c.props & kCold))) return true;  // the firmware runs it (model_command) and replies
    why = SMA_F("heater on, send stop");
  } else if (c.op == Op::Empty) {
    return true;  // nothing, no reply
  } else if (c.op == Op::TrajPoint) {
    if (s.traj.n_points >= kMaxPoints) {
      why = SMA_F("full (16 points)");
    } else if (s.traj.n_points > 0 && !(c.a > s.traj.point_t[s.traj.n_points - 1])) {
      why = SMA_F("t_s must increase");
    } else {
      s.traj.add_point(c.a, c.b);
      reply.put_f(SMA_F("OK traj point "));
      reply.put_u(s.traj.n_points);
      return true;
    }
  } else if (c.op == Op::TrajRun && s.traj.n_points == 0) {
    why = SMA_F("no points");
  }
  if (why) {
    reply.put_f(SMA_F("ERR "));
    storage::detail::put_word(reply, detail::command_words(), c.row);
    reply.put_f(SMA_F(": "));
    reply.put_f(why);
    return false;
  }
  reply.put_f(SMA_F("OK "));
  if (c.props & kEndsTraining) s.training = false;
  // `OK <command> [<keyword>]` from the table (mode pid, tele on, traj run ...), then the values.
  if (c.op != Op::Help) {
    storage::detail::put_word(reply, detail::command_words(), c.row);
    if (detail::has_sub(c.row)) {
      reply.put(' ');
      storage::detail::put_word(reply, detail::command_subs(), c.row);
    }
  }
  switch (c.op) {
    case Op::Train:
      s.training = true;
      s.mode = Mode::OpenLoop;
      s.volt = 0.0;
      s.heat = true;
      break;
    case Op::Pos:
    case Op::Step:
    case Op::Sine:
    case Op::TrajRun:
      if (c.op == Op::Pos) {
        s.run_kind = RefKind::Constant;
        s.pos_mm = c.a;
      } else {
        s.run_kind = c.op == Op::Step ? RefKind::MultiStep
                     : c.op == Op::Sine ? RefKind::Sine : RefKind::Trajectory;
      }
      if (s.mode == Mode::OpenLoop) s.mode = s.loop_mode;  // a reference needs a loop
      s.heat = true;
      ++s.run;
      reply.put(' ');
      if (c.op == Op::Pos) {
        reply.put_fixed(c.a, 4);
        reply.put(' ');
      } else if (c.op == Op::TrajRun) {
        reply.put_fixed(s.traj.duration(), 2);
        reply.put_f(SMA_F(" s "));
      }
      reply.put_f(mode_name_f(s.mode));
      break;
    case Op::TrajClear:
      s.traj.n_points = 0;  // (no Reference temporary: 185 B of stack on AVR)
      break;
    case Op::SetMode:
      s.mode = c.mode;
      if (!s.heat) reply.put_f(SMA_F(" (heater off)"));
      break;
    case Op::Volt:
      s.volt = c.a;
      s.mode = Mode::OpenLoop;
      s.heat = true;
      reply.put(' ');
      reply.put_fixed(c.a, 4);
      reply.put_f(SMA_F(" open"));
      break;
    case Op::Gains: {
      PidGains& g = s.mode == Mode::Pid ? s.gains_pid : s.gains_ffpid;
      g.kp = c.a;
      g.ki = c.b;
      g.kd = c.c;
      reply.put_f(s.mode == Mode::Pid ? SMA_F(" pid") : SMA_F(" ffpid"));
      for (uint8_t k = 0; k < 3; ++k) {
        reply.put(' ');
        reply.put_fixed(k == 0 ? c.a : k == 1 ? c.b : c.c, 4);
      }
      break;
    }
    case Op::Tlim:
      s.tlim_C = c.a;
      reply.put(' ');
      reply.put_fixed(c.a, 1);
      break;
#if SMA_CONSOLE_LEAD
    case Op::Lead:
      s.lead = c.a;
      reply.put(' ');
      reply.put_fixed(c.a, 2);
      break;
#endif
#if SMA_CONSOLE_PREVIEW
    case Op::Cool:
      s.cool_weight = c.a;
      reply.put(' ');
      reply.put_fixed(c.a, 2);
      break;
#endif
    case Op::Tele:  // (c.mode carries the row's value)
      s.tele = c.on;
      s.plot = static_cast<uint8_t>(c.mode) == kTelePlot;
      break;
    case Op::Stop: s.heat = false; break;
    case Op::Help:
      {
        Limits lim;
        lim.model = (c.key & kModelCmd) != 0;
        lim.train = (c.key & kTrainCmd) != 0;
#if SMA_CONSOLE_PREVIEW
        lim.preview = c.on;
#endif
        put_help(reply, lim);
      }
      break;
    default: break;
  }
  return true;
}

// parse + apply. Returns true for OK (or an empty line: reply empty), false for ERR.
inline bool execute(const char* line, State& s, Fault fault, Reply& reply,
                    const Limits& lim = Limits(), Command* parsed = nullptr) {
  Command c;
  if (!parse(line, c, reply, lim)) return false;
  if (parsed) *parsed = c;
  return apply(c, s, fault, reply);
}

// Live values for `status`.
struct Live {
  uint32_t ticks = 0;     // since boot
  // (t_ref_s .. temp_C consecutive: status_line() reads them in a loop)
  double t_ref_s = 0.0;   // time in the running reference
  double d_mm = 0.0, ref_mm = 0.0, v = 0.0, temp_C = 0.0;
  Fault fault = Fault::None;
  uint16_t dropped = 0;   // replies or rows dropped for lack of serial buffer
  uint16_t overruns = 0;  // ticks lost because the previous one was still running
};

static_assert(offsetof(Live, temp_C) == offsetof(Live, t_ref_s) + 4 * sizeof(double), "Live: t_ref_s..temp_C consecutive");

// `OK status <mode> <ref kind> t=<s> d=<mm> r=<mm> V=<V> T=<C> tlim=<C> fault=<name> drop=<n> ovr=<n>`
inline void status_line(Reply& r, const State& s, const Live& l) {
  r.clear();
  r.put_f(SMA_F("OK status "));
  r.put_f(mode_name_f(s.active_mode()));
  r.put(' ');
  switch (s.training ? RefKind::Constant : s.run_kind) {
    case RefKind::MultiStep: r.put_f(SMA_F("step")); break;
    case RefKind::Sine: r.put_f(SMA_F("sine")); break;
    case RefKind::Trajectory: r.put_f(SMA_F("traj")); break;
    default: r.put_f(s.training ? SMA_F("train") : SMA_F("pos")); break;
  }
  // t d r V T: Live's consecutive values t_ref_s .. temp_C, with 2 4 4 3 1 decimals; then tlim.
  const double* value = &l.t_ref_s;
  for (uint8_t k = 0; k < 6; ++k) {
    r.put(' ');
    storage::detail::put_word(r, SMA_F("t d r V T tlim"), k);
    r.put('=');
    r.put_fixed(k < 5 ? value[k] : s.tlim_C, static_cast<uint8_t>(flash_char(SMA_F("244310") + k) - '0'));
  }
  r.put_f(SMA_F(" fault="));
  r.put_f(fault_name(l.fault));
  r.put_f(SMA_F(" drop="));
  r.put_u(l.dropped);
  r.put_f(SMA_F(" ovr="));
  r.put_u(l.overruns);
}

}  // namespace console
}  // namespace sma

#endif  // SMA_CONSOLE_EXECUTE_HPP
