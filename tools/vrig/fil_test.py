#!/usr/bin/env python3
"""Firmware-in-the-loop tests: the firmware ELF, unchanged, on the virtual rig (vrig = simavr +
the library's simulated plant). Standard library only.

    fil_test.py --vrig BUILD/tools/vrig/vrig --elf BUILD/firmware/sma_firmware.elf --out DIR TEST

Tests (each writes DIR/<test>/... and prints a one-line summary; exit status 0 = pass):
  tracking_step   paper's multi-step in ffpid mode, rig-like noise: the ELF tracks like the native
                  simulation of the same console + controller (vrig --native)
  tracking_sine   paper's sine, same comparison, plus the max error while heating of the paper's
                  inverse + PID (`lead 0`)
  bad_lines       every class of bad console line answers ERR and changes nothing
  sensor_loss     ADC0 driven out of the calibrated range: heater off within one tick
  flood           random input at full baud rate: the 100 Hz tick keeps its rate, the console
                  still answers afterwards
  watchdog_boot   started as after a watchdog reset (MCUSR.WDRF): fault latched, heating
                  refused until stop
  model           model parameters in EEPROM (vrig --eeprom): pinfo/pget on a blank EEPROM,
                  pbegin/pset/pcommit, bad lines (one ERR each, nothing changes), a set check()
                  refuses, a reboot keeps the set, a power loss in the middle of an upload keeps
                  the old set; stack margin through the deepest path (pcommit rebuilds the
                  controller)
  console         `tools/sma console` over the pseudo-terminal of vrig --pty: replies, a recorded
                  rig log, and the heater off after the console ends
  upload          `tools/sma upload` over the pseudo-terminal of vrig --pty, then a reboot reads
                  every key back (needs sma_params next to vrig, or --sma-params)
  train           (either image) `train 1`: the logged v_V is sma::TrainingPlan::voltage_at
                  (slope 1 V/s) to the printed precision (at a segment boundary: at most one tick
                  off, float time on the AVR), the duty to the PWM quantisation,
                  "# train done" at the end and the heater off after it

Bounds (why these numbers):
  * ELF vs native: same controller code and plant; they differ by the ADC (10 bit, the average of
    ~96 conversions over the tick vs 10 samples of 1 ms), float rounding and the exact instant the
    PWM changes (up to ~2 ms after the tick in the ELF). 5 um on an RMS of ~75-95 um and 10 um on
    a max error are several times the differences measured (about 1 um).
  * Max |error| while heating on the sine after the first period <= 0.036 mm: the rig-like anchor
    of model.md for the paper's inverse + PID (`lead 0`; this controller gets ~0.010 mm; the
    default with the known future trades it for the falling half: fil_lead).
  * Heater off within one tick: the fault is injected at a 1 ms plant step; the firmware checks
    every ADC sample of the tick's window, so the first control section whose window holds a
    faulted sample must already have written duty 0 (ticks_heating_after_fault == 0, delay <= 10 ms + the
    control section).
  * Stack: the deepest SP seen by the virtual rig (every push and frame) stays >= 32 bytes above
    _end (avr-nm), room for one more interrupt frame.
  * Flood: tick rate within 0.5 % of 100 Hz inside the flood window and no tick interval longer
    than 12 ms (a console line is handled between ticks; handling one takes < 1.5 ms).
"""
import argparse
import json
import math
import os
import shutil
import struct
import subprocess
import sys

from pty_board import PtyBoard

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "py"))
from sma import riglog  # noqa: E402


def out_dir(args, name, eeprom=False):
    """The test's output folder; eeprom: also the path of a blank EEPROM image there."""
    d = os.path.join(args.out, name)
    os.makedirs(d, exist_ok=True)
    if not eeprom:
        return d
    ee = os.path.join(d, "eeprom.bin")
    if os.path.exists(ee):
        os.remove(ee)
    return d, ee


def run_vrig(args, name, script_lines, duration, extra=(), native=False):
    d = out_dir(args, name)
    tag = "native" if native else "elf"
    script = os.path.join(d, f"script_{tag}.txt")
    with open(script, "w") as f:
        f.write("\n".join(script_lines) + "\n")
    log = os.path.join(d, f"log_{tag}.csv")
    cyc = os.path.join(d, f"cycles_{tag}.json")
    cmd = [args.vrig, "-" if native else args.elf, "--script", script, "--duration", str(duration),
           "--log", log, "--cycles-json", cyc, "--stamp"] + list(extra)
    if native:
        cmd.insert(2, "--native")
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                       errors="replace", timeout=1800)
    with open(os.path.join(d, f"stdout_{tag}.txt"), "w") as f:
        f.write(p.stdout)
    if p.returncode != 0:
        raise SystemExit(f"FAIL {name}: vrig exited {p.returncode}: {p.stderr[-500:]}")
    lines = []
    for ln in p.stdout.splitlines():
        if ln.startswith("["):
            t, _, text = ln[1:].partition("] ")
            lines.append((float(t), text))
    with open(cyc) as f:
        stats = json.load(f)
    return lines, read_log(log), stats


def read_log(path):
    """The telemetry rows (t_s, v_V, d_mm, ref_mm, duty) by the package's one reader (sma.riglog);
    none when the run sent no telemetry."""
    return riglog.read(path, empty_ok=True).rows()


