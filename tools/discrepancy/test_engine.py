#!/usr/bin/env python3
"""One identification engine (docs/identification.md), tested through its front ends (run by
CTest): `sma_sim --replay` and the discrepancy's nominal simulation give the same trace for one
params file and one log (one replay, one initial-state rule, no voltage clamp); several logs for
one fit, with a sensor zero per run; bad input named (different sample rates or column sets, a
log that never cools given to a fit of the cooling parameters, an unknown key)."""
import csv
import json
import os
import subprocess
import sys
import tempfile

SIM, FIT, DISC = sys.argv[1], sys.argv[2], sys.argv[3]


def run(*args):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True)


def ok(*args):
    r = run(*args)
    assert r.returncode == 0, (args, r.stdout, r.stderr)
    return r


def fails_with(args, *needles):
    r = run(*args)
    assert r.returncode != 0, (args, r.stdout)
    for n in needles:
        assert n in r.stderr, (args, n, r.stderr)


def read_csv(path):
    with open(path) as f:
        rows = [l for l in f if not l.startswith("#")]
    return list(csv.DictReader(rows))


def write_log(path, rows, cols=("t_s", "v_V", "d_mm")):
    with open(path, "w") as f:
        f.write(",".join(cols) + "\n")
        for r in rows:
            f.write(",".join("%.6g" % r[c] for c in cols) + "\n")


