"""Finds the C++ helpers (sma_sim, sma_fit) or builds them with CMake on first use.

Order: $SMA_SIM / $SMA_FIT / $SMA_DISCREPANCY (set by CTest), then <root>/build/tools/host/ (the
project build, once the top-level CMakeLists.txt has add_subdirectory(tools/host)), then
<root>/build/tools-host/ (a build of tools/host as a project of its own; not for sma_discrepancy).
A missing or stale binary is (re)built with -j1. $SMA_BUILD_DIR replaces <root>/build.
"""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
TOOLS = ("sma_sim", "sma_fit")
# Where each helper lives in the project build (sma_discrepancy: tools/discrepancy, project build only).
SUBDIR = {"sma_sim": "tools/host", "sma_fit": "tools/host", "sma_discrepancy": "tools/discrepancy"}


class BuildError(RuntimeError):
    pass


def _newest_source():
    newest = 0.0
    for base in (os.path.join(ROOT, "tools", "host"), os.path.join(ROOT, "tools", "discrepancy"),
                 os.path.join(ROOT, "lib", "sma_model", "include"), os.path.join(ROOT, "host", "include")):
        for dirpath, _, files in os.walk(base):
            for f in files:
                if f.endswith((".cpp", ".hpp", ".h", ".txt")):
                    newest = max(newest, os.path.getmtime(os.path.join(dirpath, f)))
    return newest


def _project_includes_tools():
    try:
        with open(os.path.join(ROOT, "CMakeLists.txt")) as f:
            return "tools/host" in f.read()
    except OSError:
        return False


def _build_dirs():
    top = os.environ.get("SMA_BUILD_DIR") or os.path.join(ROOT, "build")
    return top, os.path.join(top, "tools", "host"), os.path.join(top, "tools-host")


def _run(cmd):
    print("sma: " + " ".join(cmd), file=sys.stderr)
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        raise BuildError("build failed: %s\n%s" % (" ".join(cmd), r.stdout[-4000:]))


def build(force=False, targets=TOOLS):
    """Builds the helpers; returns the directory of the project build (helpers in its
    tools/host, tools/discrepancy) or of the stand-alone build of tools/host."""
    top, sub, alone = _build_dirs()
    if _project_includes_tools():
        if force or not os.path.exists(os.path.join(top, "CMakeCache.txt")):
            _run(["cmake", "-S", ROOT, "-B", top])
        _run(["cmake", "--build", top, "--target", *targets, "-j", "1"])
        return top
    if any(t not in TOOLS for t in targets):
        raise BuildError("%s is built by the project build only: add_subdirectory(tools/host) and "
                         "tools/discrepancy to the top-level CMakeLists.txt" % ", ".join(targets))
    if force or not os.path.exists(os.path.join(alone, "CMakeCache.txt")):
        _run(["cmake", "-S", os.path.join(ROOT, "tools", "host"), "-B", alone, "-DCMAKE_BUILD_TYPE=Release"])
    _run(["cmake", "--build", alone, "--target", *targets, "-j", "1"])
    return alone


def tool(name):
    """Path of an up-to-date helper binary, building it if needed."""
    env = os.environ.get(name.upper())
    if env:
        if not os.path.isfile(env):
            raise BuildError("$%s=%s does not exist" % (name.upper(), env))
        return env
    top, _, alone = _build_dirs()
    in_project = os.path.join(top, SUBDIR[name], name)
    candidates = [p for p in (in_project, os.path.join(alone, name)) if os.path.isfile(p)]
    src = _newest_source()
    fresh = [c for c in candidates if os.path.getmtime(c) >= src]
    if fresh:
        return fresh[0]
    targets = TOOLS if name in TOOLS else (name,)
    d = build(targets=targets)
    path = os.path.join(d, SUBDIR[name], name) if d == top else os.path.join(d, name)
    if not os.path.isfile(path):
        raise BuildError("built, but %s is missing" % path)
    return path
