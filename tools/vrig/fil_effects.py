#!/usr/bin/env python3
"""Firmware in the loop, one effect of the vocabulary at a time: a virtual wire that has the
effect (vrig --effect), the paper's sine run by the ELF twice, once with the effect uploaded
into the board's model (pbegin / pset / pcommit: the board compensates it) and once without.
The tracking error is measured on the wire's TRUE displacement (vrig --truth), not on what the
affected sensor shows, over the first period of the sine (heating and cooling halves).

    fil_effects.py --vrig VRIG --elf ELF [--out DIR] [--json FILE] [EFFECT ...]

Passes when, for every effect, the wire with the effect uploaded moves closer to how the same
controller moves a wire WITHOUT the effect (RMS difference of the true displacements over the
period) than the wire without the upload does. (The RMS tracking errors are printed; a sensor
offset can happen to lower the error of a controller that overshoots while cooling, so the
tracking error alone is not the criterion.) Standard library only.
"""
import argparse
import json
import math
import os
import subprocess
import sys

# effect -> (vrig --effect args, pset lines): the sensor effects the board compensates.
EFFECTS = {
    "sensor_lag": (["sensor_lag.tau_s=0.5"], ["pset sensor_lag.tau_s 0.5"]),
    "sensor_delay": (["sensor_delay.delay_s=0.25"], ["pset sensor_delay.delay_s 0.25"]),
    "sensor_calibration": (["sensor_calibration.gain=1.1", "sensor_calibration.offset_mm=0.03"],
                           ["pset sensor_calibration.gain 1.1", "pset sensor_calibration.offset_mm 0.03"]),
}
START = 3.0    # the sine starts here (after the upload)
PERIOD = 50.0  # the paper's sine period


def run(args, name, effect_args, upload, d):
    script = os.path.join(d, name + ".txt")
    lines = []
    t = 0.2
    if upload:
        for cmd in ["pbegin"] + upload + ["pcommit"]:
            lines.append("%.2f %s" % (t, cmd))
            t += 0.4
    lines += ["%.2f tele on" % (START - 0.1), "%.2f sine" % START]
    with open(script, "w") as f:
        f.write("\n".join(lines) + "\n")
    log, truth = os.path.join(d, name + ".csv"), os.path.join(d, name + "_truth.csv")
    cmd = [args.vrig, args.elf, "--script", script, "--duration", "%.1f" % (START + PERIOD), "--quiet",
           "--log", log, "--truth", truth, "--noise-mm", "0.002"]
    for e in effect_args:
        cmd += ["--effect", e]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise RuntimeError("%s: vrig exit %d: %s" % (name, r.returncode, r.stderr[-300:]))
    ref = {}
    with open(log) as f:
        for ln in f:
            p = ln.strip().split(",")
            if len(p) == 5 and p[0][:1].isdigit():
                ref[round(float(p[0]), 2)] = float(p[3])
    err_h, err_c = [], []
    prev = None
    with open(truth) as f:
        next(f)
        for ln in f:
            t_s, d_mm = (float(x) for x in ln.split(","))
            k = round(t_s, 2)
            if k in ref and START + 0.5 <= t_s <= START + PERIOD:
                r_mm = ref[k]
                (err_h if prev is None or r_mm >= prev else err_c).append(d_mm - r_mm)
                prev = r_mm
    rms = lambda e: math.sqrt(sum(x * x for x in e) / len(e)) if e else float("nan")  # noqa: E731
    series = {}
    with open(truth) as f:
        next(f)
        for ln in f:
            t_s, d_mm = (float(x) for x in ln.split(","))
            if START + 0.5 <= t_s <= START + PERIOD:
                series[round(t_s, 2)] = d_mm
    return {"series": series, "rms_mm": rms(err_h + err_c), "rms_heating_mm": rms(err_h), "rms_cooling_mm": rms(err_c),
            "max_mm": max((abs(x) for x in err_h + err_c), default=float("nan")), "samples": len(err_h + err_c)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vrig", required=True)
    ap.add_argument("--elf", required=True)
    ap.add_argument("--out", default="fil_effects")
    ap.add_argument("--json", default=None)
    ap.add_argument("effects", nargs="*", default=list(EFFECTS))
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    res, fails = {}, []
    base = run(a, "none", [], None, a.out)
    res["none"] = base

    def dev(x):  # RMS difference from the wire without the effect, mm
        d = [x["series"][k] - base["series"][k] for k in x["series"] if k in base["series"]]
        return math.sqrt(sum(v * v for v in d) / len(d)) if d else float("nan")
    for name in a.effects:
        if name not in EFFECTS:
            print("fil_effects: unknown effect %s (known: %s)" % (name, ", ".join(EFFECTS)), file=sys.stderr)
            return 2
        fx, pset = EFFECTS[name]
        known = run(a, name + "_uploaded", fx, pset, a.out)
        unknown = run(a, name + "_not_uploaded", fx, None, a.out)
        known["dev_from_no_effect_mm"], unknown["dev_from_no_effect_mm"] = dev(known), dev(unknown)
        res[name] = {"uploaded": known, "not_uploaded": unknown}
        if not known["dev_from_no_effect_mm"] < unknown["dev_from_no_effect_mm"]:
            fails.append("%s: uploaded %.4f mm from the wire without the effect, not uploaded %.4f mm" % (
                name, known["dev_from_no_effect_mm"], unknown["dev_from_no_effect_mm"]))
    print("| wire | RMS true error uploaded (heating / cooling), mm | not uploaded, mm | "
          "RMS from the no-effect run: uploaded / not uploaded, mm |")
    print("|---|---|---|---|")
    print("| no effect | %.4f (%.4f / %.4f) | | |" % (base["rms_mm"], base["rms_heating_mm"], base["rms_cooling_mm"]))
    for name in a.effects:
        k, u = res[name]["uploaded"], res[name]["not_uploaded"]
        print("| %s | %.4f (%.4f / %.4f) | %.4f (%.4f / %.4f) | %.4f / %.4f |" % (
            name, k["rms_mm"], k["rms_heating_mm"], k["rms_cooling_mm"], u["rms_mm"], u["rms_heating_mm"],
            u["rms_cooling_mm"], k["dev_from_no_effect_mm"], u["dev_from_no_effect_mm"]))
    for r in [res["none"]] + [res[n][w] for n in a.effects for w in ("uploaded", "not_uploaded")]:
        r.pop("series", None)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"elf": a.elf, "results": res, "failures": fails}, f, indent=2)
    for x in fails:
        print("FAIL " + x)
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
