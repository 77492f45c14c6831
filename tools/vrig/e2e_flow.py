#!/usr/bin/env python3
"""Your rig, your model (issue 7): the whole user flow, end to end, through the real firmware.

The virtual rig's wire is not the paper's (transformation 4 K higher, h 190 instead of 165 W/m^2K,
5 % more stroke: WIRE) and hides an effect the paper's model lacks (heat loss that grows faster than linearly
with the temperature rise). Everything goes through the project's own tools, as a user would:

  1. training run: the one image (sma_firmware.elf) in the virtual rig, driven over
     its pseudo-terminal by   tools/sma console --send 'tele on' --send 'tlim 140' --send
                              'train S' --record train.csv --until 'train done'
  2. identification:          tools/sma fit train.csv
  3. what is missing:         tools/sma discrepancy train.csv --params fit/params.json
                              --refit-base all
  4. on the board:            tools/sma upload PARAMS.json --port PTY   (main image, its EEPROM
                              kept in a file, read back and verified by upload)
  5. the paper's sine and multi-step (the paper's inverse model + PID: `lead 0`, the gains of GAINS;
     and the image's default, inverse + PID with the known future, the firmware's gains), run by
     the main image with that EEPROM, for four models on the board: none uploaded (the paper's
     parameters, the firmware's fallback), the fitted one, fitted + effects, and the true wire
     (the same controller on a plant that matches its model exactly).
  6. the same tests with the preview controller, the default for references on the image that
     has it (sma_firmware_mega.elf), for the fitted, fitted + effects and true models, uploaded
     in the run's script (pbegin / pset / pcommit, the lines `sma upload` sends): whole-run
     errors, the wrong-way excursion and the steady-state error of a model that is not the wire.

Prints the error tables (inverse + PID: max and RMS |error| while heating, overall RMS; the
preview: whole run, falling half, wrong way, steady state; on the measured position), writes
OUT/e2e_flow.json, OUT/e2e_flow.md and OUT/e2e_flow.png. With --check it is a test: exit 1
unless the discrepancy names the hidden effect, fitted + effects is clearly best and close to
the true wire's result with inverse + PID and with the image's default (whole-run RMS; the
default within DEFAULT_LIMITS), and the preview with fitted + effects meets PREVIEW_LIMITS on
the multi-step.

  e2e_flow.py [--build DIR] [--out DIR] [--speed X] [--slope V/S] [--jobs N] [--check]
              [--preview-only]   (step 6 alone, on the fit and discrepancy of an earlier run in OUT)
"""
import argparse
import concurrent.futures
import json
import os
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from paper_tests import read_log  # noqa: E402  (a rig log as {column: numpy array})
from sma import progress  # noqa: E402  (on sys.path through paper_tests)
from pty_board import PtyBoard  # noqa: E402
SMA = os.path.join(ROOT, "tools", "sma")
# The user's wire: transformation 4 K higher (T_AS, T_AF), 15 % more convection (h), 5 % more
# stroke (g) than the paper's, and a hidden non-linear convection (the paper's model is linear).
WIRE = {"T_AS": 54.0, "T_AF": 84.0, "h": 190.0, "g": 1.05,
        "effects": {"convection_nonlinear": {"beta_per_K": 0.006}}}
HIDDEN = "convection_nonlinear"
TESTS = (("sine", "sine", 150.0), ("steps", "step", 150.0))
# The PID gains of each test, the same for every model: the sine's are the firmware's defaults
# (the tuner's sine optimum, bench_tracking); on steps nearly feedforward alone (the tuner's step
# optimum is at or near zero gains): a PID that does not cool a wire on its heating branch
# (README, Model choices) would otherwise lock in whatever overshoot the first second leaves,
# and the table would measure that, not the model.
GAINS = {"sine": (12.1, 3.125, 0.0), "steps": (0.03125, 0.0, 0.064)}
MODELS = (("paper", "paper's parameters (nothing uploaded)"), ("fitted", "fitted"),
          ("effects", "fitted + effects"), ("true", "the true wire (model = plant)"))
