#!/usr/bin/env python3
"""Firmware in the loop: the preview controller on the image that has it (the Mega 2560 image,
RIG_FEATURE_PREVIEW=1) against inverse + PID on the same ELF, in the virtual rig (2 um noise).

    fil_preview.py --vrig BUILD/tools/vrig/vrig --elf BUILD/firmware/sma_firmware_mega.elf \\
                   --metrics BUILD/tools/host/sma_metrics --out DIR

Runs (the controller chosen by `mode`, the trade-off by `cool 1`): the paper's sine, 100 s (the
scored period is the second: sma_metrics drops the first), and the multi-step's first 125 s (up-steps
and the 0.8 -> 0.5 mm down-step). Metrics of sma_metrics on the measured position, whole run with the
falling phase (issue 13). Pass: sine max <= 0.12 mm, RMS <= 0.05 mm, falling max <= 0.12 mm, each
below inverse + PID's (whose sine RMS is <= 0.1 mm); steps RMS <= 0.05 mm and below inverse + PID's, falling max below it,
wrong-way <= 0.03 mm; the preview's control section <= 16000 cycles in both; the plan passes of
every tick done before the next in both (the board runs the plan the host's board loop proves:
Board::plan_passes() a tick, Board::plan_short; the telemetry row after the passes,
docs/control.md section 22) and no tick late by more than 50 us; with --bound (bench_optimal_bound's
JSON, written by the benchmarks before CTest runs) the sine within issue 13's 1.5x of the rig-like
bound, max and RMS (without it: NOT CHECKED). Prints the table (with the
cycle, from the tick's start, by which the worst tick's passes were done: the margin to the next
tick, asserted >= 16 k of 160 k cycles, docs/control.md section 43) and writes
DIR/fil_preview.json.
"""
import argparse
import concurrent.futures
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fil_lead import sine_bound  # noqa: E402
from paper_tests import scored_run  # noqa: E402

RUNS = (("sine", "sine", 100.0), ("steps", "step", 125.0))
MODES = (("preview", "preview"), ("ffpid", "inverse + PID"))


