#!/usr/bin/env python3
"""Checks platformio.ini offline: `pio project config` must parse it, it must have the `uno`
and `native` envs, and every path it names must exist. (Building with PlatformIO needs its
registry, which CI cannot reach; CMake builds the same sources.)"""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main() -> int:
    out = subprocess.run(["pio", "project", "config", "--json-output", "-d", ROOT],
                         capture_output=True, text=True)
    if out.returncode != 0:
        print("platformio.ini does not parse:\n" + out.stderr, file=sys.stderr)
        return 1
    sections = dict((name, dict(opts)) for name, opts in json.loads(out.stdout))
    errors = []
    for env in ("env:uno", "env:native"):
        if env not in sections:
            errors.append(f"missing [{env}]")
    pio = sections.get("platformio", {})
    for key in ("src_dir", "include_dir", "lib_dir", "test_dir"):
        path = pio.get(key)
        if not path or not os.path.isdir(path):
            errors.append(f"[platformio] {key} = {path}: no such directory")
    for name, opts in sections.items():
        for flags in opts.get("build_flags", []):
            for flag in flags.split():
                if flag.startswith("-I") and not os.path.isdir(os.path.join(ROOT, flag[2:])):
                    errors.append(f"[{name}] build_flags {flag}: no such directory")
        for dep in opts.get("lib_deps", []):
            if not os.path.isfile(os.path.join(pio.get("lib_dir", ""), dep, "library.json")):
                errors.append(f"[{name}] lib_deps {dep}: no {dep}/library.json in lib_dir")
    if sections.get("env:uno", {}).get("board") != "uno":
        errors.append("[env:uno] board must be uno")
    for e in errors:
        print("platformio.ini: " + e, file=sys.stderr)
    if not errors:
        print(f"platformio.ini: OK ({', '.join(s for s in sections if s.startswith('env:'))})")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