def main():
    tmp = tempfile.mkdtemp()
    # A wire with a sensor zero of 0.7 mm, driven above the 5 V the plant's PWM supply defaults
    # to (a bench on a 12 V supply): both tools must run the same model on it.
    params = os.path.join(tmp, "wire.json")
    with open(params, "w") as f:
        json.dump({"R": 8.0, "effects": {"sensor_calibration": {"gain": 1.0, "offset_mm": 0.7}}}, f)
    volt = os.path.join(tmp, "volt.csv")
    ok(SIM, "--params", params, "--volt", "steps:0@0,6.5@5,0@35,5.5@60,0@80", "--duration", "110", "--dt", "0.02",
       "--v-supply", "12", "--noise", "0.002", "--seed", "3", "--out", volt)
    rows = read_csv(volt)
    log = os.path.join(tmp, "run.csv")
    write_log(log, [{"t_s": float(r["t_s"]), "v_V": float(r["v_V"]), "d_mm": float(r["d_mm"])} for r in rows])

    rep = os.path.join(tmp, "replay.csv")
    ok(SIM, "--params", params, "--replay", log, "--out", rep)
    sim = [float(r["d_model_mm"]) for r in read_csv(rep)]
    out = os.path.join(tmp, "disc")
    ok(DISC, log, "--params", params, "--out", out, "--no-plots", "--max-effects", "0")
    disc = [float(r["d_nominal_mm"]) for r in read_csv(os.path.join(out, "trace.csv"))]
    assert len(sim) == len(disc) == len(rows)
    worst = max(abs(a - b) for a, b in zip(sim, disc))
    assert worst < 1e-4, worst
    # ... and that trace is the wire that made the log (same model, same start): the noise.
    meas = [float(r["d_mm"]) for r in rows]
    rms = (sum((a - b) ** 2 for a, b in zip(sim, meas)) / len(sim)) ** 0.5
    assert rms < 0.004, rms

    # Bad input for several logs: another sample rate, another column set: refused, named.
    half = os.path.join(tmp, "half_rate.csv")
    write_log(half, [{"t_s": float(r["t_s"]), "v_V": float(r["v_V"]), "d_mm": float(r["d_mm"])} for r in rows[::2]])
    fails_with([FIT, log, half, "--params", params, "--out", os.path.join(tmp, "f1")], "half_rate.csv", "sample rate")
    cols = os.path.join(tmp, "with_ref.csv")
    write_log(cols, [{"t_s": float(r["t_s"]), "v_V": float(r["v_V"]), "d_mm": float(r["d_mm"]), "ref_mm": 0.0}
                     for r in rows], ("t_s", "v_V", "d_mm", "ref_mm"))
    fails_with([FIT, log, cols, "--params", params, "--out", os.path.join(tmp, "f2")], "with_ref.csv", "columns")

    # A log that heats and never cools back: a fit of the cooling parameters is refused, naming
    # the log and the parameters; with them fixed the fit runs.
    heat = os.path.join(tmp, "heat_only.csv")
    write_log(heat, [{"t_s": float(r["t_s"]), "v_V": float(r["v_V"]), "d_mm": float(r["d_mm"])}
                     for r in rows if float(r["t_s"]) < 34.0])
    fails_with([FIT, heat, "--params", params, "--out", os.path.join(tmp, "f3")], "heat_only.csv", "T_MF", "cool")
    fails_with([DISC, heat, "--params", params, "--refit-base", "all", "--out", os.path.join(tmp, "f3d")],
               "heat_only.csv", "T_MF", "cool")

    # An unknown key in the start file: named.
    badp = os.path.join(tmp, "bad_start.json")
    with open(badp, "w") as f:
        f.write('{"h": 160,\n "T_ASS": 50}\n')
    fails_with([FIT, log, "--params", badp, "--out", os.path.join(tmp, "f4")], "bad_start.json", "T_ASS")
    fails_with([DISC, log, "--params", badp, "--out", os.path.join(tmp, "f5")], "bad_start.json", "T_ASS")

    # Two runs of one wire whose sensor zero moved by 0.4 mm between them: one fit, a zero per run.
    moved = os.path.join(tmp, "moved.csv")
    write_log(moved, [{"t_s": float(r["t_s"]), "v_V": float(r["v_V"]), "d_mm": float(r["d_mm"]) + 0.4} for r in rows])
    fo = os.path.join(tmp, "multi")
    ok(FIT, log, moved, "--params", params, "--out", fo, "--fit", "h,offset_mm", "--validate", moved)
    with open(os.path.join(fo, "fit.json")) as f:
        fit = json.load(f)
    runs = {(r["log"], r["role"]): r for r in fit["runs"]}
    assert abs(runs[(moved, "training")]["offset_mm"] - runs[(log, "training")]["offset_mm"] - 0.4) < 0.01, runs
    assert abs(runs[(moved, "validation")]["offset_mm"] - 1.1) < 0.01, runs
    for r in fit["runs"]:
        for k in ("rms_mm", "rms_mm_heating", "rms_mm_cooling"):
            assert r[k] < 0.004, (r, k)
    # The discrepancy on the same two runs: one wire, a zero per run, the other run predicted.
    do = os.path.join(tmp, "disc_multi")
    ok(DISC, log, moved, "--params", params, "--out", do, "--no-plots", "--validate", moved)
    with open(os.path.join(do, "report.json")) as f:
        rep = json.load(f)
    assert rep["effects"] == [], rep["effects"]
    runs = {(r["log"], r["role"]): r for r in rep["runs"]}
    assert abs(runs[(moved, "training")]["offset_mm"] - runs[(log, "training")]["offset_mm"] - 0.4) < 0.01, runs
    assert abs(runs[(moved, "validation")]["offset_mm"] - 1.1) < 0.01, runs
    for r in rep["runs"]:
        assert r["rms_mm"] < 0.004, r
    fails_with([DISC, log, half, "--params", params, "--out", os.path.join(tmp, "f6")], "half_rate.csv", "sample rate")

    # A residual outside the vocabulary: the sensor reads 0.05 mm less per 10 K of wire
    # temperature (a frame that expands). Whatever is added, what is left follows T.
    exp = os.path.join(tmp, "expanding.csv")
    write_log(exp, [{"t_s": float(r["t_s"]), "v_V": float(r["v_V"]),
                     "d_mm": float(r["d_mm"]) - 0.005 * (float(r["T_true_C"]) - 22.0)} for r in rows])
    de = os.path.join(tmp, "disc_exp")
    ok(DISC, exp, "--params", params, "--out", de, "--no-plots")
    with open(os.path.join(de, "report.json")) as f:
        ra = json.load(f)["residual_analysis"]
    assert [s["state"] for s in ra["states"]][:1] == ["T"] or ra["rms_mm"] < 0.004, ra
    assert len(ra["states"]) == 6 and all(0 <= s["r2_binned"] <= 1 for s in ra["states"]), ra
    print("engine: all passed")


if __name__ == "__main__":
    main()
