#!/usr/bin/env python3
"""The main job: the paper's two tests run by the real firmware in the virtual rig.

The firmware ELF runs unchanged in simavr (vrig) against the simulated plant with the rig's
sensor noise (2 um) and ADC/PWM quantisation; for each test (multi-step, Fig. 9-11; sine,
Fig. 12-13) and each controller (PID alone, the paper's inverse model + PID: `mode ffpid` with
`lead 0`, and the Uno's default for references: inverse + PID with the known future, `mode ffpid`)
it records the telemetry as a rig log, computes the error table with sma_metrics (the
definitions of the benchmark and the tests), and draws figures like the paper's. Also runs vrig's
cycle counter.
Gains: each controller runs each test with the gains the tuner found for it in rig-like
conditions (bench_tracking's JSON, sent with the console's `gains` command), as in the native
benchmark, and the default with the lead the tuner found with them (its `lead F`, the factor on
the board's lead of the kind); without that file, the firmware's defaults (tuned on the sine).

  paper_tests.py [--build DIR] [--out DIR] [--noise-mm X] [--elf ELF] [--gains-from JSON]
Writes OUT/{steps,sine}_{pid,ffpid,lead}.csv, OUT/paper_tests.json, OUT/fig09..fig13.png.
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools", "py"))
from sma import progress, riglog  # noqa: E402
TESTS = (("steps", "step", 150.0), ("sine", "sine", 150.0))
# (row, label, console mode, commands before the reference): the paper's pair, then the default.
MODES = (("pid", "PID alone", "pid", ()), ("ffpid", "inverse model + PID (paper, lead 0)", "ffpid", ("lead 0",)),
         ("lead", "inverse + PID, known future (default)", "ffpid", ()))


def tuned_row(path, test, mode):
    """The tuner's row for this test and controller in rig-like conditions (double), or None."""
    if not path or not os.path.isfile(path):
        return None
    with open(path) as f:
        runs = json.load(f)["runs"]
    for r in runs:
        if (r["test"] == ("sine" if test == "sine" else "multi-step") and r["condition"] == "rig-like"
                and r["controller"] == mode and r["scalar"] == "double"):
            return r
    return None


def tuned_gains(path, test, mode):
    """(kp, ki, kd) the tuner found for this test and controller in rig-like conditions."""
    r = tuned_row(path, test, mode)
    return (r["kp"], r["ki"], r["kd"]) if r else None


def lead_command(path, test):
    """(`lead F` for the lead the tuner found on this test, that lead in s), or None where it is
    the board's own, out of the console's range or unknown. `lead F` multiplies the board's lead
    of the reference's kind (`lead 1`, sma::lead_for: the tuner's row carries it as
    board_lead_s); F puts that lead, truncated to 10-ms ticks, on the tuner's tick: half a tick
    above it, so that the truncation of F's float lands on it."""
    r = tuned_row(path, test, "lead")
    if not r or not r.get("lead_s") or not r.get("board_lead_s"):
        return None
    ticks, board = round(r["lead_s"] * 100), round(r["board_lead_s"] * 100)
    if ticks == board or not 0 < ticks <= 2 * board:  # the board's own; the console's range 0..2
        return None
    return "lead %.7g" % min((ticks + 0.5) / board, 2.0), r["lead_s"]  # (2: exact in float)


def lead_seconds(path, test):
    """The lead the default runs with, s: the tuner's (sent, or the board's own), None where the
    board runs its own without a tuner's row to name it."""
    r = tuned_row(path, test, "lead")
    return r.get("lead_s") if r else None


def run_vrig(vrig, elf, mode, command, duration, log, noise, cycles, gains=None, pre=(), mcu=None, rig=()):
    """One run of the ELF in the virtual rig: telemetry on, `mode`, the `pre` commands (PID gains
    when `gains`), then the reference `command`; the log and the cycle counts written. `rig`: more
    vrig options (e.g. --plant b)."""
    pre = (["gains %.6g %.6g %.6g" % gains] if gains else []) + list(pre)
    script = log + ".script"
    with open(script, "w") as f:
        f.write(f"0.0 tele on\n0.02 mode {mode}\n")
        for i, c in enumerate(pre):
            f.write(f"{0.03 + 0.005 * i:g} {c}\n")
        f.write(f"0.05 {command}\n")
    cmd = [vrig, elf] + (["--mcu", mcu] if mcu else []) + [
        "--script", script, "--duration", str(duration + 0.2), "--log", log,
        "--noise-mm", str(noise), "--quiet", "--cycles-json", cycles] + list(rig)
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"vrig failed ({' '.join(cmd)}):\n{r.stderr[-2000:]}")


