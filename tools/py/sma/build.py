"""Finds the C++ helpers (sma_sim, sma_fit, sma_metrics, sma_discrepancy, sma_params) or builds them with
CMake on first use.

Order: $SMA_SIM / $SMA_FIT / $SMA_METRICS / $SMA_DISCREPANCY / $SMA_PARAMS (set by CTest), then the project
build <root>/build (or $SMA_BUILD_DIR). A missing or stale binary is (re)built.
"""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
TOOLS = ("sma_sim", "sma_fit")
# Where each helper lives in the project build.
SUBDIR = {"sma_sim": "tools/host", "sma_fit": "tools/host", "sma_metrics": "tools/host",
          "sma_discrepancy": "tools/discrepancy", "sma_params": "tools/vrig"}


class BuildError(RuntimeError):
    pass


def _newest_source():
    newest = 0.0
    for base in (os.path.join(ROOT, "tools", "host"), os.path.join(ROOT, "tools", "discrepancy"),
                 os.path.join(ROOT, "tools", "vrig"),
                 os.path.join(ROOT, "lib", "sma_model", "include"), os.path.join(ROOT, "host", "include")):
        for dirpath, _, files in os.walk(base):
            for f in files:
                if f.endswith((".cpp", ".hpp", ".h", ".txt")):
                    newest = max(newest, os.path.getmtime(os.path.join(dirpath, f)))
    return newest


def _build_dir():
    return os.environ.get("SMA_BUILD_DIR") or os.path.join(ROOT, "build")


def _run(cmd):
    print("sma: " + " ".join(cmd), file=sys.stderr)
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        raise BuildError("build failed: %s\n%s" % (" ".join(cmd), r.stdout[-4000:]))


def build(force=False, targets=TOOLS):
    """Builds the helpers in the project build; returns its directory."""
    top = _build_dir()
    if force or not os.path.exists(os.path.join(top, "CMakeCache.txt")):
        _run(["cmake", "-S", ROOT, "-B", top, "-DCMAKE_BUILD_TYPE=Release"])
    _run(["cmake", "--build", top, "--target", *targets, "-j", str(os.cpu_count() or 1)])
    return top


def tool(name):
    """Path of an up-to-date helper binary, building it if needed."""
    env = os.environ.get(name.upper())
    if env:
        if not os.path.isfile(env):
            raise BuildError("$%s=%s does not exist" % (name.upper(), env))
        return env
    path = os.path.join(_build_dir(), SUBDIR[name], name)
    if os.path.isfile(path) and os.path.getmtime(path) >= _newest_source():
        return path
    build(targets=TOOLS if name in TOOLS else (name,))
    if not os.path.isfile(path):
        raise BuildError("built, but %s is missing" % path)
    return path
