#!/usr/bin/env python3
"""A foreign wire (issue 11): the paper's wire with its heating side 3 K lower, its cooling side
1.5 K higher, h 140 instead of 165 and g 1.05 instead of 0.958 mm, driven by the paper's decaying
ramp with six peaks (tools/plant2/excitations.hpp) and fitted by `sma_fit` from the paper's
values (the user knows R, d0, L0, T_amb; not the transformation). Three logs of that wire
(bench/foreign_wire_logs.cpp):
  own          the library's plant
  plant_b_rpm  plant B (written apart from the library: RK4, its own hysteresis code), with the
               library's reading of a re-heat that transforms nothing (return-point memory)
  plant_b      plant B with the literal reading (a new loop at every reversal); the fit decides the
               re-heat reading (fit.json "reheat") and must pick new_loop here
Targets (issue 11 "Done when"): every transformation temperature within 1.5 K (T_AS, T_AF, T_MF,
the martensite start of a full transformation q + e, and the minor-loop band T_s, T_f, which are
tied to the bands), h within 15 %, g within 5 %, on all three logs. A temperature the log does
not excite (the fit's notes say "q: not fitted" and "e: not fitted": on the literal reading the
last cool-down starts a loop of its own lower peak, so no full transformation is ever cooled) is
shown as "n/e" and not judged. The fit must also pick the re-heat reading each log was made with.

usage: bench/foreign_wire.py [--build build] [--out build/bench-results] [--only own,plant_b_rpm]
Writes OUT/foreign_wire.json and prints a table.
"""
import argparse
import json
import os
import subprocess
import sys
import time

SHIFT_HEAT, SHIFT_COOL, H, G = -3.0, 1.5, 140.0, 1.05
PAPER = {"T_AS": 50.2, "T_AF": 80.1, "T_MF": 22.0, "q+e": -32.6936 + 60.4657, "T_s": 60.8, "T_f": 75.9}
TRUTH = {"T_AS": PAPER["T_AS"] + SHIFT_HEAT, "T_AF": PAPER["T_AF"] + SHIFT_HEAT, "T_MF": PAPER["T_MF"] + SHIFT_COOL,
         "q+e": PAPER["q+e"] + SHIFT_COOL, "T_s": PAPER["T_s"] + SHIFT_HEAT, "T_f": PAPER["T_f"] + SHIFT_HEAT,
         "h": H, "g": G}
TEMPS = ["T_AS", "T_AF", "T_MF", "q+e", "T_s", "T_f"]
LOGS = ["own", "plant_b_rpm", "plant_b"]
TARGETED = ["own", "plant_b_rpm", "plant_b"]
# The re-heat reading each log was made with: the fit must find it (fit.json "reheat").
READING = {"own": "return_point", "plant_b_rpm": "return_point", "plant_b": "new_loop"}


def fitted_values(params):
    return {"T_AS": params["T_AS"], "T_AF": params["T_AF"], "T_MF": params["T_MF"], "q+e": params["q"] + params["e"],
            "T_s": params["T_s"], "T_f": params["T_f"], "h": params["h"], "g": params["g"]}


def judge(v, not_excited=()):
    errs = {k: (None if k in not_excited else v[k] - TRUTH[k]) for k in TEMPS}
    errs["h_rel"] = v["h"] / H - 1.0
    errs["g_rel"] = v["g"] / G - 1.0
    ok = all(errs[k] is None or abs(errs[k]) <= 1.5 for k in TEMPS) and abs(errs["h_rel"]) <= 0.15 and \
        abs(errs["g_rel"]) <= 0.05
    return errs, ok


def not_excited(fit_json):
    notes = fit_json.get("notes", [])
    gone = {n.split(":")[0] for n in notes if ": not fitted: this log does not excite it" in n}
    return ("q+e",) if {"q", "e"} <= gone else ()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="build/bench-results")
    ap.add_argument("--only", default=",".join(LOGS))
    a = ap.parse_args()
    gen = os.path.join(a.build, "bench/bench_foreign_wire_logs")
    fit = os.path.join(a.build, "tools/host/sma_fit")
    for b in (gen, fit):
        if not os.path.exists(b):
            sys.exit("foreign_wire: %s not built (cmake --build %s --target bench_foreign_wire_logs sma_fit)" % (b, a.build))
    work = os.path.join(a.out, "foreign_wire")
    os.makedirs(work, exist_ok=True)
    subprocess.run([gen, "--out", work, "--dT-heat", str(SHIFT_HEAT), "--dT-cool", str(SHIFT_COOL), "--h", str(H),
                    "--g", str(G)], check=True, stdout=subprocess.DEVNULL)
    result = {"truth": TRUTH, "start": "the paper's Table II", "logs": {}}
    for name in a.only.split(","):
        out = os.path.join(work, "fit_" + name)
        t0 = time.time()
        subprocess.run([fit, os.path.join(work, name + ".csv"), "--out", out], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        seconds = time.time() - t0
        with open(os.path.join(out, "params.json")) as f:
            params = json.load(f)
        with open(os.path.join(out, "fit.json")) as f:
            fj = json.load(f)
        v = fitted_values(params)
        errs, ok = judge(v, not_excited(fj))
        ok = ok and fj.get("reheat", {}).get("reading") == READING[name]
        result["logs"][name] = {"fitted": v, "errors": errs, "within_targets": ok, "targeted": name in TARGETED,
                                "rms_mm": fj["rms_mm"], "seconds": seconds,
                                "reheat": fj.get("reheat", {}).get("reading", "")}
    with open(os.path.join(a.out, "foreign_wire.json"), "w") as f:
        json.dump(result, f, indent=1)
    print("foreign wire (heating side %+.1f K, cooling side %+.1f K, h %g, g %g mm), paper's decaying ramp, "
          "fitted from the paper's values" % (SHIFT_HEAT, SHIFT_COOL, H, G))
    print("| log | re-heat reading chosen | " + " | ".join("%s err K" % k for k in TEMPS) +
          " | h err | g err | RMS mm | fit s | targets |")
    print("|---|" + "---|" * (len(TEMPS) + 6))
    for name, e in result["logs"].items():
        er = e["errors"]
        print("| %s | %s | %s | %+.1f %% | %+.1f %% | %.4f | %.1f | %s |" % (
            name, e["reheat"], " | ".join("n/e" if er[k] is None else "%+.2f" % er[k] for k in TEMPS),
            100 * er["h_rel"], 100 * er["g_rel"], e["rms_mm"], e["seconds"], ("met" if e["within_targets"] else "MISSED") if e["targeted"] else
            ("met" if e["within_targets"] else "missed (other reading, reported)")))
    print("wrote %s" % os.path.join(a.out, "foreign_wire.json"))
    return 0 if all(e["within_targets"] for e in result["logs"].values() if e["targeted"]) else 1


if __name__ == "__main__":
    sys.exit(main())
