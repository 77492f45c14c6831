#!/usr/bin/env python3
"""CTest plant2_discrepancy: the discrepancy workflow on three logs of plant B (docs/plant2.md),
a plant written independently of the library (with the library's re-heat reading): nothing named on a clean sine drive; the ambient
offset of a step log named alone with its value; latent heat and a phase-dependent resistance
hidden together on the paper's six-peak ramp, both named with their values.
Usage: test_discrepancy_plant2.py PATH/TO/plant2_make_logs PATH/TO/sma_discrepancy
"""
import json
import os
import subprocess
import sys
import tempfile

# log -> {effect: {param: (hidden value, tolerance)}}
EXPECT = {
    "sine-clean": {},
    "steps-ambient_offset-strong": {"ambient_offset": {"offset_K": (-4.5, 0.5)}},
    "ramp6-latent_heat+resistance_phase": {"latent_heat": {"L_J": (3.0, 0.45)},
                                           "resistance_phase": {"k_R": (-0.2, 0.03)}},
}


def main():
    make_logs, engine = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        # the library's re-heat reading: this test is about the effects, not that base-model difference
        subprocess.run([make_logs, "--out", tmp, "--only", ",".join(EXPECT), "--reading", "rpm"], check=True)
        cases = {c["name"]: c for c in json.load(open(os.path.join(tmp, "cases.json")))["cases"]}
        assert set(cases) == set(EXPECT), sorted(cases)
        failures = []
        for name, want in EXPECT.items():
            out = os.path.join(tmp, name)
            subprocess.run([engine, os.path.join(tmp, cases[name]["file"]), "--out", out, "--no-plots"],
                           check=True, stdout=subprocess.DEVNULL)
            rep = json.load(open(os.path.join(out, "report.json")))
            named = {e["name"]: e["params"] for e in rep["effects"]}
            print("%s: named %s" % (name, named or "nothing"))
            if set(named) != set(want):
                failures.append("%s: named %s, hidden %s" % (name, sorted(named), sorted(want)))
                continue
            for eff, params in want.items():
                for key, (value, tol) in params.items():
                    if abs(named[eff][key] - value) > tol:
                        failures.append("%s: %s %s = %.4g, hidden %.4g" % (name, eff, key, named[eff][key], value))
        if failures:
            print("\n".join(failures))
            sys.exit(1)
        print("plant2_discrepancy: %d logs OK" % len(EXPECT))


if __name__ == "__main__":
    main()
