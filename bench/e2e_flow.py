#!/usr/bin/env python3
"""End to end on the simulated rig (issue 7, item 4, model side): a wire that is not the paper's,
with an effect hidden in it, goes through the user flow with the project's tools only:

  1. the paper's training signal (faster slope) open loop       tools/sma sim --volt train
  2. identification                                              tools/sma fit
  3. the discrepancy workflow on the fitted model, on a second log with voltage holds, with
     the base's h, T_AS, T_AF refitted jointly                   tools/sma discrepancy --refit-base
  4. the paper's sine and multi-step, feedforward + PID, with the controller believing
     (a) the paper's parameters, (b) the fitted ones, (c) fitted + effects, (d) the truth
                                                                 tools/sma sim --model-params
and prints the error table (max |error| while heating, RMS; on the measured position) and writes
JSON. A benchmark, not a test: it measures how far the flow gets today (README "Status": the fit
absorbs the hidden convection into h and T_AF, so the fitted model controls only slightly better
than the paper's, far from the exact model).  e2e_flow.py [--out DIR]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SMA = os.path.join(ROOT, "tools", "sma")
# The wire: transformation 4 K higher, 15 % more convection, 10 % more stroke than the paper's,
# and heat loss that grows faster than linearly (hidden: the paper's model has no such term).
WIRE = {"T_AS": 54.0, "T_AF": 84.0, "h": 190.0, "g": 1.05,
        "effects": {"convection_nonlinear": {"beta_per_K": 0.006}}}


def sma(*args):
    r = subprocess.run([SMA, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"tools/sma {' '.join(args)} failed:\n{r.stderr[-3000:]}")
    return r.stdout


def metrics(log, test):
    tool = os.path.join(os.environ.get("SMA_BUILD_DIR") or os.path.join(ROOT, "build"), "tools", "host", "sma_metrics")
    r = subprocess.run([tool, log, "--test", test], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(r.stderr)
    return json.loads(r.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    out = a.out or tempfile.mkdtemp(prefix="sma_e2e_")
    os.makedirs(out, exist_ok=True)
    wire = os.path.join(out, "wire.json")
    with open(wire, "w") as f:
        json.dump(WIRE, f)
    paper = os.path.join(out, "paper.json")
    with open(paper, "w") as f:
        f.write("{}")
    print("1/4 training run (simulated rig, rig-like sensor)", file=sys.stderr)
    train = os.path.join(out, "train.csv")
    sma("sim", "--params", wire, "--volt", "train", "--train-slope", "0.03", "--rig-like", "--out", train)
    print("2/4 fit", file=sys.stderr)
    sma("fit", train, "--out", os.path.join(out, "fit"))
    print("3/4 discrepancy on a second log with holds at several voltages (what the report asks for)",
          file=sys.stderr)
    steps = os.path.join(out, "steps.csv")
    sma("sim", "--params", wire, "--volt", "steps:0@0,1.2@20,1.35@40,1.5@60,1.3@80,1.7@100,1.0@120,0.6@140,1.4@160,0@180",
        "--rig-like", "--out", steps)
    sma("discrepancy", steps, "--params", os.path.join(out, "fit", "params.json"), "--out",
        os.path.join(out, "disc"), "--no-plots", "--refit-base", "h,T_AS,T_AF")
    with open(os.path.join(out, "disc", "report.json")) as f:
        disc = json.load(f)
    models = (("paper's parameters", paper), ("fitted", os.path.join(out, "fit", "params.json")),
              ("fitted + effects", os.path.join(out, "disc", "params.json")), ("the true wire", wire))
    print("4/4 the paper's tests with each model", file=sys.stderr)
    table = {}
    for name, model in models:
        for ref, test in (("sine", "sine"), ("multistep", "steps")):
            log = os.path.join(out, f"{test}_{os.path.basename(model)}.csv")
            sma("sim", "--params", wire, "--model-params", model, "--ref", ref, "--rig-like", "--out", log)
            table[(name, test)] = metrics(log, test)
    added = ", ".join(e["name"] for e in disc["effects"]) or "nothing (the fit absorbed it)"
    print(f"\nHidden: convection_nonlinear; the discrepancy workflow added: {added}\n")
    print("| controller's model | sine max heat mm | sine RMS mm | multi-step max heat mm | multi-step RMS mm |")
    print("|---|---|---|---|---|")
    for name, _ in models:
        s, t = table[(name, "sine")], table[(name, "steps")]
        print(f"| {name} | {s['max_heat_mm']:.4f} | {s['rms_mm']:.4f} | {t['max_heat_mm']:.4f} | {t['rms_mm']:.4f} |")
    with open(os.path.join(out, "flow.json"), "w") as f:
        json.dump({f"{k[0]} / {k[1]}": v for k, v in table.items()}, f, indent=2)

    print(f"\nwrote {out}/flow.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
