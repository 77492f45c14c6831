#!/usr/bin/env python3
"""Firmware in the loop: inverse + PID with the known future (sma::LeadConfig: in both Uno images,
float and Q16.16, the default of `mode ffpid` on step, sine and traj) against PID alone and the
paper's inverse + PID (`lead 0`) on the same ELF, in the virtual rig (2 um noise).

    fil_lead.py --vrig BUILD/tools/vrig/vrig --elf BUILD/firmware/sma_firmware.elf \\
                --metrics BUILD/tools/host/sma_metrics --out DIR

Runs (`mode ffpid` / `mode pid`, the firmware's default gains): the paper's sine, 100 s (sma_metrics
scores the second period), and the multi-step's first 125 s (up-steps and the 0.8 -> 0.5 mm
down-step). Metrics of sma_metrics on the measured position, whole run (issue 13). Pass: on both
tests the lead's whole-run max and RMS below PID alone's and inverse + PID's; the sine within issue
13's max <= 0.12 mm and RMS <= 0.05 mm; the steps' RMS <= 0.05 mm and wrong-way after a step
<= 0.03 mm. Printed, not asserted (docs/control.md section 31): the wrong-way before a down-step
(the lead's minor-loop rise happens before the step) and the control section's cycles (the
budget test, bench/budgets.py, holds them). With --bound (bench_optimal_bound's JSON, written by
the benchmarks before CTest runs) it prints each controller's sine against the rig-like bound, on
the unrounded figures, and checks the lead's within issue 13's 1.5x (max and RMS; without a bound:
NOT CHECKED; docs/control.md section 42). With --plant b (or b-rpm) the wire in the rig is plant B,
written apart from the library (tools/vrig/rig_wire.hpp): the same checks, on a wire whose formulas
the firmware's model does not share; the bound is the library plant's and is not applied there.
Writes DIR/fil_lead.json.
"""
import argparse
import concurrent.futures
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from paper_tests import scored_run  # noqa: E402

RUNS = (("sine", "sine", 100.0), ("steps", "step", 125.0))
# (row, console mode, commands before the reference)
ROWS = (("lead", "ffpid", ()), ("pid", "pid", ()), ("ffpid", "ffpid", ("lead 0",)))


def run(a, test, command, duration, row, mode, pre):
    return scored_run(a, test, command, duration, row, a.elf, mode, pre=pre, rig=("--plant", a.plant))


def sine_bound(path):
    """The rig-like sine's bound of bench_optimal_bound's JSON, or None (with a note why)."""
    if not path:
        return None
    try:
        with open(path) as f:
            for b in json.load(f)["bounds"]:
                if b["test"] == "sine" and b["condition"] == "rig-like":
                    if all(isinstance(b.get(k), (int, float)) and math.isfinite(b[k]) and b[k] > 0
                           for k in ("max_mm", "rms_mm")):
                        return b
                    print(f"optimal bound: {path}: the rig-like sine's max_mm and rms_mm must be numbers > 0")
                    return None
        print(f"optimal bound: {path} has no rig-like sine")
    except (OSError, ValueError, KeyError, TypeError) as e:
        print(f"optimal bound: not read from {path} ({e.__class__.__name__}: {e}); the benchmarks write it")
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--vrig", required=True)
    ap.add_argument("--elf", required=True, help="an Uno image with the lead")
    ap.add_argument("--metrics", required=True, help="sma_metrics")
    ap.add_argument("--out", required=True)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--bound", help="bench_optimal_bound's JSON: print the sine against its rig-like bound")
    ap.add_argument("--plant", default="library", choices=("library", "b", "b-rpm"),
                    help="the wire in the rig: the library's plant or plant B (vrig --plant)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    res = {}
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futs = {pool.submit(run, a, t, c, d, row, mode, pre): (t, row) for t, c, d in RUNS for row, mode, pre in ROWS}
        for fu in concurrent.futures.as_completed(futs):
            t, row = futs[fu]
            res[f"{t}_{row}"] = fu.result()

    print("| test | controller | max mm | RMS mm | max rise | max fall | wrong-way after / before a step | SSE mm | "
          "control cycles max/mean |")
    print("|---|---|---|---|---|---|---|---|---|")
    labels = {"lead": "inverse + PID, known future", "pid": "PID alone", "ffpid": "inverse + PID (lead 0)"}
    for t, _, _ in RUNS:
        for row, _, _ in ROWS:
            r = res[f"{t}_{row}"]
            c = r["cycles"]
            print(f"| {t} | {labels[row]} | {r['max_mm']:.4f} | {r['rms_mm']:.4f} | {r['max_rise_mm']:.4f} | "
                  f"{r['max_fall_mm']:.4f} | {r['wrong_way_mm']:.4f} / {r['wrong_way_before_mm']:.4f} | "
                  f"{r['sse_mm']:.4f} | {c['control_cycles_max']}/{c['control_cycles_mean']:.0f} |")
    print(f"Wire in the rig: {a.plant}" + (" (plant B, written apart from the library)" if a.plant != "library" else ""))
    bound = sine_bound(a.bound) if a.plant == "library" else None
    if bound:
        print(f"Sine against the optimal bound (rig-like, {a.bound}): max {bound['max_mm']:.6f} / RMS "
              f"{bound['rms_mm']:.6f} mm; issue 13 asks within 1.5x")
        for row, _, _ in ROWS:
            r = res[f"sine_{row}"]
            rm, rr = r["max_mm"] / bound["max_mm"], r["rms_mm"] / bound["rms_mm"]
            res[f"sine_{row}"]["bound_ratio"] = {"max": rm, "rms": rr}
            print(f"  {labels[row]}: {rm:.3f}x / {rr:.3f}x" + ("" if max(rm, rr) <= 1.5 else "  (over 1.5x)"))
    with open(os.path.join(a.out, "fil_lead.json"), "w") as f:
        json.dump(res, f, indent=1)

    checks = []
    for t, _, _ in RUNS:
        l = res[f"{t}_lead"]
        for other in ("pid", "ffpid"):
            o = res[f"{t}_{other}"]
            checks.append((f"{t} max below {labels[other]}", l["max_mm"] < o["max_mm"]))
            checks.append((f"{t} RMS below {labels[other]}", l["rms_mm"] < o["rms_mm"]))
    s, p = res["sine_lead"], res["steps_lead"]
    checks += [
        ("sine max <= 0.12 mm", s["max_mm"] <= 0.12),
        ("sine RMS <= 0.05 mm", s["rms_mm"] <= 0.05),
        ("steps RMS <= 0.05 mm", p["rms_mm"] <= 0.05),
        ("steps wrong-way after a step <= 0.03 mm", p["wrong_way_mm"] <= 0.03),
    ]
    if bound:
        checks.append(("sine within 1.5x of the optimal bound (max and RMS)",
                       max(res["sine_lead"]["bound_ratio"].values()) <= 1.5))
    elif a.plant != "library":
        print("NOT APPLIED the optimal bound: it is computed on the library's plant, the wire here is plant B")
    else:
        print("NOT CHECKED sine within 1.5x of the optimal bound: no bound (--bound; scripts/bench writes it)")
    bad = [n for n, ok in checks if not ok]
    for n, ok in checks:
        print(("PASS " if ok else "FAIL ") + n)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