def replies(lines):
    return [(t, s) for t, s in lines if s.startswith("OK") or s.startswith("ERR")]


def check(cond, msg, failures):
    if not cond:
        failures.append(msg)


def rms(xs):
    return math.sqrt(sum(x * x for x in xs) / len(xs)) if xs else float("nan")


def tracking_metrics(rows, t_from):
    t0 = rows[0][0]
    e = [(r[0] - t0, r[2] - r[3], r[3]) for r in rows]
    after = [x for x in e if x[0] >= t_from]
    heat = [after[i][1] for i in range(1, len(after)) if after[i][2] > after[i - 1][2]]
    return {
        "rms_mm": rms([x[1] for x in after]),
        "max_abs_mm": max(abs(x[1]) for x in after),
        "max_abs_heating_mm": max(abs(x) for x in heat) if heat else 0.0,
        "samples": len(after),
    }


def ram_end(elf):
    """Address of _end (end of .data/.bss/.noinit) from avr-nm, or None."""
    nm = shutil.which("avr-nm")
    if not nm or not elf or elf == "-":
        return None
    out = subprocess.run([nm, elf], stdout=subprocess.PIPE, text=True).stdout
    for ln in out.splitlines():
        p = ln.split()
        if len(p) == 3 and p[2] == "_end":
            return int(p[0], 16) & 0xFFFF
    return None


ELF = None


def common_checks(stats, failures):
    check(abs(stats["tick_rate_hz"] - 100.0) < 0.05, f"tick rate {stats['tick_rate_hz']} Hz", failures)
    if "wdtcsr" in stats:
        # WDE set, prescaler WDP = 0b0100: 250 ms (wdt_enable(WDTO_250MS)).
        check(stats["wdtcsr"] & 0x08 and stats["wdtcsr"] & 0x27 == 0x04, f"watchdog not at 250 ms: WDTCSR={stats['wdtcsr']:#x}", failures)
    end = ram_end(ELF)
    if end is not None and stats.get("sp_min", 0xFFFF) != 0xFFFF:
        # The deepest stack seen (pushes included) must stay clear of the static data, with room
        # for one more interrupt frame (~32 bytes) on top of it.
        stats["stack_margin_bytes"] = stats["sp_min"] - end
        check(stats["sp_min"] - end >= 32, f"stack margin {stats['sp_min'] - end} B (sp_min {stats['sp_min']:#x}, _end {end:#x})", failures)
    check(stats["tick_cycles_max"] < stats["cycles_per_tick_budget"],
          f"tick takes {stats['tick_cycles_max']} cycles > budget", failures)


def t_tracking(args, which):
    name = f"tracking_{which}"
    cmd = "step" if which == "step" else "sine"
    duration = 150 if which == "step" else 100
    t_from = 25.0 if which == "step" else 50.0  # after the first step / the first period
    script = ["0.0 tele on", "0.01 help", f"0.05 {cmd}"]
    extra = ["--noise-mm", "0.002", "--seed", "7"]
    lines_e, rows_e, st_e = run_vrig(args, name, script, duration, extra)
    # The native twin is the float image's board, which has the known future: for an image
    # without it (its help has no `lead`), the twin runs without it too (`lead 0`).
    has_lead = any("|lead F|" in text for _, text in lines_e)
    native = script if has_lead else script[:2] + ["0.04 lead 0"] + script[2:]
    _, rows_n, _ = run_vrig(args, name, native, duration, extra, native=True)
    me, mn = tracking_metrics(rows_e, t_from), tracking_metrics(rows_n, t_from)
    failures = []
    common_checks(st_e, failures)
    check(len(rows_e) >= duration * 100 - 5, f"only {len(rows_e)} telemetry rows", failures)
    check(me["rms_mm"] <= mn["rms_mm"] + 0.005, f"RMS {me['rms_mm']:.4f} vs native {mn['rms_mm']:.4f}", failures)
    check(me["max_abs_mm"] <= mn["max_abs_mm"] + 0.010,
          f"max {me['max_abs_mm']:.4f} vs native {mn['max_abs_mm']:.4f}", failures)
    if which == "sine":
        check(me["max_abs_heating_mm"] <= mn["max_abs_heating_mm"] + 0.010, "heating error vs native", failures)
        # model.md's rig-like anchor is the paper's inverse + PID's: `lead 0` where the image has
        # the known future (an image without it answers ERR and runs the same controller).
        _, rows_p, _ = run_vrig(args, name + "_lead0", ["0.0 tele on", "0.04 lead 0", f"0.05 {cmd}"], duration, extra)
        mp = tracking_metrics(rows_p, t_from)
        me["paper_max_abs_heating_mm"] = mp["max_abs_heating_mm"]
        check(mp["max_abs_heating_mm"] <= 0.036,
              f"inverse + PID (lead 0): max heating error {mp['max_abs_heating_mm']:.4f} > 0.036", failures)
    else:
        # Settled error at the end of each 25 s step (last 5 s), ELF vs native.
        for k in range(6):
            def seg(rows):
                t0 = rows[0][0]
                return max(abs(r[2] - r[3]) for r in rows if 25 * k + 20 < r[0] - t0 < 25 * k + 25)
            se, sn = seg(rows_e), seg(rows_n)
            me[f"step{k}_end_max_mm"] = se
            check(se <= sn + 0.010, f"step {k}: settled error {se:.4f} vs native {sn:.4f}", failures)
    summary = {"elf": me, "native": mn, "cycles": st_e}
    return name, summary, failures


