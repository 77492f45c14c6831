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
tracking error alone is not the criterion.) Every run first starts the training run (`train`)
and stops it, so one ELF is shown doing `train`, `pbegin`..`pcommit` and `sine` in one session:
the replies must be OK, `status` must show the training running and `stop` must end it (heater
off until the sine). Standard library only.
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
TRAIN = (0.2, 2.2)  # the training run: started, then stopped
START = 5.0    # the sine starts here (after the training and the upload)
PERIOD = 50.0  # the paper's sine period


def session_problems(name, out, rows, upload):
    """What the board's replies and telemetry say about train / stop / the upload (list of text)."""
    replies = [ln.split("] ", 1)[1] for ln in out.splitlines() if ln.startswith("[") and "] " in ln]
    words = ["train", "stop"] + (["pbegin"] + [u.split()[0] for u in upload] + ["pcommit"] if upload else [])
    bad = ["%s: the board answered '%s'" % (name, r) for r in replies if r.startswith("ERR")]
    for w in words:
        if not any(r.startswith("OK " + w) for r in replies):
            bad.append("%s: no 'OK %s' from the board" % (name, w))
    status = [r for r in replies if r.startswith("OK status ")]
    if len(status) != 2 or " train " not in status[0] + " " or not status[1].startswith("OK status off "):
        bad.append("%s: status during the training / after stop: %s" % (name, status))
    after = [v for t, v in rows if TRAIN[1] + 0.05 < t < START - 0.05]
    if not after or max(after) != 0.0:
        bad.append("%s: the heater was not off between stop and the sine" % name)
    return bad


def run(args, name, effect_args, upload, d, problems):
    script = os.path.join(d, name + ".txt")
    lines = ["0.10 tele on", "%.2f train" % TRAIN[0], "%.2f status" % (TRAIN[0] + 0.8), "%.2f stop" % TRAIN[1],
             "%.2f status" % (TRAIN[1] + 0.1)]
    t = TRAIN[1] + 0.3
    if upload:
        for cmd in ["pbegin"] + upload + ["pcommit"]:
            lines.append("%.2f %s" % (t, cmd))
            t += 0.4
    lines += ["%.2f sine" % START]
    with open(script, "w") as f:
        f.write("\n".join(lines) + "\n")
    log, truth = os.path.join(d, name + ".csv"), os.path.join(d, name + "_truth.csv")
    cmd = [args.vrig, args.elf, "--script", script, "--duration", "%.1f" % (START + PERIOD), "--stamp",
           "--log", log, "--truth", truth, "--noise-mm", "0.002"]
    for e in effect_args:
        cmd += ["--effect", e]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise RuntimeError("%s: vrig exit %d: %s" % (name, r.returncode, r.stderr[-300:]))
    ref, rows = {}, []
    with open(log) as f:
        for ln in f:
            p = ln.strip().split(",")
            if len(p) == 5 and p[0][:1].isdigit():
                ref[round(float(p[0]), 2)] = float(p[3])
                rows.append((float(p[0]), float(p[1])))
    problems += session_problems(name, r.stdout, rows, upload)
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
    base = run(a, "none", [], None, a.out, fails)
    res["none"] = base

    def dev(x):  # RMS difference from the wire without the effect, mm
        d = [x["series"][k] - base["series"][k] for k in x["series"] if k in base["series"]]
        return math.sqrt(sum(v * v for v in d) / len(d)) if d else float("nan")
    for name in a.effects:
        if name not in EFFECTS:
            print("fil_effects: unknown effect %s (known: %s)" % (name, ", ".join(EFFECTS)), file=sys.stderr)
            return 2
        fx, pset = EFFECTS[name]
        known = run(a, name + "_uploaded", fx, pset, a.out, fails)
        unknown = run(a, name + "_not_uploaded", fx, None, a.out, fails)
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
