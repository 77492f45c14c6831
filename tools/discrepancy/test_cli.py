#!/usr/bin/env python3
"""CLI tests of sma_discrepancy (run by CTest): the report.json contract on a log with a hidden
effect, and a clear error (file, line, problem; exit 1) for every kind of bad input."""
import json
import os
import subprocess
import sys
import tempfile

BIN = sys.argv[1]        # sma_discrepancy
MAKE_LOG = sys.argv[2]   # make_log fixture


def run(*args):
    return subprocess.run([BIN, *args], capture_output=True, text=True)


def fails_with(args, *needles):
    r = run(*args)
    assert r.returncode == 1, (args, r.returncode, r.stderr)
    for n in needles:
        assert n in r.stderr, (args, n, r.stderr)


def main():
    tmp = tempfile.mkdtemp()
    log = os.path.join(tmp, "hidden.csv")
    subprocess.run([MAKE_LOG, log, "latent_heat.L_J=2.0"], check=True)

    out = os.path.join(tmp, "out")
    r = run(log, "--out", out, "--no-plots")
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "report.json")) as f:
        rep = json.load(f)
    for key in ("rms_mm_nominal", "rms_mm_final", "effects"):
        assert key in rep, key
    assert [e["name"] for e in rep["effects"]] == ["latent_heat"], rep["effects"]
    e = rep["effects"][0]
    assert abs(e["params"]["L_J"] - 2.0) < 0.1, e
    assert e["rms_mm_before"] > 5 * e["rms_mm_after"], e
    assert rep["rms_mm_final"] < 0.0025, rep
    for name in ("report.md", "params.json", "trace.csv", "analysis.json"):
        assert os.path.exists(os.path.join(out, name)), name
    with open(os.path.join(out, "params.json")) as f:
        assert abs(json.load(f)["effects"]["latent_heat"]["L_J"] - 2.0) < 0.1

    # A clean log: nothing added.
    clean = os.path.join(tmp, "clean.csv")
    subprocess.run([MAKE_LOG, clean], check=True)
    r = run(clean, "--out", os.path.join(tmp, "clean_out"), "--no-plots")
    assert r.returncode == 0, r.stderr
    with open(os.path.join(tmp, "clean_out", "report.json")) as f:
        assert json.load(f)["effects"] == []

    # Bad inputs.
    fails_with([os.path.join(tmp, "missing.csv"), "--out", out], "missing.csv")
    bad = os.path.join(tmp, "bad.csv")
    with open(bad, "w") as f:
        f.write("t_s,v_V,d_mm\n0,0,0\n0.01,abc,0\n")
    fails_with([bad, "--out", out], "bad.csv")
    short = os.path.join(tmp, "short.csv")
    with open(short, "w") as f:
        f.write("t_s,v_V,d_mm\n" + "".join(f"{k * 0.01:.2f},1.0,0.1\n" for k in range(500)))
    fails_with([short, "--out", out], "short.csv", "at least")
    flat = os.path.join(tmp, "flat.csv")
    with open(flat, "w") as f:
        f.write("t_s,v_V,d_mm\n" + "".join(f"{k * 0.01:.2f},1.0,0.1\n" for k in range(6000)))
    fails_with([flat, "--out", out], "flat.csv", "excitation")
    params = os.path.join(tmp, "p.json")
    with open(params, "w") as f:
        f.write('{"T_AS": 50.2, "T_AF": 45.0}')
    fails_with([log, "--params", params, "--out", out], "T_AF")
    with open(params, "w") as f:
        f.write('{"bogus_key": 1}')
    fails_with([log, "--params", params, "--out", out], "bogus_key")
    fails_with([log], "--out")
    fails_with([log, "--out", out, "--min-gain", "2"], "--min-gain")
    fails_with([log, "--out", out, "--refit-base", "h,bogus"], "bogus", "all, h, T_AS")
    print("1 passed, 0 failed")


if __name__ == "__main__":
    main()