def t_hold(args):
    """A constant setpoint held for 150 s (`pos 0.4`, inverse + PID): the wire and the heater's
    voltage do not creep. The PID's floor is V_hold at the controller's own temperature estimate;
    an estimate whose step disagrees with V_hold (a Q16.16 step with a rounded apart from b) walks
    the floor, and the wire rides its loop's rise, ~0.1 mm in 4 minutes. Against the native twin
    too."""
    name = "hold"
    script = ["0.0 tele on", "0.02 mode ffpid", "0.05 pos 0.4"]
    extra = ["--noise-mm", "0.002", "--seed", "7"]
    duration = 150
    _, rows_e, st_e = run_vrig(args, name, script, duration, extra)
    _, rows_n, _ = run_vrig(args, name, script, duration, extra, native=True)

    def mean(rows, col, a, b):
        t0 = rows[0][0]
        xs = [r[col] for r in rows if a <= r[0] - t0 < b]
        return sum(xs) / len(xs)
    d0, d1 = mean(rows_e, 2, 20, 30), mean(rows_e, 2, 140, 150)
    v0, v1 = mean(rows_e, 1, 20, 30), mean(rows_e, 1, 140, 150)
    dn = mean(rows_n, 2, 140, 150)
    failures = []
    common_checks(st_e, failures)
    check(len(rows_e) >= duration * 100 - 5, f"only {len(rows_e)} telemetry rows", failures)
    check(abs(d1 - d0) <= 0.005, f"the wire crept {1000 * (d1 - d0):+.1f} um from 20-30 s to 140-150 s", failures)
    check(abs(v1 - v0) <= 0.002, f"the voltage crept {1000 * (v1 - v0):+.2f} mV", failures)
    check(abs(d1 - dn) <= 0.005, f"held at {d1:.4f} mm, the native twin at {dn:.4f}", failures)
    summary = {"d_20_30_mm": d0, "d_140_150_mm": d1, "v_20_30_V": v0, "v_140_150_V": v1, "native_d_140_150_mm": dn,
               "cycles": st_e}
    return name, summary, failures


def t_bad_lines(args):
    name = "bad_lines"
    bad = [
        "frobnicate",            # unknown command
        "pos",                   # missing number
        "pos abc",               # not a number
        "pos 0.4x",              # trailing garbage
        "pos nan",               # nan
        "pos inf",               # inf
        "pos 1e-1",              # exponent not accepted
        "pos 5",                 # out of range
        "pos -0.1",              # out of range
        "pos 0.4 0.5",           # extra argument
        "volt 3",                # out of range
        "volt",                  # missing
        "gains 1 2",             # missing third
        "gains 1 2 -3",          # negative
        "tlim 500",              # out of range
        "tlim 20",               # out of range
        "lead 3",                # out of range (an image without the lead: unknown command)
        "lead",                  # missing (likewise)
        "mode warp",             # bad mode
        "mode",                  # missing mode
        "tele maybe",            # bad on/off
        "traj",                  # missing
        "traj 1",                # missing mm
        "traj -1 0.2",           # negative time
        "traj 1 2",              # mm out of range
        "traj run",              # no points
        "step now",              # extra text
        "x" * 80,                # too long
        "pos 0.\\x01",           # control character -> ERR (not a number)
        "pos \\xff0.3",          # non-ASCII byte
        "POS 0.4",               # commands are lower case
    ]
    script = ["0.05 status"] + [f"{0.1 + 0.05 * i:.2f} {b}" for i, b in enumerate(bad)]
    t_end = 0.1 + 0.05 * len(bad)
    script.append(f"{t_end + 0.1:.2f} status")
    # Then a valid setpoint, the same bad lines again while running, and a status.
    script.append(f"{t_end + 0.2:.2f} pos 0.3")
    t2 = t_end + 0.3
    script += [f"{t2 + 0.05 * i:.2f} {b}" for i, b in enumerate(bad) if b != "traj run"]
    t3 = t2 + 0.05 * len(bad) + 0.1
    script.append(f"{t3:.2f} status")
    lines, rows, st = run_vrig(args, name, script, t3 + 0.5)
    rep = replies(lines)
    failures = []
    n_err = sum(1 for _, s in rep if s.startswith("ERR"))
    expect_err = len(bad) + len(bad) - 1
    check(n_err == expect_err, f"{n_err} ERR replies, expected {expect_err}", failures)
    stat = [s for _, s in rep if s.startswith("OK status")]
    check(len(stat) == 3, f"{len(stat)} status replies", failures)
    if len(stat) == 3:
        strip = lambda s: " ".join(w for w in s.split() if not w.startswith(("t=", "d=", "V=", "T=")))
        check(strip(stat[0]) == strip(stat[1]), f"state changed by bad lines: {stat[0]!r} -> {stat[1]!r}", failures)
        check(" ffpid pos " in stat[2] and "r=0.3000" in stat[2] and "tlim=110" in stat[2],
              f"state after bad lines while running: {stat[2]!r}", failures)
    check(not rows, "telemetry started by a bad line", failures)
    check(any("line too long" in s for _, s in rep), "no 'line too long' error", failures)
    check(any("unknown command" in s for _, s in rep), "no 'unknown command' error", failures)
    common_checks(st, failures)
    return name, {"replies": rep, "cycles": st}, failures