# --check: "clearly best" and "close to the exact model", on max and RMS |error| while heating.
CLEARLY_BETTER = 0.75   # at most this fraction of the better of (paper, fitted)
CLOSE_FACTOR, CLOSE_MM = 1.25, 0.003  # at most 1.25 x the true wire's + 3 um (1.5 ADC steps)
# Step 6: the preview on the image that has it, with the models a user has after step 3.
PREVIEW_MODELS = (("fitted", "fitted"), ("effects", "fitted + effects"), ("true", "the true wire (model = plant)"))
# The preview's sine runs two periods (the metrics skip the first), as in fil_preview.
PREVIEW_TESTS = (("sine", "sine", 100.0), ("steps", "step", 150.0))
# --check on the multi-step with fitted + effects (issue 13: whole-run RMS, wrong way after a
# down-step, zero steady-state error with a model that is not the wire: 10 um = 5 ADC steps).
PREVIEW_LIMITS = {"rms_mm": 0.05, "wrong_way_mm": 0.03, "sse_mm": 0.01}
# --check on the image's default (the known future) with fitted + effects, whole run (issue 13's
# sine and multi-step limits; its steady-state error is reported: 10-12 um with this model and
# the true wire's, the default gains' locked-in overshoot of an up-step).
DEFAULT_LIMITS = {("sine", "max_mm"): 0.12, ("sine", "rms_mm"): 0.05, ("steps", "rms_mm"): 0.05,
                  ("steps", "wrong_way_mm"): 0.03}


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def run(cmd, what, live=False, **kw):
    """Runs a step; live: its stderr (progress bars, messages) goes straight to ours."""
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=None if live else subprocess.PIPE, text=True, **kw)
    if r.returncode != 0:
        sys.exit(f"{what} failed (exit {r.returncode}): {' '.join(cmd)}\n{r.stdout[-1500:]}{(r.stderr or '')[-3000:]}")
    return r


def training_duration(build, slope):
    """The training plan's length (sma::TrainingPlan::duration, as sma_sim reports it)."""
    import tempfile
    sim = os.path.join(build, "tools", "host", "sma_sim")
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "plan.csv")
        run([sim, "--volt", "train", "--train-slope", f"{slope:g}", "--dt", "1", "--out", out], "sma_sim")
        return read_log(out)["t_s"][-1] + 1.0


def paper_test(a, model, ee, test, command, duration, default=False):
    """One of the paper's tests by the main image with `ee` as its EEPROM; -> metrics.
    `default`: the image's own controller for the reference and its gains (inverse + PID with the
    known future), else the paper's inverse + PID with the gains of GAINS."""
    name = f"{test}_{model}" + ("_default" if default else "")
    log_path = os.path.join(a.out, name + ".csv")
    script = log_path + ".script"
    with open(script, "w") as f:
        # (`lead 0`: the paper's inverse + PID, the controller these models are compared on; the
        # image's default for references adds the known future.)
        if default:
            f.write("0.0 tele on\n0.05 %s\n" % command)
        else:
            f.write("0.0 tele on\n0.02 mode ffpid\n0.03 gains %g %g %g\n0.04 lead 0\n0.05 %s\n" % (*GAINS[test], command))
    ee_copy = os.path.join(a.out, name + ".eeprom")  # a run saves its EEPROM at the end: one each
    if os.path.exists(ee):
        shutil.copy(ee, ee_copy)
    elif os.path.exists(ee_copy):
        os.remove(ee_copy)
    run([a.vrig, a.elf, "--script", script, "--duration", f"{duration + 0.2:g}", "--log", log_path,
         "--params", a.wire, "--noise-mm", "0.002", "--eeprom", ee_copy, "--quiet"], f"vrig {name}")
    d = read_log(log_path)
    start = float(d["t_s"][d["ref_mm"] > 0][0])
    r = run([a.metrics, log_path, "--test", "sine" if test == "sine" else "steps", "--start", f"{start:.3f}"],
            "sma_metrics")
    return json.loads(r.stdout)