def scored_run(a, test, command, duration, tag, elf, mode, pre=(), mcu=None, rig=()):
    """run_vrig, then the whole-run metrics from the command on (sma_metrics) and the cycle
    counts: what the FIL comparisons (fil_preview, fil_lead) tabulate per run."""
    log = os.path.join(a.out, f"{test}_{tag}.csv")
    cyc = os.path.join(a.out, f"{test}_{tag}_cycles.json")
    run_vrig(a.vrig, elf, mode, command, duration, log, 0.002, cyc, pre=pre, mcu=mcu, rig=rig)
    d = read_log(log)
    start = float(d["t_s"][d["ref_mm"] > 0][0])  # the reference starts with the command
    m = metrics(a.metrics, log, test, start)
    with open(cyc) as f:
        m["cycles"] = json.load(f)
    return m


def read_log(path):
    """A rig log as {column: numpy array}, by the package's one reader (sma.riglog)."""
    return riglog.read(path).columns


def metrics(tool, log, test, start):
    r = subprocess.run([tool, log, "--test", "sine" if test == "sine" else "steps", "--start", f"{start:.3f}"],
                       capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(r.stderr)
    return json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=None)
    ap.add_argument("--elf", default=None, help="firmware ELF (default: BUILD/firmware/sma_firmware.elf)")
    ap.add_argument("--noise-mm", type=float, default=0.002)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2, help="runs at a time (default: cores)")
    ap.add_argument("--gains-from", default=None,
                    help="bench_tracking JSON (default: BUILD/bench-results/tracking.json if present)")
    a = ap.parse_args()
    out = a.out or os.path.join(a.build, "paper-tests")
    os.makedirs(out, exist_ok=True)
    vrig = os.path.join(a.build, "tools", "vrig", "vrig")
    elf = a.elf or os.path.join(a.build, "firmware", "sma_firmware.elf")
    tool = os.path.join(a.build, "tools", "host", "sma_metrics")
    for p in (vrig, elf, tool):
        if not os.path.isfile(p):
            sys.exit(f"missing {p}: build first (cmake --build {a.build})")

    gains_file = a.gains_from or os.path.join(a.build, "bench-results", "tracking.json")
    results = {}
    runs = [(test, command, duration, row) for test, command, duration in TESTS for row, _, _, _ in MODES]

    def one(test, command, duration, mode):
        log = os.path.join(out, f"{test}_{mode}.csv")
        t0 = time.time()
        cyc = os.path.join(out, f"{test}_{mode}_cycles.json")
        _, _, console_mode, pre = next(m for m in MODES if m[0] == mode)
        gains = tuned_gains(gains_file, test, mode)
        lead = lead_command(gains_file, test) if mode == "lead" and gains else None
        if lead:
            pre = pre + (lead[0],)
        run_vrig(vrig, elf, console_mode, command, duration, log, a.noise_mm, cyc, gains, pre=pre)
        d = read_log(log)
        start = float(d["t_s"][d["ref_mm"] > 0][0])  # the reference starts with the command
        m = metrics(tool, log, test, start)
        with open(cyc) as f:
            m["cycles"] = json.load(f)
        m["wall_s"] = round(time.time() - t0, 1)
        m["gains"] = gains or "firmware defaults"
        if mode == "lead" and gains and lead_seconds(gains_file, test):
            m["lead_s"] = lead_seconds(gains_file, test)
        return m

    print(f"firmware in the virtual rig: {len(runs)} runs of 150 s simulated (steps and sine x PID alone, "
          f"inverse model + PID and with the known future), {a.jobs} at a time; gains: "
          f"{gains_file if os.path.isfile(gains_file) else 'the firmware defaults (no ' + gains_file + ')'}",
          file=sys.stderr, flush=True)
    with progress.Progress("paper tests", total=len(runs)) as bar, \
            concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futs = {pool.submit(one, *r): r for r in runs}
        for fu in concurrent.futures.as_completed(futs):
            test, _, _, mode = futs[fu]
            results[f"{test}_{mode}"] = fu.result()
            bar.update(len(results), text=f"{test} {mode} done")

    print("\nThe firmware (ATmega328P ELF, float) in the virtual rig, 2 um sensor noise, errors on the "
          "measured position:\n")
    print("Whole run (the sine after its first period), phases with their transitions; the paper's "
          "heating-only figure last, labelled:\n")
    print("| test | controller | kp, ki, kd | max mm | RMS mm | max rise mm | max fall mm | RMS fall mm | "
          "wrong-way mm | settle max s | SSE mm | (paper) max heat mm | control cycles max/mean |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for test, _, _ in TESTS:
        for mode, label, _, _ in MODES:
            m = results[f"{test}_{mode}"]
            c = m["cycles"]
            g = m["gains"] if isinstance(m["gains"], str) else ", ".join("%.3g" % x for x in m["gains"])
            if "lead_s" in m:
                g += "; lead %g s" % m["lead_s"]
            print(f"| {test} | {label} | {g} | {m['max_mm']:.4f} | {m['rms_mm']:.4f} | {m['max_rise_mm']:.4f} | "
                  f"{m['max_fall_mm']:.4f} | {m['rms_fall_mm']:.4f} | {m['wrong_way_mm']:.4f} | "
                  f"{m['settle_max_s']:.2f} | {m['sse_mm']:.4f} | {m['max_heat_mm']:.4f} | "
                  f"{c['control_cycles_max']}/{c['control_cycles_mean']:.0f} |")
    for test, _, _ in TESTS:
        p, f = results[f"{test}_pid"]["max_heat_mm"], results[f"{test}_ffpid"]["max_heat_mm"]
        if p > 0:
            print(f"\n{test}: (paper-style, heating only) max |error| while heating, inverse + PID vs PID "
                  f"alone: {100 * (1 - f / p):+.1f} % (the paper: 51.4 % better on its sine)")
        p, f = results[f"{test}_pid"]["max_mm"], results[f"{test}_ffpid"]["max_mm"]
        if p > 0:
            print(f"{test}: whole run, max |error|, inverse + PID vs PID alone: {100 * (1 - f / p):+.1f} %")
        f = results[f"{test}_lead"]["max_mm"]
        if p > 0:
            print(f"{test}: whole run, max |error|, the default (known future) vs PID alone: {100 * (1 - f / p):+.1f} %")
    with open(os.path.join(out, "paper_tests.json"), "w") as f:
        json.dump(results, f, indent=2)
    plot(out, results)
    print(f"\nwrote {out}/paper_tests.json and fig09..fig13.png")


def plot(out, results=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    colors = {"pid": "tab:red", "ffpid": "tab:blue", "lead": "tab:green"}
    figs = (("fig09", "steps", "position", "Test 1: multi-step, position (paper Fig. 9)"),
            ("fig10", "steps", "error", "Test 1: tracking error (paper Fig. 10)"),
            ("fig11", "steps", "voltage", "Test 1: voltage across the wire (paper Fig. 11)"),
            ("fig12", "sine", "position", "Test 2: sine, position (paper Fig. 12)"),
            ("fig13", "sine", "error", "Test 2: tracking error (paper Fig. 13)"))
    for name, test, what, title in figs:
        fig, ax = plt.subplots(figsize=(10, 4.2))
        for mode, label, _, _ in MODES:
            d = read_log(os.path.join(out, f"{test}_{mode}.csv"))
            y = {"position": d["d_mm"], "error": d["ref_mm"] - d["d_mm"], "voltage": d["v_V"]}[what]
            if results and f"{test}_{mode}" in results:
                m = results[f"{test}_{mode}"]
                label += (f" (whole run: max {m['max_mm']:.3f}, RMS {m['rms_mm']:.3f} mm; rising max "
                          f"{m['max_rise_mm']:.3f}, falling max {m['max_fall_mm']:.3f}, wrong-way "
                          f"{m['wrong_way_mm']:.3f} mm)")
            ax.plot(d["t_s"], y, color=colors[mode], lw=1, label=label)
        if what == "position":
            ax.plot(d["t_s"], d["ref_mm"], "k--", lw=1, label="reference")
        ax.set_xlabel("time, s")
        ax.set_ylabel({"position": "displacement, mm", "error": "reference - position, mm", "voltage": "V"}[what])
        ax.set_title(title + " - firmware in the virtual rig")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(out, name + ".png"), dpi=90)
        plt.close(fig)


if __name__ == "__main__":
    main()