def t_plot(args):
    """`tele plot`: Teleplot lines (`>name:value`, one per telemetry column, every tick) instead of
    the rig-log rows; `tele on` switches back to rows (header first), `tele off` stops both."""
    name = "plot"
    names = ["v_V", "d_mm", "ref_mm", "duty"]
    script = ["0.05 tele plot", "0.10 pos 0.3", "3.00 tele on", "4.00 tele plot", "5.00 tele off", "5.50 status"]
    lines, rows, st = run_vrig(args, name, script, 6.0)
    failures = []
    rep = [s for _, s in replies(lines)]
    check(rep[:1] == ["OK tele plot"], f"first reply {rep[:1]}", failures)
    plot = [(t, s) for t, s in lines if s.startswith(">")]
    groups = {}
    for t, s in plot:
        key, sep, val = s[1:].partition(":")
        check(sep == ":" and key in names, f"not a Teleplot line of the telemetry: {s!r}", failures)
        try:
            groups.setdefault(key, []).append((t, float(val)))
        except ValueError:
            failures.append(f"value not a number: {s!r}")
    # Every tick while plotting (0.05..3 s and 4..5 s: ~395 ticks), each name once per tick, in order.
    n = [len(groups.get(k, [])) for k in names]
    check(len(set(n)) == 1 and 380 <= n[0] <= 400, f"lines per name {dict(zip(names, n))}", failures)
    seq = [s[1:].partition(":")[0] for _, s in plot]
    check(seq == names * (len(seq) // 4), "names not in v_V, d_mm, ref_mm, duty order", failures)
    check(not any(3.05 < t < 3.95 or t > 5.05 for t, _ in plot), "Teleplot lines outside `tele plot`", failures)
    # The values are the rig-log row's: the setpoint after pos 0.3, duty and voltage in range and
    # the duty the voltage's (V / V_supply)^2 while rows would show the same.
    ref = [v for t, v in groups.get("ref_mm", []) if 0.2 < t < 2.9]
    check(ref and all(abs(v - 0.3) < 1e-9 for v in ref), "ref_mm is not the setpoint 0.3", failures)
    check(all(0.0 <= v <= 1.0 for _, v in groups.get("duty", [])), "duty outside 0..1", failures)
    check(any(v > 0.0 for _, v in groups.get("v_V", [])), "no heating voltage plotted", failures)
    d = [v for t, v in groups.get("d_mm", []) if 2.0 < t < 2.9]
    check(d and all(0.0 <= v < 1.0 for v in d), "d_mm out of the stroke", failures)
    # tele on in between: the header once, then rows (3..4 s); none after tele plot / off.
    headers = [t for t, s in lines if s == "t_s,v_V,d_mm,ref_mm,duty"]
    check(len(headers) == 1 and 3.0 <= headers[0] < 3.05, f"header lines at {headers}", failures)
    check(90 <= len(rows) <= 102, f"{len(rows)} rig-log rows between tele on and tele plot", failures)
    check(any(s.startswith("OK status") for s in rep), "no status reply after tele off", failures)
    common_checks(st, failures)
    return name, {"lines_per_name": dict(zip(names, n)), "rows": len(rows), "cycles": st}, failures


def t_sensor_loss(args):
    name = "sensor_loss"
    t_fault = 5.0  # on a slow ramp: the wire is being heated
    script = ["0.0 tele on", "0.05 traj 0 0", "0.1 traj 20 0.6", "0.15 traj run", f"{t_fault + 0.5} status", f"{t_fault + 0.6} pos 0.4",
              f"{t_fault + 0.7} stop", f"{t_fault + 0.8} status"]
    lines, rows, st = run_vrig(args, name, script, t_fault + 1.0, ["--sensor-fault", f"{t_fault}:5000"])
    failures = []
    delay = st["heater_off_s"] - t_fault
    check(st["heater_off_s"] >= t_fault, "heater never switched off", failures)
    check(st["ticks_heating_after_fault"] == 0, f"{st['ticks_heating_after_fault']} ticks heated after the fault", failures)
    check(delay <= 0.010 + st["control_cycles_max"] / 16e6, f"heater off {delay * 1e3:.2f} ms after the fault", failures)
    # Rows stamped with the simulated time at which they were received (t_s counts from the
    # first tick, ~10 ms after power-on); a row leaves up to ~3 ms after its tick.
    rows = []
    for t, text in lines:
        p = text.split(",")
        if len(p) == 5 and not text.startswith("t_s"):
            rows.append((t,) + tuple(float(x) for x in p[1:]))
    before = [r for r in rows if r[0] < t_fault - 0.1]
    check(before and before[-1][1] > 0.0, "was not heating before the fault", failures)
    check(all(r[1] > 0.0 for r in rows if t_fault - 0.5 <= r[0] < t_fault), "heater off before the fault", failures)
    after = [r for r in rows if r[0] >= t_fault + 0.015]
    check(after and all(r[1] == 0.0 and r[4] == 0.0 for r in after), "heating after the fault", failures)
    rep = [s for _, s in replies(lines)]
    check(any(s.startswith("OK status") and "fault=sensor" in s for s in rep), "status does not show fault=sensor", failures)
    check(any(s.startswith("ERR fault sensor") for s in rep), "pos not refused while faulted", failures)
    common_checks(st, failures)
    return name, {"heater_off_delay_ms": delay * 1e3, "cycles": st}, failures


def t_flood(args):
    name = "flood"
    # "6.4" alone sends an empty line: it ends the flood's last partial line (as a terminal would).
    script = ["0.0 tele on", "0.05 pos 0.4", "6.4", "6.5 status", "6.6 tele off"]
    lines, rows, st = run_vrig(args, name, script, 7.0, ["--flood", "2:6", "--noise-mm", "0.002"])
    failures = []
    check(abs(st["flood_tick_rate_hz"] - 100.0) < 0.5, f"tick rate in flood {st['flood_tick_rate_hz']:.3f} Hz", failures)
    check(st["flood_tick_interval_max_us"] < 12000, f"tick interval {st['flood_tick_interval_max_us']:.0f} us in flood", failures)
    check(st["uart_bytes_in"] > 4 * 10000, f"only {st['uart_bytes_in']} bytes sent", failures)
    rep = [s for t, s in replies(lines) if t > 6.4]
    check(any(s.startswith("OK status") and "ffpid" in s and "fault=none" in s for s in rep),
          f"no sane status after the flood: {rep}", failures)
    # Telemetry rows kept coming during the flood (each tick sends one row unless the TX buffer
    # is full of replies: allow 10 % drops).
    in_flood = [r for r in rows if 2.0 <= r[0] < 6.0]
    check(len(in_flood) >= 360, f"{len(in_flood)} telemetry rows in 4 s of flood", failures)
    common_checks(st, failures)
    return name, {"rows_in_flood": len(in_flood), "cycles": st}, failures


def t_watchdog_boot(args):
    name = "watchdog_boot"
    script = ["0.05 status", "0.1 pos 0.3", "0.2 stop", "0.3 pos 0.3", "0.4 tele on", "1.5 status"]
    lines, rows, st = run_vrig(args, name, script, 2.0, ["--wdrf"])
    failures = []
    texts = [s for _, s in lines]
    check(any(s.startswith("# fault watchdog") for s in texts), "no watchdog banner", failures)
    rep = [s for _, s in replies(lines)]
    check(len(rep) == 6, f"{len(rep)} replies: {rep}", failures)
    if len(rep) == 6:
        check("fault=watchdog" in rep[0] and " off " in rep[0], f"status at boot: {rep[0]!r}", failures)
        check(rep[1] == "ERR fault watchdog: send stop", f"pos while faulted: {rep[1]!r}", failures)
        check(rep[2] == "OK stop", rep[2], failures)
        check(rep[3].startswith("OK pos 0.3000"), rep[3], failures)
        check("fault=none" in rep[5] and " ffpid " in rep[5], f"status after stop: {rep[5]!r}", failures)
    check(rows and max(r[1] for r in rows) > 0.0, "no heating after stop + pos", failures)
    common_checks(st, failures)
    return name, {"replies": rep, "cycles": st}, failures


# ---- model parameters in EEPROM ----------------------------------------------------------------
def model_checks(stats, failures):
    """common_checks without the tick rate: EEPROM writes and the controller rebuild of pcommit
    hold the loop (heater off) and the skipped ticks are not made up."""
    end = ram_end(ELF)
    if end is not None and stats.get("sp_min", 0xFFFF) != 0xFFFF:
        stats["stack_margin_bytes"] = stats["sp_min"] - end
        check(stats["sp_min"] - end >= 32, f"stack margin {stats['sp_min'] - end} B", failures)
    check(stats["control_cycles_max"] < stats["cycles_per_tick_budget"], "control section over budget", failures)


def t_model(args):
    name = "model"
    d, ee = out_dir(args, name, eeprom=True)
    failures = []
    bad = [("pset T_AS 500", "ERR T_AS: value out of range -100..400"),
           ("pset foo 1", "ERR pset: unknown key 'foo'"),
           ("pset g", "ERR g: missing number <value>"),
           ("pset loops 2.5", "ERR loops: value must be an integer 0..8"),
           ("pset d0 1e-3", "ERR d0: value is not a number: '1e-3'"),
           ("pget", "ERR pget: missing <key>"),
           ("pinfo 1", "ERR pinfo: unexpected extra text"),
           ("pcommitx", "ERR unknown command 'pcommitx' (try help)")]
    good = [("pinfo", "OK pinfo v1 defaults"), ("pget T_AS", "OK pget T_AS 50.2 0x4248cccd"),
            ("pbegin", "OK pbegin slot 0"), ("pset T_AS 55.2", "OK pset T_AS 0x425ccccd"),
            ("pset T_AF 84.1", "OK pset T_AF 0x42a83333"), ("pset h 214.5", "OK pset h 0x43568000"),
            ("pset g 1.1496", "OK pset g 0x3f932618")]
    script, t = [], 0.05
    for cmd, _ in good + bad + [("pset T_AF 40", None), ("pcommit", None), ("pset T_AF 84.1", None),
                                ("pcommit", None), ("pget T_AS", None), ("pinfo", None), ("tele on", None),
                                ("pos 0.4", None), ("status", None), ("pget g", None), ("pinfo", None),
                                ("pset g 1", None)]:
        script.append(f"{t:.2f} {cmd}")
        t += 0.1
    lines, rows, st = run_vrig(args, name, script, t + 8.0, ["--eeprom", ee])
    rep = [s for _, s in replies(lines)]
    check(len(rep) == len(script), f"{len(rep)} replies to {len(script)} lines: {rep}", failures)
    if len(rep) == len(script):
        for k, (cmd, want) in enumerate(good + bad):
            check(rep[k] == want, f"{cmd!r}: {rep[k]!r}, expected {want!r}", failures)
        k = len(good) + len(bad)
        check(rep[k] == "OK pset T_AF 0x42200000", rep[k], failures)
        check(rep[k + 1] == "ERR pcommit: invalid model", f"refused commit: {rep[k + 1]!r}", failures)
        check(rep[k + 3].startswith("OK pcommit v1 slot 0 seq 1 crc 0x"), rep[k + 3], failures)
        check(rep[k + 4] == "OK pget T_AS 55.2 0x425ccccd", rep[k + 4], failures)
        check(rep[k + 5] == rep[k + 3].replace("pcommit", "pinfo"), rep[k + 5], failures)
        check(rep[k + 7].startswith("OK pos 0.4000"), rep[k + 7], failures)
        # read-only model commands while heating (their scratch Params is on the stack)
        check(rep[k + 9] == "OK pget g 1.1496 0x3f932618", rep[k + 9], failures)
        check(rep[k + 10] == rep[k + 5], rep[k + 10], failures)
        check(rep[k + 11] == "ERR pset: heater on, send stop", rep[k + 11], failures)
    check(rows and max(r[1] for r in rows) > 0.0, "no heating with the uploaded model", failures)
    model_checks(st, failures)
    # Reboot: the set is there; then a power loss in the middle of the next upload.
    lines2, _, st2 = run_vrig(args, name + "_reboot", ["0.05 pinfo", "0.1 pget g", "0.2 pbegin",
                                                        "0.3 pset T_AS 53", "0.4 pset g 1.2"], 0.45,
                              ["--eeprom", ee])
    rep2 = [s for _, s in replies(lines2)]
    info = rep[k + 5] if len(rep) == len(script) else "?"
    check(rep2[:3] == [info, "OK pget g 1.1496 0x3f932618", "OK pbegin slot 1"], f"after reboot: {rep2}", failures)
    lines3, _, st3 = run_vrig(args, name + "_powerloss", ["0.05 pinfo", "0.1 pget T_AS", "0.2 pget g"], 0.3,
                              ["--eeprom", ee])
    rep3 = [s for _, s in replies(lines3)]
    check(rep3 == [info, "OK pget T_AS 55.2 0x425ccccd", "OK pget g 1.1496 0x3f932618"],
          f"after a power loss mid-upload: {rep3}", failures)
    return name, {"replies": rep + rep2 + rep3, "cycles": st}, failures


def t_upload(args):
    """tools/sma upload through vrig's pseudo-terminal."""
    name = "upload"
    d, ee = out_dir(args, name, eeprom=True)
    wire = os.path.join(d, "wire.json")
    with open(wire, "w") as f:
        f.write('{"T_AS": 55.2, "T_AF": 84.1, "h": 214.5, "g": 1.1496, "loops": [{"T_i": 64, "T_ii": 60, "j": 0.2}],'
                ' "effects": {"sensor_delay": {"delay_s": 0.05}, "convection_nonlinear": {"beta_per_K": 0.001234567}}}')
    helper = args.sma_params or os.path.join(os.path.dirname(os.path.abspath(args.vrig)), "sma_params")
    sma = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sma")
    failures = []
    try:
        board = PtyBoard(args.vrig, args.elf, 40, extra=["--eeprom", ee])
    except RuntimeError as e:
        return name, {}, [str(e)]
    with board:  # leaving it: SIGINT, vrig writes the EEPROM file
        env = dict(os.environ, SMA_PARAMS=helper)
        up = subprocess.run([sys.executable, sma, "upload", wire, "--port", board.port], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, timeout=120)
    with open(os.path.join(d, "upload.txt"), "w") as f:
        f.write(up.stdout + up.stderr)
    check(up.returncode == 0, f"upload exit {up.returncode}: {up.stderr[-400:]}", failures)
    check("57 keys" in up.stdout, "upload did not verify 57 keys", failures)
    lines, _, st = run_vrig(args, name, ["0.05 pinfo", "0.1 pget T_AS", "0.2 pget loops", "0.3 pget delay_s",
                                         "0.4 pget beta_per_K"], 0.5, ["--eeprom", ee])
    rep = [s for _, s in replies(lines)]
    check(len(rep) == 5 and rep[0].startswith("OK pinfo v1 slot 0 seq 1"), f"after reboot: {rep}", failures)
    if len(rep) == 5:
        check(rep[1] == "OK pget T_AS 55.2 0x425ccccd", rep[1], failures)
        check(rep[2] == "OK pget loops 1 0x01", rep[2], failures)
        check(rep[3].startswith("OK pget sensor_delay.delay_s 0.05 "), rep[3], failures)
        check(rep[4].startswith("OK pget convection_nonlinear.beta_per_K 0.001235 "), rep[4], failures)
    return name, {"replies": rep, "upload": up.stdout[-500:]}, failures


def t_download(args):
    """Settings dump and restore on the virtual rig: upload a wire, download it (sma download),
    upload the download into a blank EEPROM, download again: both downloads and the uploaded
    file agree key by key within float32 precision (the board's decimal parser)."""
    name = "download"
    d = out_dir(args, name)
    wire = os.path.join(d, "wire.json")
    with open(wire, "w") as f:
        f.write('{"T_AS": 55.2, "T_AF": 84.1, "h": 214.5, "g": 1.1496, "loops": [{"T_i": 64, "T_ii": 60, "j": 0.2}],'
                ' "effects": {"sensor_lag": {"tau_s": 0.5}, "sensor_calibration": {"gain": 1.02, "offset_mm": -0.0123},'
                ' "convection_nonlinear": {"beta_per_K": 0.001234567}}}')
    helper = args.sma_params or os.path.join(os.path.dirname(os.path.abspath(args.vrig)), "sma_params")
    sma = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sma")
    env = dict(os.environ, SMA_PARAMS=helper)
    failures = []

    def keys_of(path):
        r = subprocess.run([helper, path], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        check(r.returncode == 0, f"sma_params {path}: {r.stderr[-300:]}", failures)
        out = {}
        for ln in r.stdout.splitlines():
            k, v = ln.split()
            out[k] = float(v) if k == "loops" else struct.unpack("<f", struct.pack("<f", float(v)))[0]
        return out

    def round_trip(src, dst, ee):
        if os.path.exists(ee):
            os.remove(ee)
        try:
            board = PtyBoard(args.vrig, args.elf, 60, extra=["--eeprom", ee])
        except RuntimeError as e:
            failures.append(str(e))
            return
        with board:
            up = subprocess.run([sys.executable, sma, "upload", src, "--port", board.port], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=env, timeout=120)
            check(up.returncode == 0, f"upload {src}: exit {up.returncode}: {up.stderr[-300:]}", failures)
            dl = subprocess.run([sys.executable, sma, "download", "--port", board.port, "-o", dst],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, timeout=120)
            check(dl.returncode == 0, f"download: exit {dl.returncode}: {dl.stderr[-300:]}", failures)
            check("57 keys" in dl.stdout, f"download did not read 57 keys: {dl.stdout[-200:]}", failures)

    first = os.path.join(d, "board.json")
    second = os.path.join(d, "board2.json")
    round_trip(wire, first, os.path.join(d, "eeprom1.bin"))
    round_trip(first, second, os.path.join(d, "eeprom2.bin"))
    if failures:
        return name, {}, failures
    a, b, c = keys_of(wire), keys_of(first), keys_of(second)
    # The board parses a decimal in float arithmetic (not correctly rounded): a value sent by
    # upload lands within a float32 ulp or two (upload checks 4e-7 relative), one more per trip.
    def close(x, y, trips):
        return y is not None and abs(x - y) <= trips * 4e-7 * max(abs(x), 1e-30)
    diff = [k for k in a if not (close(a[k], b.get(k), 1) and close(a[k], c.get(k), 2))]
    check(not diff, f"keys differ after the round trip: {[(k, a[k], b.get(k), c.get(k)) for k in diff[:5]]}",
          failures)
    return name, {"keys": len(a), "differ": len(diff)}, failures


def t_console(args):
    """tools/sma console against the virtual rig, through its pseudo-terminal: commands get their
    replies, telemetry is recorded as a rig log, and leaving the console turns the heater off."""
    name = "console"
    d = out_dir(args, name)
    sma = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "sma")
    failures = []
    try:
        board = PtyBoard(args.vrig, args.elf, 120)
    except RuntimeError as e:
        return name, {}, [str(e)]
    port = board.port
    rec = os.path.join(d, "run.csv")
    with board:
        c1 = subprocess.run([sys.executable, sma, "console", "--port", port, "--send", "tele on", "--send",
                             "pos 0.4", "--duration", "3", "--record", rec, "--status", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=60)
        c2 = subprocess.run([sys.executable, sma, "console", "--port", port, "--send", "status", "--duration",
                             "0.5", "--status", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            timeout=60)
    with open(os.path.join(d, "console.txt"), "w") as f:
        f.write(c1.stdout + c1.stderr + c2.stdout + c2.stderr)
    check(c1.returncode == 0, f"console exit {c1.returncode}: {c1.stderr[-400:]}", failures)
    check("OK pos 0.4000" in c1.stdout, f"no OK for pos: {c1.stdout[-300:]}", failures)
    rows = []
    if os.path.exists(rec):
        with open(rec) as f:
            body = [ln.strip() for ln in f if ln.strip() and not ln.startswith("#")]
        check(bool(body) and body[0] == "t_s,v_V,d_mm,ref_mm,duty", f"record header: {body[:1]}", failures)
        rows = [ln.split(",") for ln in body[1:]]
    check(len(rows) > 50, f"only {len(rows)} telemetry rows recorded", failures)
    check(any(float(r[1]) > 0.5 for r in rows), "the recorded run never heated", failures)
    # The console sent `stop` when it ended: the next session finds the heater off.
    check(c2.returncode == 0 and "OK status off" in c2.stdout, f"after the console ended: {c2.stdout[-300:]}",
          failures)
    return name, {"rows": len(rows)}, failures


# ---- the built-in training run (either image) ----------------------------------------------------
def training_oracle(args, slope):
    """The training signal as sma_sim writes it (sma::TrainingPlan::voltage_at, the one
    definition): (times, volts, duration) sampled every 10 ms."""
    sim = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(args.vrig))), "host", "sma_sim")
    out = os.path.join(args.out, "train_oracle.csv")
    subprocess.run([sim, "--volt", "train", "--train-slope", f"{slope:g}", "--out", out], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t, v = [], []
    with open(out) as f:
        for ln in f:
            if ln[0].isdigit():
                a, b = ln.split(",")[:2]
                t.append(float(a))
                v.append(float(b))
    return t, v, t[-1]


def t_train(args):
    name = "train"
    slope = 1.0
    o_t, o_v, dur = training_oracle(args, slope)

    def training_voltage(tt):
        k = int(round(tt / 0.01))
        return o_v[k] if 0 <= k < len(o_v) else 0.0

    t0 = 0.5
    lines, rows, st = run_vrig(args, name, ["0.0 tele on", f"{t0} train {slope:g}", f"{dur + 3:.1f} status"],
                               dur + 5, ["--noise-mm", "0.002"])
    failures = []
    rep = [s for _, s in replies(lines)]
    check(len(rep) == 3 and rep[1] == f"OK train {dur:.1f} s", f"replies {rep}", failures)
    done = [t for t, s in lines if s.startswith("# train done")]
    check(len(done) == 1, f"'# train done' lines: {len(done)}", failures)
    # Alignment: the first tick after the command has t = 0 in the plan.
    start = min((r[0] for r in rows if r[0] >= t0 and r[1] > 0), default=None)
    check(start is not None, "no training voltage at all", failures)
    worst_v = worst_duty = 0.0
    if start is not None:
        first = start - 20.0  # the plan starts with a 20 s hold at 0 V; the ramp starts at start
        # (the ramp's first non-zero tick is 0.01 s into it)
        first -= 0.01
        for t, v, _, _, duty in rows:
            tt = t - first
            if tt < 0 or tt > dur - 0.02:
                continue
            # At a segment boundary the AVR's float time can fall one tick to either side of the
            # double oracle's: the nearest of the three ticks counts.
            want = min((training_voltage(tt + dt) for dt in (0.0, -0.01, 0.01)), key=lambda w: abs(v - w))
            worst_v = max(worst_v, abs(v - want))
            # duty = n / 16000 with n = round((V / 5)^2 * 16000): +-0.5 count, printed to 1e-5
            worst_duty = max(worst_duty, abs(duty - (want / 5.0) ** 2))
        after = [r for r in rows if done and r[0] > done[0] + 0.05]
        check(after and max(r[1] for r in after) == 0.0, "heater not off after the training", failures)
    check(worst_v <= 1.5e-4, f"v_V differs from TrainingPlan::voltage_at by {worst_v:.2e} V", failures)
    check(worst_duty <= 0.5 / 16000 + 1e-5, f"duty differs by {worst_duty:.2e}", failures)
    if len(rep) == 3:
        check(" off " in rep[2] and "fault=none" in rep[2], f"status after: {rep[2]!r}", failures)
    model_checks(st, failures)
    check(abs(st["tick_rate_hz"] - 100.0) < 0.05, f"tick rate {st['tick_rate_hz']}", failures)
    return name, {"max_v_error_V": worst_v, "max_duty_error": worst_duty, "duration_s": dur, "cycles": st}, failures


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vrig", required=True)
    ap.add_argument("--elf", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--sma-params", help="the sma_params helper (upload test; default: next to vrig)")
    ap.add_argument("test", choices=["tracking_step", "tracking_sine", "bad_lines", "sensor_loss", "flood",
                                     "watchdog_boot", "model", "upload", "download", "console", "train", "plot", "hold"])
    args = ap.parse_args()
    global ELF
    ELF = args.elf
    os.makedirs(args.out, exist_ok=True)
    tests = {"tracking_step": lambda: t_tracking(args, "step"), "tracking_sine": lambda: t_tracking(args, "sine"),
             "bad_lines": lambda: t_bad_lines(args), "sensor_loss": lambda: t_sensor_loss(args),
             "watchdog_boot": lambda: t_watchdog_boot(args), "model": lambda: t_model(args),
             "upload": lambda: t_upload(args), "download": lambda: t_download(args), "console": lambda: t_console(args), "train": lambda: t_train(args),
             "plot": lambda: t_plot(args), "hold": lambda: t_hold(args)}
    name, summary, failures = tests.get(args.test, lambda: t_flood(args))()
    summary["failures"] = failures
    with open(os.path.join(args.out, name, "summary.json"), "w") as f:
        json.dump(summary, f, indent=2)
    short = {k: v for k, v in summary.items() if k not in ("cycles", "replies")}
    print(json.dumps(short, indent=None)[:2000])
    c = summary.get("cycles", {})
    print(f"cycles: control max {c.get('control_cycles_max')} mean {c.get('control_cycles_mean')}, "
          f"tick max {c.get('tick_cycles_max')}, jitter {c.get('tick_jitter_us')} us, "
          f"stack margin {c.get('stack_margin_bytes')} B")
    if failures:
        print(f"FAIL {name}: " + "; ".join(failures))
        return 1
    print(f"PASS {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
