#!/usr/bin/env python3
"""CTest plant2_logs_valid: plant2_make_logs writes rig logs of the interfaces.md format.

Checks the --quick set: every file of cases.json exists; header t_s,v_V,d_mm after `#` comments;
100 Hz with time increasing; V within the paper's 0..2 V; displacement finite and within the
stroke (eq 12: 0..g = 0.958 mm, plus noise and the hidden sensor effects); 2 um noise at rest;
ADC counts where the manifest says so; the hidden offset of a calibration log shows at rest.
Usage: check_logs.py PATH/TO/plant2_make_logs
"""
import json
import math
import os
import subprocess
import sys
import tempfile

G_MM = 0.958
NOISE_MM = 0.002


def read_log(path):
    header, rows = None, []
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if line.startswith("#"):
                continue
            if header is None:
                header = line.strip().split(",")
                continue
            vals = [float(x) for x in line.split(",")]
            assert len(vals) == 3, "%s:%d: %d fields" % (path, n, len(vals))
            rows.append(vals)
    return header, rows


def main():
    exe = sys.argv[1]
    bad = subprocess.run([exe, "--out", "/nonexistent-dir-x", "--only", "no-such-case"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert bad.returncode == 2 and "no-such-case" in bad.stderr, bad.stderr
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([exe, "--out", tmp, "--quick"], check=True)
        man = json.load(open(os.path.join(tmp, "cases.json")))
        cases = man["cases"]
        assert len(cases) >= 10, len(cases)
        excitations = {c["excitation"] for c in cases}
        assert excitations == {"sine", "ramp6", "stairs", "steps"}, excitations
        for c in cases:
            header, rows = read_log(os.path.join(tmp, c["file"]))
            assert header == ["t_s", "v_V", "d_mm"], (c["file"], header)
            assert len(rows) > 100 * 100, (c["file"], len(rows))
            t = [r[0] for r in rows]
            for a, b in zip(t, t[1:]):
                assert abs((b - a) - 0.01) < 1e-6, (c["file"], a, b)
            assert all(0.0 <= r[1] <= 2.0 for r in rows), c["file"]
            d = [r[2] for r in rows]
            assert all(math.isfinite(x) for x in d), c["file"]
            assert min(d) > -0.1 and max(d) < 1.3 * G_MM, (c["file"], min(d), max(d))
            # every log starts at rest (V = 0 for the first 2 s): cold martensite, D = 0
            rest = [r[2] for r in rows[:200]]
            assert all(r[1] == 0.0 for r in rows[:200]), c["file"]
            mean = sum(rest) / len(rest)
            sd = math.sqrt(sum((x - mean) ** 2 for x in rest) / len(rest))
            assert 0.7 * NOISE_MM < sd < 1.5 * NOISE_MM, (c["file"], sd)
            offset = c["hidden"].get("sensor_calibration", {}).get("offset_mm", 0.0)
            assert abs(mean - offset) < 0.002, (c["file"], mean, offset)
            # without hidden effects the drives reach full transformation: the stroke g shows
            if not c["hidden"]:
                top = sorted(d)[-200:]
                assert abs(sum(top) / len(top) - G_MM) < 0.01, (c["file"], top[0])
            if c["adc"]:
                q = man["adc_mm"]
                assert all(abs(x / q - round(x / q)) < 0.01 for x in d[:500]), c["file"]
        print("plant2_logs_valid: %d logs OK" % len(cases))


if __name__ == "__main__":
    main()