def run(a, test, command, duration, mode):
    # (`lead 0`: the paper's inverse + PID; the image's `mode ffpid` adds the known future.)
    return scored_run(a, test, command, duration, mode, a.elf, mode, pre=["cool 1", "lead 0"], mcu=a.mcu)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--vrig", required=True)
    ap.add_argument("--elf", required=True)
    ap.add_argument("--mcu", default="atmega2560")
    ap.add_argument("--metrics", required=True, help="sma_metrics")
    ap.add_argument("--out", required=True)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--bound", help="bench_optimal_bound's JSON: check the sine within 1.5x of its rig-like bound")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    res = {}
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futs = {pool.submit(run, a, t, c, d, m): (t, m) for t, c, d in RUNS for m, _ in MODES}
        for fu in concurrent.futures.as_completed(futs):
            t, m = futs[fu]
            res[f"{t}_{m}"] = fu.result()

    print("| test | controller | max mm | RMS mm | max rise | max fall | wrong-way after / before a step | SSE mm | "
          "control cycles max/mean | plan cut short (passes done by, worst, of the tick's cycles) | tick jitter us |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for t, _, _ in RUNS:
        for m, label in MODES:
            r = res[f"{t}_{m}"]
            c = r["cycles"]
            print(f"| {t} | {label} | {r['max_mm']:.4f} | {r['rms_mm']:.4f} | {r['max_rise_mm']:.4f} | "
                  f"{r['max_fall_mm']:.4f} | {r['wrong_way_mm']:.4f} / {r['wrong_way_before_mm']:.4f} | {r['sse_mm']:.4f} | "
                  f"{c['control_cycles_max']}/{c['control_cycles_mean']:.0f} | {c['plan_short_ticks']} "
                  f"({c.get('plan_done_cycles_max', 0)} of {c.get('cycles_per_tick_budget', 0)}) | {c['tick_jitter_us']:.1f} |")
    bound = sine_bound(a.bound)
    if bound:
        sp = res["sine_preview"]
        sp["bound_ratio"] = {"max": sp["max_mm"] / bound["max_mm"], "rms": sp["rms_mm"] / bound["rms_mm"]}
        print(f"Sine against the optimal bound (rig-like, {a.bound}): max {bound['max_mm']:.6f} / RMS "
              f"{bound['rms_mm']:.6f} mm; the preview {sp['bound_ratio']['max']:.3f}x / "
              f"{sp['bound_ratio']['rms']:.3f}x; issue 13 asks within 1.5x")
    with open(os.path.join(a.out, "fil_preview.json"), "w") as f:
        json.dump(res, f, indent=1)

    s, sf = res["sine_preview"], res["sine_ffpid"]
    p, pf = res["steps_preview"], res["steps_ffpid"]
    checks = [
        ("sine max <= 0.12 mm", s["max_mm"] <= 0.12),
        ("sine RMS <= 0.05 mm", s["rms_mm"] <= 0.05),
        ("sine falling max <= 0.12 mm", s["max_fall_mm"] <= 0.12),
        # The comparison row itself tracks (main: RMS 0.074 mm; a wire never heated: 0.48 mm, as a
        # layout of the Board's members made the Mega's Controller put out 0 V, docs/control.md
        # section 22).
        ("inverse + PID tracks the sine: RMS <= 0.1 mm", sf["rms_mm"] <= 0.1),
        ("sine max below inverse + PID", s["max_mm"] < sf["max_mm"]),
        ("sine RMS below inverse + PID", s["rms_mm"] < sf["rms_mm"]),
        ("sine falling max below inverse + PID", s["max_fall_mm"] < sf["max_fall_mm"]),
        ("steps RMS <= 0.05 mm", p["rms_mm"] <= 0.05),
        ("steps RMS below inverse + PID", p["rms_mm"] < pf["rms_mm"]),
        ("steps falling max below inverse + PID", p["max_fall_mm"] < pf["max_fall_mm"]),
        ("steps wrong-way <= 0.03 mm", p["wrong_way_mm"] <= 0.03),
        # Past a held setpoint away from the next one (the minor-loop rise before a down-step).
        ("steps wrong-way before a step <= 0.03 mm", p["wrong_way_before_mm"] <= 0.03),
        # The preview's tick within the one-image budget (issue 12: <= 16000 cycles float), on
        # the Mega image (3-byte calls: slower than the Uno on the same code).
        ("sine control section <= 16000 cycles", s["cycles"]["control_cycles_max"] <= 16000),
        ("steps control section <= 16000 cycles", p["cycles"]["control_cycles_max"] <= 16000),
        # The tick's plan passes done before the next tick: the board runs the host's plan (the
        # telemetry row after the passes, or in the next tick when they leave no time for it).
        ("sine: no tick cut the plan short", s["cycles"]["plan_short_ticks"] == 0),
        ("steps: no tick cut the plan short", p["cycles"]["plan_short_ticks"] == 0),
        # ... with room to spare: 1 ms (16 k cycles) after the worst tick's passes, so that a
        # change of the image's code layout does not decide it (docs/control.md section 43).
        ("sine: the worst tick's passes done >= 1 ms before the next tick",
         s["cycles"]["plan_done_cycles_max"] <= s["cycles"]["cycles_per_tick_budget"] - 16000),
        ("steps: the worst tick's passes done >= 1 ms before the next tick",
         p["cycles"]["plan_done_cycles_max"] <= p["cycles"]["cycles_per_tick_budget"] - 16000),
        # ... without making a tick late: the row waits rather than push the next tick.
        ("sine: tick jitter <= 50 us", s["cycles"]["tick_jitter_us"] <= 50.0),
        ("steps: tick jitter <= 50 us", p["cycles"]["tick_jitter_us"] <= 50.0),
    ]
    if bound:
        checks.append(("sine within 1.5x of the optimal bound (max and RMS)", max(s["bound_ratio"].values()) <= 1.5))
    else:
        print("NOT CHECKED sine within 1.5x of the optimal bound: no bound (--bound; scripts/bench writes it)")
    bad = [n for n, ok in checks if not ok]
    for n, ok in checks:
        print(("PASS " if ok else "FAIL ") + n)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
