"""`sma fit --guess` on the real bench (../shared/data/real-wire-1m, docs/real-bench.md): with the
bench README's start values and the thermal_expansion effect, ramp02 fits within 0.25 mm RMS with
every parameter in a NiTi wire's plausible ranges, and the expansion coefficient comes out as a
metal's (NiTi 0.66-1.1e-5 /K) with an interval that excludes zero; without the effect the bands
widen past what a NiTi wire does and the fit says so, naming them.
"""
import json
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "..", "shared", "data", "real-wire-1m")
START = {"R": 2.97, "d0": 0.0005, "L0": 0.99, "T_amb": 26.0, "h": 35.0, "g": 16.0, "T_AS": 50.0, "T_AF": 65.0,
         "effects": {"convection_nonlinear": {"beta_per_K": 0.005}}}
FIT = "h,T_AS,T_AF,T_MF,e,g,offset_mm,L_J,beta_per_K"

pytestmark = pytest.mark.skipif(not os.path.isdir(DATA), reason="real bench data not beside the repo")


def fit(binaries, tmp_path, expansion):
    start = json.loads(json.dumps(START))
    if expansion:
        start["effects"]["thermal_expansion"] = {"alpha_per_K": 1e-5}
    sp = tmp_path / "start.json"
    sp.write_text(json.dumps(start))
    out = tmp_path / "fit"
    names = FIT + (",alpha_per_K" if expansion else "")
    subprocess.run([binaries["sma_fit"], os.path.join(DATA, "ramp02.csv"), "--params", str(sp), "--guess",
                    "--band-hint", "57.5", "--fit", names, "--out", str(out)],
                   check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    return json.loads((out / "fit.json").read_text())


def test_expansion_explains_ramp02_with_a_plausible_wire(binaries, tmp_path):
    r = fit(binaries, tmp_path, True)
    assert r["rms_mm"] <= 0.25, r["rms_mm"]
    warnings = [n for n in r["notes"] if n.startswith("warning:")]
    assert not warnings, warnings
    a = {p["name"]: p for p in r["parameters"]}["alpha_per_K"]
    assert 5e-6 < a["value"] < 1.5e-5, a
    assert a["ci95"] < 0.5 * a["value"], a  # named with an interval, not at a bound


def test_without_expansion_the_bands_leave_a_nitis_range(binaries, tmp_path):
    r = fit(binaries, tmp_path, False)
    warnings = [n for n in r["notes"] if n.startswith("warning:")]
    assert any("T_AF - T_AS" in w for w in warnings), r["notes"]