def preview_test(a, model, params, test, command, duration):
    """One of the paper's tests by the preview image, `params` uploaded in the run's script
    (the lines `sma upload` sends, without the read-back); -> metrics."""
    sys.path.insert(0, os.path.join(ROOT, "tools", "py"))
    from sma.upload import pset_line, read_keys
    name = f"preview_{test}_{model}"
    log_path = os.path.join(a.out, name + ".csv")
    script = log_path + ".script"
    lines = ["pbegin"] + [pset_line(k, v) for k, v in read_keys(params, a.params_tool)] + ["pcommit"]
    t = 0.05
    with open(script, "w") as f:
        for ln in lines:
            f.write(f"{t:.2f} {ln}\n")
            t += 0.05
        start = t + 0.2
        f.write(f"{start - 0.1:.2f} tele on\n{start - 0.05:.2f} mode preview\n{start:.2f} {command}\n")
    r = run([a.vrig, a.mega_elf, "--mcu", "atmega2560", "--script", script, "--duration", f"{start + duration + 0.2:g}",
             "--log", log_path, "--params", a.wire, "--noise-mm", "0.002", "--stamp"], f"vrig {name}")
    replies = [ln for ln in r.stdout.splitlines() if "] OK p" in ln or "] ERR" in ln]
    if not any("OK pcommit" in ln for ln in replies) or any("ERR" in ln for ln in replies):
        sys.exit(f"{name}: the upload was refused: {replies}")
    d = read_log(log_path)
    t0 = float(d["t_s"][d["ref_mm"] > 0][0])
    m = run([a.metrics, log_path, "--test", "sine" if test == "sine" else "steps", "--start", f"{t0:.3f}"],
            "sma_metrics")
    return json.loads(m.stdout)


