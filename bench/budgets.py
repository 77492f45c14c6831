#!/usr/bin/env python3
"""The Uno's budgets of every firmware image, measured: flash and static RAM (avr-size), the
control section's worst cycles and the stack margin (tools/vrig --cycles-json on the ELF, the
deepest path: console lines, telemetry, a sine, pbegin/pset/pcommit while ticking, a sensor fault).

    bench/budgets.py --build build [--json build/bench-results/budgets.json] [--strict]

Budgets (issue 12): flash <= 28672 B, static RAM <= 1536 B, stack margin >= 256 B, float control
section <= 16000 cycles, Q16.16 control section <= half of float's. Prints a table; --strict
exits 1 when a budget is broken (the build's own hard limits are firmware/check_size.cmake).
Standard library only.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

FLASH_MAX, RAM_MAX, STACK_MIN, CYCLES_MAX = 28672, 1536, 256, 16000

# Every feature of an image at once: telemetry, a reference, console lines, the model store
# (where the image has it), the training run (where it has it), then a sensor fault while heating.
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
        subprocess.run([vrig, elf, "--script", script, "--duration", "7", "--quiet", "--cycles-json", cj,
                        "--sensor-fault", "6.0"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        with open(cj) as f:
            return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="build")
    ap.add_argument("--json", default=None)
    ap.add_argument("--strict", action="store_true", help="exit 1 when a budget is broken")
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
    return 1 if (a.strict and broken) else 0


if __name__ == "__main__":
    sys.exit(main())
