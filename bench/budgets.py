#!/usr/bin/env python3
"""The Uno's budgets of every firmware image, measured: flash and static RAM (avr-size), the
control section's worst cycles and the stack margin (tools/vrig --cycles-json on the ELF, the
deepest path: console lines, telemetry, a sine, pbegin/pset/pcommit while ticking, a sensor fault).

    bench/budgets.py --build build [--json build/bench-results/budgets.json] [--strict]
                     [--enforce] [--update-ratchet]

Budgets (issue 12): flash <= 28672 B, static RAM <= 1536 B, stack margin >= 256 B, float control
section <= 16000 cycles, Q16.16 control section <= half of float's. Prints a table.
--enforce (CTest bench_budgets): exits 1 when an image breaks a budget it meets today's ratchet
  for: a figure within its budget must stay within it; a figure still over budget must not get
  worse than its ratchet in bench/budgets_ratchet.json (printed "over budget (issue 12)").
--update-ratchet: tightens bench/budgets_ratchet.json to today's figures (never loosens it).
--strict: exits 1 on any broken budget (the issue's "done when").
The build itself fails on flash/RAM above the ratchet (firmware/check_size.cmake reads the same
file). Standard library only.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

FLASH_MAX, RAM_MAX, STACK_MIN, CYCLES_MAX = 28672, 1536, 256, 16000
RATCHET = os.path.join(os.path.dirname(os.path.abspath(__file__)), "budgets_ratchet.json")
# figure -> True when larger is better (the stack margin), False when smaller is (the rest)
FIGURES = {"flash_B": False, "static_ram_B": False, "stack_margin_B": True, "control_cycles_max": False}
# A ratchet is exact for bytes; the worst tick's cycles move by a few with any change of code
# layout on the same path, so its ratchet allows 1 %.
RATCHET_SLACK = {"control_cycles_max": 0.01}


def budget_of(row, fig, float_row):
    """The issue's budget of one figure of one image."""
    if fig == "flash_B":
        return FLASH_MAX
    if fig == "static_ram_B":
        return RAM_MAX
    if fig == "stack_margin_B":
        return STACK_MIN
    if row["image"] == "sma_firmware_fixed" and float_row:
        return 0.5 * float_row["control_cycles_max"]
    return CYCLES_MAX


def within(value, limit, larger_better):
    return value >= limit if larger_better else value <= limit


def enforce(rows, ratchet):
    """Failures: a figure that meets its budget must keep meeting it; one over budget must not get
    worse than its ratchet (missing ratchet: today's value is printed to add). Prints a line each."""
    fl = next((r for r in rows if r["image"] == "sma_firmware"), None)
    failures = []
    for r in rows:
        rr = ratchet.get(r["image"], {})
        for fig, larger_better in FIGURES.items():
            v, b = r[fig], budget_of(r, fig, fl)
            if v is None:
                failures.append("%s %s: not measured" % (r["image"], fig))
                continue
            if within(v, b, larger_better):
                continue
            lim = rr.get(fig)
            if lim is None:
                failures.append("%s %s = %s: over budget (%s) and no ratchet in %s" % (r["image"], fig, v, b, RATCHET))
            elif within(v, lim * (1.0 + RATCHET_SLACK.get(fig, 0.0)), larger_better):
                print("%s %s = %s: over budget (issue 12): budget %s, ratchet %s" % (r["image"], fig, v, b, lim))
            elif within(lim, b, larger_better):
                failures.append("%s %s = %s: breaks the budget %s (issue 12), met before (%s)" % (r["image"], fig, v, b, lim))
            else:
                failures.append("%s %s = %s: worse than the ratchet %s (budget %s)" % (r["image"], fig, v, lim, b))
    return failures


def update_ratchet(rows, ratchet):
    """Today's figures into the ratchet where they are better (or new); never loosened."""
    for r in rows:
        rr = ratchet.setdefault(r["image"], {})
        for fig, larger_better in FIGURES.items():
            v = r[fig]
            if v is not None and (fig not in rr or within(v, rr[fig], larger_better)):
                rr[fig] = v
    with open(RATCHET, "w") as f:
        json.dump(ratchet, f, indent=2, sort_keys=True)
        f.write("\n")

# Every feature of an image at once: telemetry, a reference, console lines, the model store
# (where the image has it), the training run (where it has it), the sine's first peak (a heating ->
# cooling reversal builds a new minor loop: the model's most expensive tick, t = 30 s), then a
# sensor fault while the wire is hot.
SCRIPT = """0.10 tele on
0.20 status
0.30 sine
1.00 gains 12 3 0.1
1.50 status
2.00 pinfo
2.10 pget T_AS
2.50 stop
2.60 pbegin
3.00 pset rho 6400
3.40 pcommit
4.00 train
4.50 status
5.00 sine
5.20 status
"""