def preview_stage(a, sources):
    """Step 6: the preview with each model; -> (results, table lines, failures)."""
    log(f"6/6 the preview (Mega image) with each model ({len(PREVIEW_MODELS) * len(PREVIEW_TESTS)} runs) ...")
    results = {}
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futs = {(m, t): pool.submit(preview_test, a, m, sources[m], t, c, d)
                for m, _ in PREVIEW_MODELS for t, c, d in PREVIEW_TESTS}
        with progress.Progress("6/6 the preview's tests", total=len(futs)) as bar:
            for fu in concurrent.futures.as_completed(futs.values()):
                fu.result()
                bar.update(bar.done + 1)
        for k, fu in futs.items():
            results[k] = fu.result()
    lines = ["", "The preview controller (the default for references on the Mega image), whole run:", "",
             "| model on the board | sine max mm | sine RMS mm | sine max falling mm | multi-step RMS mm | "
             "multi-step max falling mm | wrong way mm | steady state mm |", "|---|---|---|---|---|---|---|---|"]
    for m, label in PREVIEW_MODELS:
        s, t = results[(m, "sine")], results[(m, "steps")]
        lines.append(f"| {label} | {s['max_mm']:.4f} | {s['rms_mm']:.4f} | {s['max_fall_mm']:.4f} | "
                     f"{t['rms_mm']:.4f} | {t['max_fall_mm']:.4f} | {t['wrong_way_mm']:.4f} | {t['sse_mm']:.4f} |")
    failures = [f"preview steps {k} with fitted + effects: {results[('effects', 'steps')][k]:.4f} > {lim:g} mm"
                for k, lim in PREVIEW_LIMITS.items() if not results[("effects", "steps")][k] <= lim]
    return results, lines, failures


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--out", default=None, help="default: BUILD/e2e-flow")
    ap.add_argument("--speed", type=float, default=8.0,
                    help="virtual rig speed over the console (x wall-clock; simavr reaches ~6-8)")
    ap.add_argument("--slope", type=float, default=0.06, help="training ramp slope, V/s (paper: 0.00588)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--check", action="store_true", help="fail unless the flow reaches its goal")
    ap.add_argument("--no-plots", action="store_true")
    ap.add_argument("--preview-only", action="store_true",
                    help="step 6 alone, on OUT/fit and OUT/disc of an earlier run")
    a = ap.parse_args()
    a.out = os.path.abspath(a.out or os.path.join(a.build, "e2e-flow"))
    os.makedirs(a.out, exist_ok=True)
    a.vrig = os.path.join(a.build, "tools", "vrig", "vrig")
    a.elf = os.path.join(a.build, "firmware", "sma_firmware.elf")
    train_elf = a.elf  # the one image has the training run
    a.metrics = os.path.join(a.build, "tools", "host", "sma_metrics")
    a.mega_elf = os.path.join(a.build, "firmware", "sma_firmware_mega.elf")
    a.params_tool = os.path.join(a.build, "tools", "vrig", "sma_params")
    for p in (a.vrig, a.elf, train_elf, a.metrics, a.mega_elf, a.params_tool):
        if not os.path.isfile(p):
            sys.exit(f"missing {p}: build first (cmake --build {a.build})")
    env = dict(os.environ, SMA_BUILD_DIR=a.build)
    a.wire = os.path.join(a.out, "wire.json")
    with open(a.wire, "w") as f:
        json.dump(WIRE, f, indent=1)
    t_start = time.time()
    if a.preview_only:
        fit, disc = os.path.join(a.out, "fit"), os.path.join(a.out, "disc")
        sources = {"fitted": os.path.join(fit, "params.json"), "effects": os.path.join(disc, "params.json"),
                   "true": a.wire}
        _, lines, failures = preview_stage(a, sources)
        print("\n".join(lines))
        for msg in failures:
            log("FAIL: " + msg)
        return 1 if (a.check and failures) else 0

    # 1. the training run, over the console
    dur = training_duration(a.build, a.slope)
    log(f"1/6 training run: the firmware in the virtual rig, {dur:.0f} s of rig time at up to {a.speed:g}x "
        f"(~{dur / a.speed / 60:.0f} min or more), over the console ...")
    train = os.path.join(a.out, "train.csv")
    with PtyBoard(a.vrig, train_elf, dur + 120, a.speed, ["--params", a.wire, "--noise-mm", "0.002"]) as board:
        # tlim 140: until the user's model is on the board, the temperature the latch watches is
        # the paper's wire's, which the training's 2 V first peak takes to ~132 degC (this wire,
        # with more heat loss, reaches ~88 degC); the default 110 degC limit would end the run.
        # The wall-clock bound allows a rig at half real time (a loaded machine: the run ends at
        # "train done", and the virtual rig itself stops after dur + 120 s of rig time).
        run([sys.executable, SMA, "console", "--port", board.port, "--send", "tele on", "--send", "tlim 140",
             "--send", f"train {a.slope:g}", "--record", train, "--until", "train done", "--duration",
             f"{(dur + 120) * 2.0:.0f}", "--progress", f"{dur:.0f}", "--timeout", "5", "-q"],
            "tools/sma console (training run)", live=True, env=env)

    # 2. fit, 3. discrepancy
    log("2/6 tools/sma fit train.csv ...")
    fit = os.path.join(a.out, "fit")
    run([SMA, "fit", train, "--out", fit], "tools/sma fit", live=True, env=env)
    log("3/6 tools/sma discrepancy train.csv --params fit/params.json --refit-base all ...")
    disc = os.path.join(a.out, "disc")
    run([SMA, "discrepancy", train, "--params", os.path.join(fit, "params.json"), "--refit-base", "all",
         "--out", disc], "tools/sma discrepancy", live=True, env=env)
    with open(os.path.join(disc, "report.json")) as f:
        report = json.load(f)
    added = [e["name"] for e in report["effects"]]

    # 4. upload each model to its own board EEPROM
    sources = {"fitted": os.path.join(fit, "params.json"), "effects": os.path.join(disc, "params.json"),
               "true": a.wire}
    eeprom = {m: os.path.join(a.out, f"eeprom_{m}.bin") for m, _ in MODELS}
    for m in eeprom.values():
        if os.path.exists(m):
            os.remove(m)  # a blank EEPROM: the firmware falls back to the paper's parameters
    for i, (model, src) in enumerate(sources.items()):
        log(f"4/6 tools/sma upload {os.path.relpath(src, a.out)} ({i + 1}/3) ...")
        with PtyBoard(a.vrig, a.elf, 600, a.speed, ["--eeprom", eeprom[model]]) as board:
            up = run([SMA, "upload", src, "--port", board.port], "tools/sma upload", env=env)
        with open(os.path.join(a.out, f"upload_{model}.txt"), "w") as f:
            f.write(up.stdout + up.stderr)

    # 5. the paper's tests with each model on the board
    log(f"5/6 the paper's sine and multi-step with each model on the board ({2 * len(MODELS) * len(TESTS)} runs: "
        f"the paper's inverse + PID and the image's default, "
        f"{a.jobs} at a time) ...")
    results = {}
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futs = {(m, t): pool.submit(paper_test, a, m, eeprom[m], t, c, d) for m, _ in MODELS for t, c, d in TESTS}
        # The image's default (the known future, the firmware's gains) with the same models.
        futs.update({(m, t, "default"): pool.submit(paper_test, a, m, eeprom[m], t, c, d, True)
                     for m, _ in MODELS for t, c, d in TESTS})
        with progress.Progress("5/6 paper's tests", total=len(futs)) as bar:
            for fu in concurrent.futures.as_completed(futs.values()):
                fu.result()
                bar.update(bar.done + 1)
        for k, fu in futs.items():
            results[k] = fu.result()

    lines = [f"Hidden in the wire: `{HIDDEN}`; the discrepancy workflow added: "
             f"{', '.join(f'`{n}`' for n in added) or 'nothing'}.", "",
             "| model on the board | sine max heating mm | sine RMS heating mm | sine RMS mm | multi-step max heating mm | "
             "multi-step RMS heating mm | multi-step RMS mm |", "|---|---|---|---|---|---|---|"]
    for m, label in MODELS:
        s, t = results[(m, "sine")], results[(m, "steps")]
        lines.append(f"| {label} | {s['max_heat_mm']:.4f} | {s['rms_heat_mm']:.4f} | {s['rms_mm']:.4f} | "
                     f"{t['max_heat_mm']:.4f} | {t['rms_heat_mm']:.4f} | {t['rms_mm']:.4f} |")

    lines += ["", "The image's default for references (inverse + PID with the known future, the firmware's "
              "gains), whole run, the same models:", "",
              "| model on the board | sine max mm | sine RMS mm | multi-step max mm | multi-step RMS mm | "
              "wrong way after / before a step mm | steady state mm |", "|---|---|---|---|---|---|---|"]
    for m, label in MODELS:
        s, t = results[(m, "sine", "default")], results[(m, "steps", "default")]
        lines.append(f"| {label} | {s['max_mm']:.4f} | {s['rms_mm']:.4f} | {t['max_mm']:.4f} | {t['rms_mm']:.4f} | "
                     f"{t['wrong_way_mm']:.4f} / {t['wrong_way_before_mm']:.4f} | {t['sse_mm']:.4f} |")

    failures = []
    if HIDDEN not in added:
        failures.append(f"the discrepancy workflow named {added}, not {HIDDEN}")
    for test, _, _ in TESTS:
        for key in ("max_heat_mm", "rms_heat_mm"):
            fx = results[("effects", test)][key]
            others = min(results[("paper", test)][key], results[("fitted", test)][key])
            true = results[("true", test)][key]
            if not fx <= CLEARLY_BETTER * others:
                failures.append(f"{test} {key}: fitted + effects {fx:.4f} not clearly below paper/fitted {others:.4f}")
            if not fx <= CLOSE_FACTOR * true + CLOSE_MM:
                failures.append(f"{test} {key}: fitted + effects {fx:.4f} not close to the true wire's {true:.4f}")
    # The default: the same ordering on the whole run's RMS (a more exact model never tracks
    # worse: fitted + effects clearly below paper / fitted, the true wire's close to it either
    # way), and issue 13's limits with fitted + effects.
    for test, _, _ in TESTS:
        fx = results[("effects", test, "default")]["rms_mm"]
        others = min(results[("paper", test, "default")]["rms_mm"], results[("fitted", test, "default")]["rms_mm"])
        true = results[("true", test, "default")]["rms_mm"]
        if not fx <= CLEARLY_BETTER * others:
            failures.append(f"default {test} RMS: fitted + effects {fx:.4f} not clearly below paper/fitted {others:.4f}")
        if not (fx <= CLOSE_FACTOR * true + CLOSE_MM and true <= CLOSE_FACTOR * fx + CLOSE_MM):
            failures.append(f"default {test} RMS: fitted + effects {fx:.4f} not close to the true wire's {true:.4f}")
    for (test, key), lim in DEFAULT_LIMITS.items():
        v = results[("effects", test, "default")][key]
        if not v <= lim:
            failures.append(f"default {test} {key} with fitted + effects: {v:.4f} > {lim:g} mm")

    # 6. the preview with the same models
    preview, preview_lines, preview_failures = preview_stage(a, sources)
    failures += preview_failures
    table = "\n".join(lines + preview_lines)
    print(table)
    with open(os.path.join(a.out, "e2e_flow.md"), "w") as f:
        f.write(table + "\n")
    with open(os.path.join(a.out, "e2e_flow.json"), "w") as f:
        json.dump({"wire": WIRE, "training_slope_V_per_s": a.slope, "effects_added": added,
                   "fitted_params": sources["fitted"], "corrected_params": sources["effects"],
                   "results": {"/".join(k): v for k, v in results.items()},
                   "preview": {f"{m}/{t}": v for (m, t), v in preview.items()},
                   "failures": failures, "wall_s": round(time.time() - t_start, 1)}, f, indent=2)
    if not a.no_plots:
        plot(a)
    log(f"wrote {a.out}/e2e_flow.json, e2e_flow.md{'' if a.no_plots else ', e2e_flow.png'} "
        f"({time.time() - t_start:.0f} s)")
    for msg in failures:
        log("FAIL: " + msg)
    return 1 if (a.check and failures) else 0


