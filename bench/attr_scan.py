#!/usr/bin/env python3
"""Per-function code generation attributes, measured on a whole Uno image: each job puts GNU
attributes before given lines of a copy of the sources (a function definition's first line) and
builds the image with its own build's commands (firmware/CMakeLists.txt as configured in --build:
compile, first link, layout.py, second link, avr-size, z_scan), in a temporary directory.

    bench/attr_scan.py --build build [--target sma_firmware_fixed] JOBS.tsv OUT.csv

JOBS.tsv, one job a line: tag <TAB> path:line[;path:line...] <TAB> attribute[;attribute...]
(paths relative to the source root, e.g. lib/sma_model/include/sma/pid.hpp:66 and
optimize("-fira-algorithm=CB")). OUT.csv gets tag, attributes, flash B, static RAM B, z_scan
(clean/HIT) or the build's error; jobs whose tag is already in OUT.csv are skipped (a scan can
be resumed). A benchmark, not a test: docs/board.md "Session 13, qattr" has a scan's table.
Standard library only.
"""
import argparse
import csv
import os
import re
import shutil
import subprocess
import tempfile


def recipe(build, target):
    """The target's commands from the build's Makefile: (source root, build dir, commands)."""
    mk = os.path.join(build, "firmware", "CMakeFiles", target + ".dir", "build.make")
    cmds = [l.strip() for l in open(mk) if re.match(r"\s*cd \S+ && ", l) and "cmake" not in l]
    cmds = [c for c in cmds if "avr-objcopy" not in c]
    cmds.sort(key=lambda c: 0 if " -c " in c else 1)  # the compile before the links
    cache = open(os.path.join(build, "CMakeCache.txt")).read()
    root = re.search(r"^CMAKE_HOME_DIRECTORY:INTERNAL=(.*)$", cache, re.M).group(1)
    return root, os.path.join(os.path.abspath(build), "firmware"), cmds


def run_job(root, fw_build, cmds, edits):
    d = tempfile.mkdtemp(prefix="attr_scan_")
    try:
        for sub in ("lib/sma_model/include", "firmware"):
            shutil.copytree(os.path.join(root, sub), os.path.join(d, "src", sub))
        for rel, line, attr in edits:
            p = os.path.join(d, "src", rel)
            lines = open(p).read().split("\n")
            s = lines[line - 1]
            ind = len(s) - len(s.lstrip())
            lines[line - 1] = s[:ind] + "__attribute__((%s)) " % attr + s[ind:]
            open(p, "w").write("\n".join(lines))
        out = ""
        for c in cmds:
            c = c.replace(fw_build, os.path.join(d, "out")).replace(root, os.path.join(d, "src"))
            os.makedirs(os.path.join(d, "out"), exist_ok=True)
            r = subprocess.run(["bash", "-c", c], capture_output=True, text=True)
            out += r.stdout
            if r.returncode != 0 and "z_scan" not in c:
                return None, None, "ERR " + r.stderr[-200:].replace("\n", " ")
        flash = re.search(r"Program:\s+(\d+) bytes", out)
        ram = re.search(r"Data:\s+(\d+) bytes", out)
        hit = re.search(r"z_scan: \S+ (\d+) Z-clobber", out)
        return (int(flash.group(1)) if flash else None, int(ram.group(1)) if ram else None,
                "clean" if hit and hit.group(1) == "0" else "HIT")
    finally:
        shutil.rmtree(d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", required=True)
    ap.add_argument("--target", default="sma_firmware_fixed")
    ap.add_argument("jobs")
    ap.add_argument("out")
    a = ap.parse_args()
    root, fw_build, cmds = recipe(a.build, a.target)
    done = {r[0] for r in csv.reader(open(a.out))} if os.path.exists(a.out) else set()
    for l in open(a.jobs):
        if not l.strip() or l.startswith("#"):
            continue
        tag, locs, attrs = l.rstrip("\n").split("\t")
        if tag in done:
            continue
        edits = [(loc.rsplit(":", 1)[0], int(loc.rsplit(":", 1)[1]), at)
                 for loc, at in zip(locs.split(";"), attrs.split(";"))]
        flash, ram, z = run_job(root, fw_build, cmds, edits)
        with open(a.out, "a") as f:
            csv.writer(f).writerow([tag, attrs, flash, ram, z])
        print(tag, attrs, flash, z, flush=True)


if __name__ == "__main__":
    main()
