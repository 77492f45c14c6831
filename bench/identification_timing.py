#!/usr/bin/env python3
"""Timing of the identification front ends on a 300 s log at 100 Hz (issue 11: fit <= 10 s,
discrepancy <= 60 s on 2 cores; several logs: proportional). The log: a wire that is not the
paper's (T_AS +7 K, h x1.15) with a latent heat of 2 J hidden, driven by voltage steps that heat
and cool it four times, 2 um noise. Prints a table, writes JSON (wall and CPU seconds).

  bench/identification_timing.py --build build [--json FILE]
"""
import argparse
import json
import os
import resource
import subprocess
import tempfile
import time


def timed(cmd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit("failed: %s\n%s" % (" ".join(cmd), r.stderr))
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    sim = os.path.join(a.build, "tools/host/sma_sim")
    fit = os.path.join(a.build, "tools/host/sma_fit")
    disc = os.path.join(a.build, "tools/discrepancy/sma_discrepancy")
    tmp = tempfile.mkdtemp()
    wire = os.path.join(tmp, "wire.json")
    with open(wire, "w") as f:
        json.dump({"T_AS": 57.2, "h": 190.0, "effects": {"latent_heat": {"L_J": 2.0}}}, f)
    logs = []
    for i, seed in enumerate((1, 2)):
        path = os.path.join(tmp, "run%d.csv" % (i + 1))
        subprocess.run([sim, "--params", wire, "--volt",
                        "steps:1.6@0,0@40,1.4@75,0@110,1.5@150,0@185,1.3@225,0@260", "--duration", "300",
                        "--dt", "0.01", "--noise", "0.002", "--seed", str(seed), "--out", path], check=True,
                       capture_output=True)
        logs.append(path)
    rows = []
    for name, cmd, limit in (
            ("fit, 1 log", [fit, logs[0], "--out", os.path.join(tmp, "f1")], 10.0),
            ("fit, 2 logs", [fit, logs[0], logs[1], "--out", os.path.join(tmp, "f2")], 20.0),
            ("discrepancy, 1 log", [disc, logs[0], "--out", os.path.join(tmp, "d1"), "--no-plots"], 60.0),
    ):
        wall, cpu = timed(cmd)
        rows.append({"run": name, "wall_s": wall, "cpu_s": cpu, "limit_s": limit, "ok": cpu <= limit})
    print("| run (300 s at 100 Hz each) | wall s | CPU s | limit s |\n|---|---|---|---|")
    for r in rows:
        print("| %s | %.1f | %.1f | %.0f |" % (r["run"], r["wall_s"], r["cpu_s"], r["limit_s"]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