def plot(a):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(3, 2, figsize=(12, 10))
    for col, (test, _, _) in enumerate(TESTS):
        ax, ax_e = axes[0][col], axes[1][col]
        for i, (m, label) in enumerate(MODELS):
            d = read_log(os.path.join(a.out, f"{test}_{m}.csv"))
            on = d["ref_mm"] > 0
            t = d["t_s"][on] - d["t_s"][on][0]
            if i == 0:
                ax.plot(t, d["ref_mm"][on], "k--", lw=1, label="reference")
            ax.plot(t, d["d_mm"][on], lw=0.8, label=label)
            ax_e.plot(t, d["ref_mm"][on] - d["d_mm"][on], lw=0.8, label=label)
        ax.set_title(f"{test}: the firmware with each model on the board")
        ax.set_ylabel("displacement, mm")
        ax_e.set_ylabel("reference - measured, mm")
        ax_e.set_xlabel("time, s")
        ax_e.set_ylim(-0.1, 0.1)
        ax.legend(fontsize=7)
        ax_p = axes[2][col]
        for i, (m, label) in enumerate(PREVIEW_MODELS):
            d = read_log(os.path.join(a.out, f"preview_{test}_{m}.csv"))
            on = d["ref_mm"] > 0
            t = d["t_s"][on] - d["t_s"][on][0]
            if i == 0:
                ax_p.plot(t, d["ref_mm"][on], "k--", lw=1, label="reference")
            ax_p.plot(t, d["d_mm"][on], lw=0.8, label=label)
        ax_p.set_title(f"{test}: the preview controller (Mega image) with each model")
        ax_p.set_ylabel("displacement, mm")
        ax_p.set_xlabel("time, s")
        ax_p.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "e2e_flow.png"), dpi=110)


if __name__ == "__main__":
    sys.exit(main())