def avr_size(elf):
    out = subprocess.run(["avr-size", elf], stdout=subprocess.PIPE, text=True, check=True).stdout
    text, data, bss = (int(x) for x in out.splitlines()[1].split()[:3])
    return text + data, data + bss


def cycles(vrig, elf):
    with tempfile.TemporaryDirectory() as d:
        script = os.path.join(d, "script.txt")
        with open(script, "w") as f:
            f.write(SCRIPT)
        cj = os.path.join(d, "cycles.json")
        subprocess.run([vrig, elf, "--script", script, "--duration", "32", "--quiet", "--cycles-json", cj,
                        "--sensor-fault", "31.0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        with open(cj) as f:
            return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--json", default=None)
    ap.add_argument("--strict", action="store_true", help="exit 1 when a budget is broken")
    ap.add_argument("--enforce", action="store_true",
                    help="exit 1 when a budget met today, or a ratchet (bench/budgets_ratchet.json), is broken")
    ap.add_argument("--update-ratchet", action="store_true", help="tighten bench/budgets_ratchet.json to today")
    a = ap.parse_args()
    fw = os.path.join(a.build, "firmware")
    vrig = os.path.join(a.build, "tools", "vrig", "vrig")
    rows = []
    for name in ("sma_firmware", "sma_firmware_fixed"):
        elf = os.path.join(fw, name + ".elf")
        if not os.path.isfile(elf):
            continue
        flash, ram = avr_size(elf)
        c = cycles(vrig, elf)
        rows.append({"image": name, "flash_B": flash, "static_ram_B": ram,
                     "stack_margin_B": c.get("sram_never_touched_bytes"),
                     "control_cycles_max": c.get("control_cycles_max"),
                     "control_cycles_mean": c.get("control_cycles_mean"),
                     "tick_cycles_max": c.get("tick_cycles_max")})
    if not rows:
        print("budgets: no firmware ELF under %s (avr-gcc missing?)" % fw)
        return 0
    fl = next((r for r in rows if r["image"] == "sma_firmware"), None)
    broken = []
    for r in rows:
        ok = {"flash": r["flash_B"] <= FLASH_MAX, "ram": r["static_ram_B"] <= RAM_MAX,
              "stack": (r["stack_margin_B"] or 0) >= STACK_MIN}
        if r["image"] == "sma_firmware_fixed" and fl:
            ok["cycles"] = r["control_cycles_max"] <= 0.5 * fl["control_cycles_max"]
        else:
            ok["cycles"] = r["control_cycles_max"] <= CYCLES_MAX
        r["within"] = ok
        broken += ["%s %s" % (r["image"], k) for k, v in ok.items() if not v]
    print("| image | flash B (<= %d) | static RAM B (<= %d) | stack margin B (>= %d) | control cycles max "
          "(float <= %d, Q16.16 <= float/2) | mean | whole tick max |" % (FLASH_MAX, RAM_MAX, STACK_MIN, CYCLES_MAX))
    print("|---|---|---|---|---|---|---|")
    mark = lambda v: "" if v else " **over**"  # noqa: E731
    for r in rows:
        w = r["within"]
        print("| %s | %d%s | %d%s | %s%s | %d%s | %.0f | %d |" % (
            r["image"], r["flash_B"], mark(w["flash"]), r["static_ram_B"], mark(w["ram"]), r["stack_margin_B"],
            mark(w["stack"]), r["control_cycles_max"], mark(w["cycles"]), r["control_cycles_mean"],
            r["tick_cycles_max"]))
    print("budgets broken: %s" % (", ".join(broken) if broken else "none"))
    if a.json:
        os.makedirs(os.path.dirname(os.path.abspath(a.json)), exist_ok=True)
        with open(a.json, "w") as f:
            json.dump({"budgets": {"flash_B": FLASH_MAX, "static_ram_B": RAM_MAX, "stack_margin_B": STACK_MIN,
                                   "control_cycles_float": CYCLES_MAX, "fixed_vs_float": 0.5},
                       "images": rows, "broken": broken}, f, indent=2)
    with open(RATCHET) as f:
        ratchet = json.load(f)
    if a.update_ratchet:
        update_ratchet(rows, ratchet)
        print("ratchet written: %s" % RATCHET)
    if a.enforce:
        failures = enforce(rows, ratchet)
        for m in failures:
            print("BUDGET BROKEN: %s" % m)
        if failures:
            return 1
    return 1 if (a.strict and broken) else 0


if __name__ == "__main__":
    sys.exit(main())
