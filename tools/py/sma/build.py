"""Finds the C++ helpers (sma_sim, sma_fit, sma_metrics, sma_discrepancy, sma_params, vrig) or
builds them with CMake on first use.

The model lives in C++ only (lib/sma_model); the Python side runs these helpers and never
re-implements a formula. Order of the search for helper NAME:
  1. $NAME in upper case ($SMA_FIT, ...; CTest sets them),
  2. the project build <root>/build (or $SMA_BUILD_DIR), rebuilt when older than the sources,
     where <root> is $SMA_ROOT, else the source tree this package was loaded from, else the
     current directory or one of its parents (a pip-installed `sma` run inside a clone),
  3. NAME on $PATH (installed helpers).
Anything else is a BuildError whose message says which of these to do.
"""
import os
import shutil
import subprocess
import sys

TOOLS = ("sma_sim", "sma_fit")
# Where each helper lives in the project build.
SUBDIR = {"sma_sim": "tools/host", "sma_fit": "tools/host", "sma_metrics": "tools/host",
          "sma_discrepancy": "tools/discrepancy", "sma_params": "tools/vrig", "vrig": "tools/vrig"}


class BuildError(RuntimeError):
    pass


def _is_root(path):
    return (os.path.isfile(os.path.join(path, "CMakeLists.txt"))
            and os.path.isdir(os.path.join(path, "lib", "sma_model", "include")))


def find_root():
    """The repository (source tree) or None."""
    env = os.environ.get("SMA_ROOT")
    if env:
        if not _is_root(env):
            raise BuildError("$SMA_ROOT=%s is not the project's source tree (no CMakeLists.txt "
                             "and lib/sma_model there)" % env)
        return os.path.abspath(env)
    here = os.path.dirname(os.path.abspath(__file__))
    src = os.path.dirname(os.path.dirname(os.path.dirname(here)))  # <root>/tools/py/sma
    if _is_root(src):
        return src
    d = os.getcwd()
    while True:
        if _is_root(d):
            return d
        parent = os.path.dirname(d)
        if parent == d:
            return None
        d = parent


ROOT = None  # resolved on first use (find_root), so that importing never fails


def root():
    global ROOT
    if ROOT is None:
        ROOT = find_root()
    return ROOT


def _newest_source(top):
    newest = 0.0
    for base in ("tools/host", "tools/discrepancy", "tools/vrig", "lib/sma_model/include", "host/include"):
        for dirpath, _, files in os.walk(os.path.join(top, base)):
            for f in files:
                if f.endswith((".cpp", ".hpp", ".h", ".txt")):
                    newest = max(newest, os.path.getmtime(os.path.join(dirpath, f)))
    return newest


def build_dir():
    env = os.environ.get("SMA_BUILD_DIR")
    if env:
        return env
    r = root()
    return os.path.join(r, "build") if r else None


def _run(cmd):
    print("sma: " + " ".join(cmd), file=sys.stderr)
    try:
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    except FileNotFoundError:
        raise BuildError("%s is not installed: it is needed to build the C++ helpers "
                         "(Debian: bash scripts/setup)" % cmd[0])
    if r.returncode != 0:
        raise BuildError("build failed: %s\n%s" % (" ".join(cmd), r.stdout[-4000:]))


def build(force=False, targets=TOOLS):
    """Builds the helpers in the project build; returns its directory."""
    top, src = build_dir(), root()
    if src is None:
        raise BuildError(_not_found_hint("the C++ helpers"))
    if force or not os.path.exists(os.path.join(top, "CMakeCache.txt")):
        _run(["cmake", "-S", src, "-B", top, "-DCMAKE_BUILD_TYPE=Release"])
    _run(["cmake", "--build", top, "--target", *targets, "-j", str(os.cpu_count() or 1)])
    return top


def _not_found_hint(what):
    return ("cannot find %s: run sma inside a clone of the repository (or set SMA_ROOT=/path/to/clone), "
            "or set $SMA_FIT, $SMA_SIM, ... to the binaries, or put them on PATH" % what)


def tool(name):
    """Path of an up-to-date helper binary, building it if needed."""
    env = os.environ.get(name.upper())
    if env:
        if not os.path.isfile(env):
            raise BuildError("$%s=%s does not exist" % (name.upper(), env))
        return env
    top = build_dir()
    if top is not None and root() is not None:
        path = os.path.join(top, SUBDIR[name], name)
        if os.path.isfile(path) and os.path.getmtime(path) >= _newest_source(root()):
            return path
        build(targets=TOOLS if name in TOOLS else (name,))
        if not os.path.isfile(path):
            raise BuildError("built, but %s is missing" % path)
        return path
    found = shutil.which(name)
    if found:
        return found
    raise BuildError(_not_found_hint("the C++ helper " + name))
