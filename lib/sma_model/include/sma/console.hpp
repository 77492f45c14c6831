// The firmware's serial console as pure functions: no I/O, no heap, no printf, C++14, AVR-ready.
// One line in -> one reply out, and a change of the console State only when the reply is OK.
//
// Commands (one per line, lower case, fields separated by spaces or tabs; numbers are plain
// decimals such as 0.4, -1, .5, +2.25: no exponent, no inf/nan):
//
// | command              | does                                                    | range      |
// |----------------------|---------------------------------------------------------|------------|
// | pos <mm>             | hold a constant setpoint, heater on                     | 0..g mm    |
// | step                 | run the paper's multi-step (0.2..0.8 mm, 25 s steps)    |            |
// | sine                 | run the paper's sine (0.2..0.7 mm, 50 s, 3 periods)     |            |
// | traj clear           | forget the trajectory points                            |            |
// | traj <t_s> <mm>      | add a point (time increasing, at most 16)               | 0..3600 s  |
// | traj run             | run the trajectory (linear between points, then hold)   |            |
// | mode open|pid|ff|ffpid|preview | select the controller (live if heating); preview where Limits::preview | |
// | volt <V>             | open-loop voltage; selects mode open, heater on         | 0..2 V     |
// | gains <kp> <ki> <kd> | PID gains of the selected PID mode (pid or ffpid)       | 0..999     |
// | tlim <degC>          | wire temperature limit of the safety latch              | 30..150    |
// | tele on|off          | telemetry rows t_s,v_V,d_mm,ref_mm,duty at 100 Hz       |            |
// | tele plot            | the same values as Teleplot lines `>v_V:0.81` ... (no rows) |        |
// | status               | one line: mode, reference, measurement, fault           |            |
// | stop                 | heater off (mode off), clears a latched fault           |            |
// | help                 | list the commands                                       |            |
// | cool <W>             | preview: weight of errors while the reference falls (sma/preview.hpp cool_weight; where Limits::preview) | 0..100 |
// | lead <F>             | ffpid on a reference: the cooling lead as a factor of the tuned one (sma::lead_for; 0: the paper's inverse + PID; where SMA_CONSOLE_LEAD) | 0..2 |
// | train [slope]        | the paper's training signal open loop (sma/training.hpp), then heater off | 0.0001..1 V/s |
// | pbegin               | start a new model set in the inactive EEPROM slot (copy of the active one) | |
// | pset <key> <value>   | write one value of the staged set: `OK pset <key> 0x<float32 bits read back>` | per key |
// | pcommit              | validate the staged set (Params/Effects::check), make it active, rebuild the controller | |
// | pabort               | drop the staged set (the active set stays)              |            |
// | pget <key>           | a value of the active set: `OK pget <key> <value> 0x<float32 bits>` | |
// | pinfo                | `OK pinfo v<version> slot <s> seq <n> crc 0x<crc>` or `... defaults` | |
//
// pbegin, pset and pcommit need the heater off (`ERR pset: heater on, send stop`). Keys are the
// params JSON contract's (interfaces.md) flattened: rho c h d0 L0 R T_amb T_AS T_AF T_MS T_MF
// T_s T_f T_MSs T_MSf q e g, m0..m5, loop<i>.T_i|T_ii|j (i 0..7), loops (count 0..8) and the
// effects as <effect>.<param> (sensor_delay.delay_s, ...). A value out of the key's range gets
// `ERR <key>: value out of range lo..hi`; a set check() refuses at pcommit gets `ERR <key>: <why>`
// with storage::CheckValidator (host), `ERR pcommit: <why>` with a validator that gives no key
// (the firmware's, which checks the whole model it builds, not one key).
// An effect's parameter alone is accepted as its key too (beta_per_K): a long key and a precise
// value must fit 47 characters. The model commands only parse here: the firmware runs them on
// its EEPROM with model_command(). train and the model commands exist where Limits::train /
// Limits::model say so (a firmware variant without them answers `ERR unknown command`).
//
// Replies: `OK <what changed>` or `ERR <problem>`; an ERR changes nothing. While a safety fault
// is latched, commands that would heat (pos, step, sine, traj run, volt) answer
// `ERR fault <name>: send stop`. When telemetry starts, the header `t_s,v_V,d_mm,ref_mm,duty` is
// sent once, then one row per tick, so the captured rows are a rig log (interfaces.md); reply
// lines start with OK/ERR and comments with '#', which log readers skip or report.
//
// Heater off at boot: State::heat is false until pos/step/sine/traj run/volt.
#ifndef SMA_CONSOLE_HPP
#define SMA_CONSOLE_HPP

// One concept per file:
#include "console/state.hpp"           // Limits, State, Op, Command, default gains
#include "console/reply.hpp"           // Reply (bounded text), telemetry row
#include "console/line_buffer.hpp"     // bytes -> lines
#include "console/parse.hpp"           // the command table, parse(), help
#include "console/execute.hpp"         // apply(), execute(), status_line()
#include "console/model_commands.hpp"  // pbegin .. pinfo on a storage::Store

#endif  // SMA_CONSOLE_HPP
