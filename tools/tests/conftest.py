import os
import subprocess
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
TOOLS = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(TOOLS, "py"))

SMA = os.path.join(TOOLS, "sma")


@pytest.fixture(scope="session")
def binaries():
    """Paths of sma_sim / sma_fit (from CTest's environment, or built on first use); exported so
    that `tools/sma` run by the tests uses the same ones."""
    from sma import build

    paths = {name: build.tool(name) for name in ("sma_sim", "sma_fit")}
    os.environ["SMA_SIM"] = paths["sma_sim"]
    os.environ["SMA_FIT"] = paths["sma_fit"]
    os.environ.setdefault("MPLBACKEND", "Agg")
    return paths


def run_sma(*args, check=True):
    r = subprocess.run([sys.executable, SMA] + [str(a) for a in args], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True)
    if check and r.returncode != 0:
        raise AssertionError("sma %s failed (%d):\n%s\n%s" % (" ".join(map(str, args)), r.returncode, r.stdout, r.stderr))
    return r
