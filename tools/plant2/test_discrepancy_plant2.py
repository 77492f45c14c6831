#!/usr/bin/env python3
"""CTest plant2_discrepancy: the discrepancy workflow on three logs of plant B (docs/plant2.md),
a plant written independently of the library (with the library's re-heat reading): nothing named on a clean sine drive; the ambient
offset of a step log named alone with its value; latent heat and a phase-dependent resistance
hidden together on the paper's six-peak ramp, both named with their values. And on a clean sine
from plant B's literal re-heat reading (no effect hidden): the engine picks the `new_loop` reading
and names nothing; with the library's reading forced (--reheat return_point) the base differs,
nothing is named, and the report says the vocabulary does not explain the log, naming the
stand-ins it refused.
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
        # The literal reading: the engine must find that the log follows the other reading of a
        # re-heat (a choice of the model's structure, report.json "reheat") and then name nothing.
        lit = os.path.join(tmp, "literal")
        subprocess.run([make_logs, "--out", lit, "--only", "sine-clean", "--reading", "literal"], check=True)
        out = os.path.join(lit, "out")
        subprocess.run([engine, os.path.join(lit, "sine-clean.csv"), "--out", out, "--no-plots"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rep = json.load(open(os.path.join(out, "report.json")))
        named = [e["name"] for e in rep["effects"]]
        print("sine-clean (literal reading): reading %s; named %s; gap %.4f mm" % (
            rep["reheat"]["reading"], named or "nothing", rep["rms_mm_final"]))
        if rep["reheat"]["reading"] != "new_loop":
            failures.append("sine-clean, literal reading: the engine kept the %s reading" % rep["reheat"]["reading"])
        if named:
            failures.append("sine-clean, literal reading: named %s on a log with no hidden effect" % named)
        if not rep["rms_mm_final"] < 1.5 * 0.002:
            failures.append("sine-clean, literal reading: gap %.4f mm left with the literal reading" % rep["rms_mm_final"])
        # The same log with the reading forced to the library's: the base model then differs; no
        # effect of the vocabulary may be added to stand in for it (discrepancy.hpp, credibility()).
        out = os.path.join(lit, "out_rpm")
        subprocess.run([engine, os.path.join(lit, "sine-clean.csv"), "--out", out, "--no-plots",
                        "--reheat", "return_point"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rep = json.load(open(os.path.join(out, "report.json")))
        named = [e["name"] for e in rep["effects"]]
        ra = rep["residual_analysis"]
        print("sine-clean (literal reading, --reheat return_point): named %s; refused %s" % (
            named or "nothing", ra.get("not_credible")))
        if named:
            failures.append("sine-clean, --reheat return_point: named %s on a log with no hidden effect" % named)
        if not ra.get("no_credible_candidate") or not ra.get("not_credible"):
            failures.append("sine-clean, --reheat return_point: the report does not say that the vocabulary does not explain it")
        if "does not explain" not in open(os.path.join(out, "report.md")).read():
            failures.append("sine-clean, --reheat return_point: report.md does not say the vocabulary does not explain it")
        if failures:
            print("\n".join(failures))
            sys.exit(1)
        print("plant2_discrepancy: %d logs OK" % (len(EXPECT) + 1))


if __name__ == "__main__":
    main()
